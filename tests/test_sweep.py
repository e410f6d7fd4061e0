"""The fast frequency sweep and the post-processing CLI."""

from __future__ import annotations

import csv
import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli import post as post_cli
from fishfsi.cli import run as run_cli
from fishfsi.cli import sweep as sweep_cli
from fishfsi.cli.fast_model import shell_with_fast_fluid
from fsi_orchestrator.case import CaseError, load_case
from fsi_orchestrator.case.schema import Waveform
from solid_adapter.build import (
    mean_voltage_equilibrium,
    rayleigh_coefficients,
    static_loads,
)
from solid_adapter.harmonic import (
    ModalSweep,
    harmonic_load,
    mean_voltage_tangent,
    periodic_response,
)
from solid_adapter.piezo import DriveSignal
from tests.conftest import strict_json

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases/beam_in_liquid"


def status(row: dict) -> str:
    """A row's status less the note a run shorter than one period carries (these tests run
    half periods)."""
    text = row["status"].replace("; shorter than one period", "")
    return text.replace(" (shorter than one period)", "")


def test_modal_superposition_matches_the_direct_frequency_response():
    """40 wet modes plus the (undamped) static correction against the direct solve of
    (K - w^2 M + i w C) X = F at 3 and 12 Hz (the beam in FC-3283), both about the
    mean-voltage equilibrium, C = alpha M + beta K with its tangent K."""
    case = load_case(CASE)
    model, _ = shell_with_fast_fluid(case)
    drive = DriveSignal.from_case(case)
    x_static = mean_voltage_equilibrium(case, model, drive, static_loads(case, model))
    tangent = mean_voltage_tangent(model, x_static, drive)
    alpha, beta = rayleigh_coefficients(case, model)
    sweep = ModalSweep.build(
        model, harmonic_load(model, drive, x_static), 40, (alpha, beta), stiffness=tangent
    )
    damping = alpha * model.inertia + beta * tangent
    for f in (3.0, 12.0):
        omega = 2 * np.pi * f
        direct = periodic_response(
            model,
            DriveSignal(
                frequency_hz=f,
                waveform=drive.waveform,
                left_volts=drive.left_volts,
                right_volts=drive.right_volts,
            ),
            x_static,
            damping,
            prestressed=True,
        ).harmonics[0][1]
        np.testing.assert_allclose(
            sweep.response(omega), direct, rtol=0, atol=1e-3 * np.abs(direct).max()
        )


def test_fsi_sweep_writes_the_table_and_fsi_post_draws_it(tmp_path, capsys):
    out = tmp_path / "sweep"
    args = [str(CASE), "--frequencies", "2,8,20", "--json", "--output", str(out)]
    assert sweep_cli.main(args) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [(r["waveform"], r["frequency_hz"]) for r in rows] == [
        (w, f) for w in ("sine", "square") for f in (2.0, 8.0, 20.0)
    ]
    assert len(list(csv.DictReader(open(out / "sweep.csv")))) == 6
    square_2hz = rows[3]["tip_amplitude_m"]
    assert square_2hz > rows[0]["tip_amplitude_m"]  # 4/pi more drive at the fundamental
    assert post_cli.main([str(out)]) == 0
    assert (out / "sweep.png").stat().st_size > 10_000


def test_the_sweep_table_has_unix_line_ends(tmp_path):
    """csv's default "\\r\\n" showed as ^M in a terminal, diff and awk."""
    sweep_cli.write_tables([{"waveform": "sine", "frequency_hz": 2.0, "status": "ok"}], tmp_path)
    assert (tmp_path / "sweep.csv").read_bytes() == b"waveform,frequency_hz,status\nsine,2.0,ok\n"


def test_a_failed_frequency_is_reported_and_the_others_kept(tmp_path, capsys, monkeypatch):
    """A run that fails (here: the 2nd of three) becomes a row with its error and no figures
    (null in strict JSON, an empty cell); the other runs' rows are written and the sweep exits
    with EXIT_FAILED."""
    from fishfsi.cli import run as run_cli
    from fishfsi.cli.common import EXIT_FAILED

    real = run_cli.run_dynamic

    def failing_at_8hz(case, output, **kwargs):
        if case.actuation.frequency_hz == 8.0:
            raise RuntimeError("pimpleFoam diverged in somewhere/openfoam\nlast lines ...")
        return real(case, output, **kwargs)

    monkeypatch.setattr(run_cli, "run_dynamic", failing_at_8hz)
    out = tmp_path / "sweep"
    args = [str(CASE), "--frequencies", "2,8,20", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.periods=0.5", "--set", "time.steps_per_period=8"]
    assert sweep_cli.main([*args, "--json", "--output", str(out)]) == EXIT_FAILED
    rows = strict_json(capsys.readouterr().out)["rows"]
    assert [status(r) for r in rows] == [
        "ok",
        "failed: pimpleFoam diverged in somewhere/openfoam",
        "ok",
    ]
    assert rows[1]["tip_amplitude_m"] is None
    assert strict_json((out / "sweep.json").read_text())[1]["tip_amplitude_m"] is None
    with open(out / "sweep.csv", newline="") as table:
        assert list(csv.DictReader(table))[1]["tip_amplitude_m"] == ""
    assert rows[0]["tip_amplitude_m"] > 0 and rows[2]["tip_amplitude_m"] > 0
    # an ok row holds no NaN: a figure the run did not give (half a period: no per-period
    # thrust, so no periodic thrust) is left out, an empty cell in sweep.csv
    for row in (rows[0], rows[2]):
        assert not [k for k, v in row.items() if v is None]
        assert "mean_thrust_periodic_n" not in row
    assert len(list(csv.DictReader(open(out / "sweep.csv")))) == 3


def test_a_point_started_from_rest_is_not_a_failure(tmp_path, capsys, monkeypatch):
    """A point that started from rest (near a wet resonance) is reported as such and the
    sweep still exits 0."""
    from fishfsi.cli import run as run_cli

    real = run_cli.run_dynamic

    def from_rest(case, output, **kwargs):
        return {**real(case, output, **kwargs), "start_from_rest": "note: started from rest"}

    monkeypatch.setattr(run_cli, "run_dynamic", from_rest)
    args = [str(CASE), "--frequencies", "8", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.periods=1", "--set", "time.steps_per_period=8"]
    assert sweep_cli.main([*args, "--json", "--output", str(tmp_path / "sweep")]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [status(r) for r in rows] == ["ok (started from rest)"]


@pytest.mark.slow
def test_a_point_whose_single_solve_windows_diverge_is_rerun_iterated(
    tmp_path, capsys, monkeypatch
):
    """One sweep spans the frequencies where one fluid solve per window is stable and those
    where it is not (explicit-am on the coarse fish above 15 Hz): a point whose coupling
    diverges is rerun with iterated windows, says so in its status, and a resumed sweep
    continues it iterated."""
    from fsi_orchestrator.case.schema import CouplingScheme
    from fsi_orchestrator.convergence import CouplingDivergenceError
    from fsi_orchestrator.loop import ResumeError
    from fsi_orchestrator.results import CHECKPOINT_FILE

    real = run_cli.run_dynamic
    schemes = []

    def unstable_at_8hz(case, output, **kwargs):
        c = case.coupling
        schemes.append((case.actuation.frequency_hz, c.scheme, c.explicit_periods))
        if case.actuation.frequency_hz == 8.0 and not c.scheme.iterates:
            if kwargs["resume"]:
                raise ResumeError("the case changed")
            real(case, output, **kwargs)  # its windows and checkpoint, then the divergence
            raise CouplingDivergenceError(
                "the interface force flipped sign", field="force", window=7, iteration=1
            )
        if case.actuation.frequency_hz == 8.0:  # the rerun never continues the explicit run
            assert not (output / CHECKPOINT_FILE).exists() or kwargs["resume"]
        return real(case, output, **kwargs)

    monkeypatch.setattr(run_cli, "run_dynamic", unstable_at_8hz)
    out = tmp_path / "sweep"
    args = [str(CASE), "--frequencies", "2,8", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.periods=0.5", "--set", "time.steps_per_period=8"]
    args += ["--set", "coupling.partitioned=true", "--set", "coupling.scheme=explicit-am"]
    assert sweep_cli.main([*args, "--json", "--output", str(out)]) == 0
    captured = capsys.readouterr()
    rows = json.loads(captured.out)["rows"]
    assert [status(r) for r in rows] == ["ok", "ok (iterated windows)"]
    assert np.isfinite(rows[1]["tip_amplitude_m"])
    explicit, iqn = CouplingScheme.EXPLICIT_AM, CouplingScheme.IQN_ILS_AM
    assert schemes == [(2.0, explicit, 0), (8.0, explicit, 0), (8.0, iqn, 0)]
    assert "sine 8 Hz: coupling diverged" in captured.err
    assert "again with iterated windows" in captured.err
    assert (out / "sine_8Hz" / sweep_cli.ITERATED_MARK).is_file()
    # killed after the rerun: --resume continues that point iterated, not explicit again
    (out / "sweep_rows" / "sine_8Hz.json").unlink()
    schemes.clear()
    assert sweep_cli.main([*args, "--json", "--output", str(out), "--resume"]) == 0
    assert schemes == [(8.0, iqn, 0)]
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [status(r) for r in rows] == ["ok", "ok (iterated windows)"]
    # killed in its explicit run: a checkpoint it cannot continue is run afresh, and when that
    # diverges it is rerun iterated all the same
    (out / "sweep_rows" / "sine_8Hz.json").unlink()
    (out / "sine_8Hz" / sweep_cli.ITERATED_MARK).unlink()
    assert (out / "sine_8Hz" / CHECKPOINT_FILE).is_file()
    schemes.clear()
    assert sweep_cli.main([*args, "--json", "--output", str(out), "--resume"]) == 0
    assert schemes == [(8.0, explicit, 0), (8.0, explicit, 0), (8.0, iqn, 0)]
    assert status(json.loads(capsys.readouterr().out)["rows"][1]) == "ok (iterated windows)"


@pytest.mark.slow
def test_a_diverging_point_is_rerun_with_fewer_windows_before_iterating(
    tmp_path, capsys, monkeypatch
):
    """Longer windows steady one solve per window (explicit-am at 15-25 Hz): a point whose
    windows diverge is rerun with each of coupling.explicit_fallback_windows below its own
    count in turn; its row names the count; a higher frequency starts at that count; --resume
    continues the rerun it was on; where every count diverges, the windows are iterated at
    the point's own count."""
    from fsi_orchestrator.case.schema import CouplingScheme
    from fsi_orchestrator.convergence import CouplingDivergenceError

    real = run_cli.run_dynamic
    runs = []
    stable_below = {"8": 6}  # windows per period that run, by frequency

    def unstable(case, output, **kwargs):
        c, n = case.coupling, case.time.steps_per_period
        runs.append((case.actuation.frequency_hz, c.scheme, n, kwargs["resume"]))
        limit = stable_below.get(f"{case.actuation.frequency_hz:g}", 100)
        if not c.scheme.iterates and n > limit:
            real(case, output, **kwargs)
            raise CouplingDivergenceError(
                "the interface force flipped sign", field="force", window=3, iteration=1
            )
        return real(case, output, **kwargs)

    monkeypatch.setattr(run_cli, "run_dynamic", unstable)
    out = tmp_path / "sweep"
    args = [str(CASE), "--frequencies", "2,8,9", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.periods=0.5", "--set", "time.steps_per_period=10"]
    args += ["--set", "coupling.partitioned=true", "--set", "coupling.scheme=explicit-am"]
    args += ["--set", "coupling.explicit_fallback_windows=[12, 8, 6]"]
    assert sweep_cli.main([*args, "--json", "--output", str(out)]) == 0
    captured = capsys.readouterr()
    rows = json.loads(captured.out)["rows"]
    assert [status(r) for r in rows] == ["ok", *["ok (6 windows per period)"] * 2]
    assert [r["windows_per_period"] for r in rows] == [10, 6, 6]
    explicit, iqn = CouplingScheme.EXPLICIT_AM, CouplingScheme.IQN_ILS_AM
    assert runs == [(2.0, explicit, 10, False), (8.0, explicit, 10, False)] + [
        (8.0, explicit, 8, False),
        (8.0, explicit, 6, False),
        (9.0, explicit, 6, False),  # 9 Hz would run at 10 here; it starts where 8 Hz ran
    ]
    assert "again with 8 windows per period" in captured.err
    assert (out / "sine_8Hz" / sweep_cli.WINDOWS_MARK).read_text().startswith("6\n")
    # killed in its rerun (and the next point, started at that count): --resume continues
    # each checkpoint at its count
    (out / "sweep_rows" / "sine_8Hz.json").unlink()
    (out / "sweep_rows" / "sine_9Hz.json").unlink()
    runs.clear()
    assert sweep_cli.main([*args, "--json", "--output", str(out), "--resume"]) == 0
    assert runs == [(8.0, explicit, 6, True), (9.0, explicit, 6, True)]
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [status(r) for r in rows[1:]] == ["ok (6 windows per period)"] * 2
    # a new launch (another rank, a resumed sweep) learns the count from the finished rows:
    # 9 Hz, lost with its folder, starts where 8 Hz's row says that point ran
    (out / "sweep_rows" / "sine_9Hz.json").unlink()
    shutil.rmtree(out / "sine_9Hz")
    runs.clear()
    assert sweep_cli.main([*args, "--json", "--output", str(out), "--resume"]) == 0
    assert runs == [(9.0, explicit, 6, False)]
    capsys.readouterr()
    # every count diverges: iterated at the point's own count
    stable_below["8"] = 4
    assert sweep_cli.main([*args, "--json", "--output", str(out), "--overwrite"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert status(rows[1]) == "ok (iterated windows)"
    assert [(r[1], r[2]) for r in runs if r[0] == 8.0][-4:] == [
        (explicit, 10),
        (explicit, 8),
        (explicit, 6),
        (iqn, 10),
    ]


def test_a_point_started_on_an_earlier_sweeps_orbit_starts_at_the_windows_it_ran_with(
    tmp_path, capsys, monkeypatch
):
    """--start-from: a point whose source needed fewer windows (the coarse level's stable
    count for that drive) starts at that count, where trying its own would diverge first (the
    default level's 19-21 Hz from the coarse sweep); a point whose source ran at its own count
    keeps it. Where the windows diverge from the orbit at that count (the default level's
    23 Hz), the point runs from its usual start there before its windows are iterated.
    --resume continues each at the count and start it was on."""
    from fsi_orchestrator.convergence import CouplingDivergenceError

    real = run_cli.run_dynamic
    runs = []
    stable_below = {"8": 6}  # windows per period that run, by frequency
    unstable_from_the_orbit = set()  # frequencies whose windows diverge from the orbit

    def unstable(case, output, **kwargs):
        n, started, f = (
            case.time.steps_per_period,
            bool(case.time.start_from),
            f"{case.actuation.frequency_hz:g}",
        )
        runs.append((case.actuation.frequency_hz, n, started, kwargs["resume"]))
        out = real(case, output, **kwargs)
        if n > stable_below.get(f, 100) or (started and f in unstable_from_the_orbit):
            raise CouplingDivergenceError("force grew", field="force", window=3, iteration=1)
        return out

    monkeypatch.setattr(run_cli, "run_dynamic", unstable)
    args = [str(CASE), "--frequencies", "2,8", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.periods=1", "--set", "time.steps_per_period=10", "--quiet"]
    args += ["--set", "coupling.partitioned=true", "--set", "coupling.scheme=explicit-am"]
    args += ["--set", "coupling.explicit_fallback_windows=[8, 6]", "--json"]
    assert sweep_cli.main([*args, "--output", str(tmp_path / "a")]) == 0
    capsys.readouterr()
    assert [r[:2] for r in runs] == [(2.0, 10), (8.0, 10), (8.0, 8), (8.0, 6)]
    started = [*args, "--start-from", str(tmp_path / "a"), "--output", str(tmp_path / "b")]
    runs.clear()
    assert sweep_cli.main(started) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert runs == [(2.0, 10, True, False), (8.0, 6, True, False)]
    assert [status(r) for r in rows] == ["ok", "ok (6 windows per period)"]
    assert [r["windows_per_period"] for r in rows] == [10, 6]
    # killed in its run: --resume continues the checkpoint at the count it started with
    (tmp_path / "b" / "sweep_rows" / "sine_8Hz.json").unlink()
    runs.clear()
    assert sweep_cli.main([*started, "--resume"]) == 0
    assert runs == [(8.0, 6, True, True)]
    capsys.readouterr()
    # diverging from the orbit: the usual start at that count
    unstable_from_the_orbit.add("8")
    runs.clear()
    assert sweep_cli.main([*started, "--overwrite"]) == 0
    captured = capsys.readouterr()
    assert runs == [(2.0, 10, True, False), (8.0, 6, True, False), (8.0, 6, False, False)]
    assert "running the point again with its usual start" in captured.err
    second = status(json.loads(captured.out)["rows"][1])
    assert second == "ok (6 windows per period; its start on the earlier orbit diverged)"
    (tmp_path / "b" / "sweep_rows" / "sine_8Hz.json").unlink()
    runs.clear()
    assert sweep_cli.main([*started, "--resume"]) == 0
    assert runs == [(8.0, 6, False, True)]
    # a source that ran its own case's fewer windows (no fallback) sets no count
    two = [a if a != "2,8" else "2" for a in args]
    assert (
        sweep_cli.main([*two, "--set", "time.steps_per_period=8", "--output", str(tmp_path / "c")])
        == 0
    )
    runs.clear()
    assert (
        sweep_cli.main([*two, "--start-from", str(tmp_path / "c"), "--output", str(tmp_path / "d")])
        == 0
    )
    assert runs == [(2.0, 10, True, False)]


def test_a_mesh_folded_by_a_steady_swing_is_not_rerun(tmp_path, capsys, monkeypatch):
    """A fold after whole periods of a swing that stopped growing is the motion's own (the
    default level's 1 Hz point): fewer or iterated windows would move the plate the same way,
    so the point fails at once with one line. A fold within the first period (a growing
    explicit instability) is rerun as before."""
    from fluid_adapter.openfoam.errors import MeshFoldedError

    real = run_cli.run_dynamic
    runs = []

    def folding(case, output, **kwargs):
        runs.append((case.coupling.scheme, case.time.steps_per_period))
        real(case, output, **kwargs)
        raise MeshFoldedError("t=0.3: 2 faces inside out at x = 163 mm")

    monkeypatch.setattr(run_cli, "run_dynamic", folding)
    args = [str(CASE), "--frequencies", "2", "--waveforms", "sine", "--method", "transient"]
    args += ["--set", "time.steps_per_period=10", "--set", "coupling.partitioned=true"]
    args += ["--set", "coupling.scheme=explicit-am"]
    args += ["--set", "coupling.explicit_fallback_windows=[8]"]
    out = tmp_path / "steady"
    assert sweep_cli.main([*args, "--set", "time.periods=2", "--json", "--output", str(out)]) == 1
    row = json.loads(capsys.readouterr().out)["rows"][0]
    assert len(runs) == 1
    assert row["status"].startswith("failed: t=0.3: 2 faces inside out")
    assert "after 2 whole periods of a steady" in row["status"]
    assert "not rerun" in row["status"]
    runs.clear()
    out = tmp_path / "early"
    assert sweep_cli.main([*args, "--set", "time.periods=0.5", "--json", "--output", str(out)]) == 1
    capsys.readouterr()
    assert [n for _, n in runs] == [10, 8, 10]  # fewer windows, then iterated


def test_only_cases_with_single_solve_windows_have_an_iterated_rerun():
    from fsi_orchestrator.case.schema import CouplingScheme

    case = load_case(CASE)  # potential flow, monolithic: nothing to iterate
    assert sweep_cli.with_iterated_windows(case) is None
    partitioned = load_case(CASE, ["coupling.partitioned=true", "coupling.scheme=iqn-ils-am"])
    assert sweep_cli.with_iterated_windows(partitioned) is None
    started = load_case(
        CASE,
        ["coupling.partitioned=true", "coupling.scheme=iqn-ils-am", "coupling.explicit_periods=1"],
    )
    rerun = sweep_cli.with_iterated_windows(started)
    assert (rerun.coupling.scheme, rerun.coupling.explicit_periods) == (
        CouplingScheme.IQN_ILS_AM,
        0,
    )
    plain = load_case(CASE, ["coupling.partitioned=true", "coupling.scheme=explicit"])
    assert sweep_cli.with_iterated_windows(plain).coupling.scheme is CouplingScheme.IQN_ILS_AM
    # reruns with fewer windows: one-solve schemes only, counts below the case's own
    forty = load_case(
        CASE, ["coupling.partitioned=true", "coupling.scheme=explicit", "time.steps_per_period=40"]
    )
    assert [c.time.steps_per_period for c in sweep_cli.with_fewer_windows(forty)] == [30, 20]
    for iterating in (case, partitioned, started):
        assert sweep_cli.with_fewer_windows(iterating) == []
    short = load_case(
        CASE,
        ["coupling.partitioned=true", "coupling.scheme=explicit-am", "time.steps_per_period=24"],
    )
    assert [c.time.steps_per_period for c in sweep_cli.with_fewer_windows(short)] == [20]
    # longest windows first, each once; sines only (measured with sines)
    mixed = load_case(
        CASE,
        ["coupling.partitioned=true", "coupling.scheme=explicit-am", "time.steps_per_period=40"]
        + ["coupling.explicit_fallback_windows=[20, 30, 20, 25]"],
    )
    assert [c.time.steps_per_period for c in sweep_cli.with_fewer_windows(mixed)] == [30, 25, 20]
    square = dataclasses.replace(
        mixed, actuation=dataclasses.replace(mixed.actuation, waveform=Waveform.SQUARE)
    )
    assert sweep_cli.with_fewer_windows(square) == []


@pytest.mark.parametrize("text, expected", [("1:5:2", [1.0, 3.0, 5.0]), ("3,10", [3.0, 10.0])])
def test_frequency_lists(text, expected):
    assert sweep_cli.parse_frequencies(text) == pytest.approx(expected)


def test_a_fractional_step_gives_the_frequencies_as_written():
    """np.arange's float noise (1.2000000000000002) would go into the point names, the CSV
    and the JSON."""
    got = sweep_cli.parse_frequencies("1:2:0.1")
    assert [repr(f) for f in got] == [repr(round(1 + 0.1 * k, 1)) for k in range(11)]


@pytest.mark.parametrize("text", ["0,3", "3,-1", "1:5:0", "1:5:-1", "nan", "3;5"])
def test_a_bad_frequency_list_is_refused_in_one_line(text):
    with pytest.raises(CaseError, match=r"--frequencies .*: use start:stop:step or a,b,c"):
        sweep_cli.parse_frequencies(text)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("3,3", "3 Hz is given twice"),
        ("24.748743466977366,24.7487", "24.7487 Hz is given as 24.748743466977366 and 24.7487"),
        ("1:2:0.0000001", "more than 1000 points in one sweep (check the step)"),
    ],
)
def test_frequencies_that_name_one_point_twice_or_too_many_are_refused(text, expected):
    """A point's folder and row are named by its frequency to 6 digits: two such frequencies
    would share them (the table printed 2 rows, sweep.csv kept 1)."""
    with pytest.raises(CaseError, match=re.escape(f"--frequencies {text!r}: {expected}")):
        sweep_cli.parse_frequencies(text)


def test_frequencies_are_plain_floats():
    assert all(type(f) is float for f in sweep_cli.parse_frequencies("1:25:2"))


@pytest.mark.parametrize(
    "case, argv, expected",
    [
        ("cases/seed/beam_sweep", ["--waveforms", "sine,sine"], "a waveform is given twice"),
        ("cases/rectangle_tip_force", [], 'geometry.kind = "rectangle" carries no actuators'),
    ],
)
def test_a_sweep_of_nothing_new_is_refused_in_one_line(tmp_path, capsys, case, argv, expected):
    args = [str(ROOT / case), "--frequencies", "3", "--output", str(tmp_path / "s"), *argv]
    assert sweep_cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and expected in err
    assert not (tmp_path / "s" / "sweep.csv").exists()


@pytest.mark.parametrize("flag", [[], ["--overwrite"], ["--resume"]])
def test_a_sweep_into_a_runs_folder_is_refused(tmp_path, capsys, flag):
    """sweep.csv beside a run's results.h5 hid the run from fsi-post."""
    (tmp_path / "results.h5").write_text("a run")
    args = [str(ROOT / "cases/seed/beam_sweep"), "--frequencies", "3", "--waveforms", "sine"]
    assert sweep_cli.main([*args, "--output", str(tmp_path), *flag]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        err == f"error: --output {tmp_path}: holds a run of fsi-run (results.h5); sweep into "
        "another folder"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.h5"]


def test_the_linear_sweep_oscillates_about_the_mean_voltage_equilibrium(tmp_path):
    """The MFCs' mean voltage (500 V) expands the active area against the plate around it;
    that prestress changes the bending stiffness. The free original fish in potential flow at
    3 Hz: the linear sweep about the prestressed equilibrium swings the tail as far as the
    nonlinear transient (6.15 against 6.2 mm); about the unloaded plate it gave 7.22 mm."""
    case = load_case(
        ROOT / "cases/fixed_head_3Hz",
        [
            "fluid.model=potential",
            "boundary.head=free",
            "material.cfrp=acoustic",
            "time.periods=1",
            "output.vtk=false",
        ],
    )
    (row,) = sweep_cli.linear_sweep(case, [3.0], [Waveform.SINE])
    transient = run_cli.run_dynamic(case, tmp_path / "run", resume=False, show_progress=False)
    assert row["tip_amplitude_m"] == pytest.approx(transient["tip_amplitude_m"], rel=0.02)
    assert row["tip_amplitude_m"] < 0.9 * 7.22e-3


def test_each_transient_point_starts_from_the_jacobian_the_last_one_learned(tmp_path, monkeypatch):
    """fsi-sweep --method transient with OpenFOAM and iqn-ils-am: every point after the first
    takes coupling.jacobian_from = the previous point's output (fewer fluid solves, same result
    to the tolerance: docs/coupling.md), unless the case names its own; a failed point passes
    nothing on. (The runs are stubbed: the wiring is checked here, the warm start itself in
    tests/test_openfoam_coupled.py.)"""
    seen = []

    def stub(case, output, **kwargs):
        seen.append(case.coupling.jacobian_from)
        if case.actuation.frequency_hz == 4.0:
            raise RuntimeError("pimpleFoam crashed")
        output.mkdir(parents=True, exist_ok=True)  # the sweep's lock is in it already
        (output / "checkpoint.h5").write_bytes(b"")
        return {"tip_amplitude_m": 1e-3, "mean_thrust_n": 1e-3}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    case = load_case(ROOT / "cases/fixed_head_3Hz")
    sweep_cli.transient_sweep(case, [3.0, 4.0, 5.0, 6.0], [Waveform.SINE], tmp_path)
    first = str((tmp_path / "sine_3Hz").resolve())
    assert seen == ["", first, first, str((tmp_path / "sine_5Hz").resolve())]
    own = load_case(ROOT / "cases/fixed_head_3Hz", ["coupling.jacobian_from=/elsewhere"])
    assert sweep_cli.chained(own, tmp_path / "sine_3Hz") is own
    potential = load_case(ROOT / "cases/fixed_head_3Hz", ["fluid.model=potential"])
    assert sweep_cli.chained(potential, tmp_path / "sine_3Hz") is potential


@pytest.mark.parametrize("name, text", [("sweep.csv", "a,b\n1,2\n"), ("results.h5", "x\n")])
def test_fsi_post_refuses_a_file_it_did_not_write_in_one_line(tmp_path, capsys, name, text):
    (tmp_path / name).write_text(text)
    assert post_cli.main([str(tmp_path / name)]) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and line.startswith(f"error: {tmp_path / name}: not a table")


def test_a_linear_sweep_in_vacuum_pushes_nothing_and_says_when_it_leaves_small_deflections(
    tmp_path, capsys
):
    """The seed's beam in air at its 25 Hz resonance: no thrust column (nothing to push), and
    a tip amplitude past a fifth of the 87 mm strip gets a note (the linear model's range)."""
    args = [str(ROOT / "cases/seed/beam_sweep"), "--frequencies", "10,25", "--waveforms", "sine"]
    assert sweep_cli.main([*args, "--json", "--quiet", "--output", str(tmp_path)]) == 0
    out = capsys.readouterr()
    rows = strict_json(out.out)["rows"]
    assert all("slender_body_mean_thrust_n" not in r for r in rows)
    assert rows[0]["tip_amplitude_m"] < 0.2 * 0.087 < rows[1]["tip_amplitude_m"]
    notes = [line for line in out.err.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "exceeds a fifth of the plate's 87 mm at 1 point(s)" in notes[0]


def test_the_fast_models_keys_are_not_part_of_an_openfoam_sweeps_identity():
    """A transient OpenFOAM sweep's rows hold the CFD's answer: KC0 of the fast thrust and
    the edge inertia are not in its identity, so a sweep made before the keys resumes; a
    linear sweep's rows carry them."""
    case = load_case(ROOT / "cases" / "fixed_head_3Hz")
    openfoam = sweep_cli.sweep_identity(case, "transient")["case"]["fluid"]
    assert openfoam["model"] == "openfoam"
    linear = sweep_cli.sweep_identity(case, "linear")["case"]["fluid"]
    for key, value in (
        ("thrust_shedding_kc", 0.61),
        ("edge_inertia", True),
        ("edge_inertia_gamma", 1.17),
    ):
        assert key not in openfoam and linear[key] == value, key


def test_a_run_whose_lead_in_diverges_runs_again_from_rest_and_resumes_so(
    tmp_path, capsys, monkeypatch
):
    """The CFD blew up in the lead-in on the fast orbit (the hinged thrust rig at 3 Hz:
    undamped, the orbit swings 27 mm where the coupled run swings 12 mm): the run starts
    again from rest with a one-period voltage ramp and two more periods, says so in one note
    and in its summary (a sweep's row: "started from rest"), and a --resume continues that
    run, not the lead-in's."""
    from fishfsi.cli import run as run_cli
    from fluid_adapter.openfoam.errors import LeadInDivergenceError

    calls, orbit_diverges = [], [True]

    def fake(case, output, resume, show_progress, overrides=(), replaces_run=False):
        calls.append((case.actuation.ramp_periods, case.time.periods, resume))
        if case.actuation.ramp_periods == 0 and orbit_diverges[0]:
            raise LeadInDivergenceError(
                "pimpleFoam diverged in X: floating point exception (NaN); reduce the time "
                "step It diverged in the lead-in\nlog lines"
            )
        return {"tip_amplitude_m": 0.01}

    monkeypatch.setattr(run_cli, "_run_dynamic", fake)
    case = load_case(ROOT / "cases/seed/thrust_rig", ["actuation.frequency_hz=3"])
    out = tmp_path / "run"
    out.mkdir()
    summary = run_cli.run_dynamic(case, out, resume=False, show_progress=False)
    assert calls == [(0.0, 2.0, False), (1.0, 4.0, False)]
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "lead-in" in err
    assert "floating point exception (NaN)" in err and "4 periods in all (2 asked for)" in err
    assert summary["start_from_rest"] == err.strip()
    calls.clear()
    resumed = run_cli.run_dynamic(case, out, resume=True, show_progress=False)
    assert calls == [(1.0, 4.0, True)] and resumed["start_from_rest"] == err.strip()
    assert (out / run_cli.FROM_REST_MARK).is_file()
    calls.clear()
    orbit_diverges[0] = False  # a fresh run tries the orbit again
    fresh = run_cli.run_dynamic(case, out, resume=False, show_progress=False)
    assert calls == [(0.0, 2.0, False)] and "start_from_rest" not in fresh
    assert not (out / run_cli.FROM_REST_MARK).exists()
