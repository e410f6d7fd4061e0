"""Structure-alone dynamic runs through fsi-run: summary contract, results file, resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path

import h5py
import numpy as np
import pytest

from fishfsi.cli import run as run_cli
from fsi_orchestrator.case import CaseError, load_case
from fsi_orchestrator.loop import AFRESH
from fsi_orchestrator.results import ResultsFile
from solid_adapter.build import run_static
from tests.conftest import PARTITIONED_BEAM

ROOT = Path(__file__).resolve().parents[1]

CASE = """
[geometry]
kind = "rectangle"
length_m = 1.0
width_m = 0.1
thickness_m = 0.01
[material]
youngs_modulus_pa = 1e9
poisson_ratio = 0.3
density_kg_m3 = 1000.0
[loads]
tip_force_n = 0.05
[analysis]
kind = "dynamic"
rho_infinity = 1.0
[time]
step_s = 0.02
end_time_s = {end}
[mesh]
elements_length = 4
elements_width = 1
[output]
vtk = {vtk}
checkpoint_every = 5
"""


def make(tmp_path: Path, end=0.8, vtk="true") -> Path:
    case = tmp_path / "case"
    case.mkdir()
    (case / "case.toml").write_text(CASE.format(end=end, vtk=vtk))
    return case


def test_dynamic_run_starts_at_rest_in_equilibrium(tmp_path, capsys):
    """A constant load: the run starts in the static equilibrium and stays there, so the
    history equals the static solution and the amplitude is zero."""
    case = make(tmp_path)
    assert run_cli.main([str(case), "--json", "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    static = run_static(load_case(case)).tip_displacement_m
    with h5py.File(summary["results"]) as h5:
        assert h5["time_s"].shape == (40, 1)
        tip = h5["shell/tip_displacement_m"][:]
    np.testing.assert_allclose(tip, np.broadcast_to(static, tip.shape), rtol=1e-8, atol=1e-14)
    assert summary["tip_amplitude_m"] == pytest.approx(0.0, abs=1e-8 * abs(static[2]))
    assert len(summary["tip_displacement_m"]) == 3
    assert (case / "output" / "vtk" / "shell.pvd").exists()


BEAM = """
[geometry]
kind = "beam"
[actuation]
frequency_hz = 10.0
[time]
periods = 4
steps_per_period = 20
[mesh]
level = "coarse"
[output]
vtk = false
checkpoint_every = 5
"""


def beam_case(folder: Path) -> Path:
    """A case folder holding the BEAM case."""
    folder.mkdir()
    (folder / "case.toml").write_text(BEAM)
    return folder


def test_killed_run_resumes_to_the_same_result(tmp_path):
    """kill -9 mid-run of the piezo-driven beam, then --resume: the same history as an
    uninterrupted run."""
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    ref_case, case = tmp_path / "a", tmp_path / "b"
    for folder in (ref_case, case):
        beam_case(folder)
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    subprocess.run([*cmd, str(ref_case)], check=True, capture_output=True, env=env)
    proc = subprocess.Popen(
        [*cmd, str(case)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    checkpoint = case / "output" / "checkpoint.h5"
    deadline = time.time() + 60
    while not checkpoint.exists() and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with h5py.File(case / "output" / "results.h5") as h5:
        written = h5["time_s"].shape[0]
    assert 0 < written < 80, "the run should have been killed mid-way"
    done = subprocess.run([*cmd, "--resume", str(case)], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    with (
        h5py.File(ref_case / "output" / "results.h5") as a,
        h5py.File(case / "output" / "results.h5") as b,
    ):
        tip = a["shell/tip_displacement_m"][:]
        assert np.ptp(tip[:, 2]) > 1e-3  # a real dynamic response (mm at the beam tip)
        np.testing.assert_allclose(b["shell/tip_displacement_m"][:], tip, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(b["time_s"][:], a["time_s"][:])


def test_the_fluid_force_summary_reports_the_turning_load_of_the_last_period(tmp_path):
    """Unequal voltages on the two MFCs turn the fish (seed Sec. 4.5): the summary gives the
    last period's mean lateral force and yaw moment (about the vertical y axis through the
    nose) next to the thrust. A synthetic history: a mean lateral force of 0.2 N at x = 0.1 m
    plus a swing that averages out over the period."""
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", ["time.steps_per_period=8"])
    t = np.arange(24) / 24.0  # three periods of 8 windows
    swing = np.sin(2 * np.pi * 3 * t)
    force = np.column_stack([-0.01 + 0 * t, 0 * t, 0.2 + swing])
    nose_to_load = np.array([0.1, 0.0, 0.0])
    moment = np.cross(nose_to_load, force)
    path = tmp_path / "results.h5"
    with h5py.File(path, "w") as h5:
        h5["fluid/thrust_n"] = -force[:, :1]
        h5["fluid/force_n"] = force
        h5["fluid/moment_nm"] = moment
    summary = run_cli.fluid_force_summary(case, path)
    assert summary["mean_thrust_n"] == pytest.approx(0.01)
    assert summary["mean_lateral_force_n"] == pytest.approx(0.2)
    assert summary["mean_yaw_moment_nm"] == pytest.approx(-0.1 * 0.2)  # M_y = z F_x - x F_z
    assert summary["lateral_force_amplitude_n"] == pytest.approx(1.0, rel=0.01)


def test_the_summary_says_when_the_last_period_is_not_periodic_yet(tmp_path, capsys):
    """Per-period tail amplitudes (exactly the half peak-to-peak of each period in
    results.h5) and their change over the last period; a run that started on its periodic
    orbit is periodic (change < 1 %, no note), one started from rest is not, and stderr says so."""
    case = beam_case(tmp_path / "beam")
    assert run_cli.main([str(case), "--json", "--quiet", "--output", str(tmp_path / "p")]) == 0
    out = capsys.readouterr()
    periodic = json.loads(out.out)
    assert len(periodic["tip_amplitude_per_period_m"]) == 4
    assert abs(periodic["tip_amplitude_change_last_period"]) < 0.01
    assert "not periodic yet" not in out.err

    args = [str(case), "--json", "--quiet", "--set", "time.start=rest"]
    assert run_cli.main([*args, "--output", str(tmp_path / "r")]) == 0
    out = capsys.readouterr()
    rest = json.loads(out.out)
    with h5py.File(rest["results"]) as h5:
        z = h5["shell/tip_displacement_m"][:, 2]
    expected = [np.ptp(z[k : k + 20]) / 2 for k in range(0, 80, 20)]
    np.testing.assert_allclose(rest["tip_amplitude_per_period_m"], expected, rtol=1e-12)
    change = (expected[3] - expected[2]) / expected[3]
    assert rest["tip_amplitude_change_last_period"] == pytest.approx(change, rel=1e-12)
    assert abs(change) > 0.01
    assert f"tail amplitude changed by {100 * change:+.1f} %" in out.err


def test_a_run_ends_once_periodic_and_a_resume_with_a_tighter_tolerance_goes_on(tmp_path, capsys):
    """time.periodic_tolerance: the beam started on its periodic orbit changes by < 1 % per
    period, so at 1 % the run ends after three periods (the first with two changes to
    compare), each recorded window the full run's; resumed with a tolerance it cannot meet it
    goes on to time.periods and equals the uninterrupted run. Started at rest (changes of
    several %), it runs all four periods."""
    case = beam_case(tmp_path / "beam")
    run = [str(case), "--json", "--quiet"]
    assert run_cli.main([*run, "--output", str(tmp_path / "full")]) == 0
    full = json.loads(capsys.readouterr().out)
    a = full["tip_amplitude_per_period_m"]
    changes = [abs(y - x) / y for x, y in pairwise(a)]
    assert max(changes[:2]) < 0.01

    short = [*run, "--output", str(tmp_path / "short"), "--set", "time.periodic_tolerance=0.01"]
    assert run_cli.main(short) == 0
    out = capsys.readouterr()
    stopped = json.loads(out.out)
    assert stopped["windows"] == 60
    assert stopped["stopped_periodic"].startswith("periodic after 3 periods")
    assert "note: periodic after 3 periods" in out.err
    np.testing.assert_array_equal(stopped["tip_amplitude_per_period_m"], a[:3])

    # resumed as it was: it stays ended
    assert run_cli.main([*short, "--resume"]) == 0
    assert json.loads(capsys.readouterr().out)["windows"] == 60
    tighter = [*short[:-1], "time.periodic_tolerance=1e-12", "--resume"]
    assert run_cli.main(tighter) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert resumed["windows"] == 80 and "stopped_periodic" not in resumed
    with h5py.File(full["results"]) as f, h5py.File(resumed["results"]) as g:
        np.testing.assert_allclose(
            g["shell/tip_displacement_m"][:], f["shell/tip_displacement_m"][:], rtol=0, atol=1e-12
        )

    rest = [*run, "--output", str(tmp_path / "rest"), "--set", "time.start=rest"]
    assert run_cli.main([*rest, "--set", "time.periodic_tolerance=0.01"]) == 0
    assert json.loads(capsys.readouterr().out)["windows"] == 80


def test_a_periodic_tolerance_without_periods_is_refused(tmp_path):
    case = beam_case(tmp_path / "beam")
    sets = ["time.step_s=0.001", "time.end_time_s=0.01", "time.periodic_tolerance=0.01"]
    with pytest.raises(CaseError, match="time.periodic_tolerance counts periods of the drive"):
        load_case(case, sets)


def test_a_run_does_not_end_as_periodic_during_its_explicit_start_up(tmp_path):
    """With coupling.explicit_periods = 3 the periodic stop waits for an iterated period: a
    synthetic history that repeats exactly (changes 0) ends the run after period 4, not 3."""
    sets = [
        "coupling.explicit_periods=3",
        "time.periods=6",
        "time.steps_per_period=8",
        "time.periodic_tolerance=0.01",
    ]
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", sets)
    rule = run_cli.periodic_stop(case)
    t = np.arange(48) / 24.0
    results = ResultsFile(tmp_path / "results.h5")
    said = []
    for k in range(48):
        tip = [0.0, 0.0, 0.008 * np.sin(2 * np.pi * 3 * t[k])]
        results.append({"shell/tip_displacement_m": tip, "fluid/thrust_n": 0.013})
        said.append(rule(results))
    results.close()
    ended = [k + 1 for k, why in enumerate(said) if why is not None]
    assert ended[0] == 32
    assert said[31].startswith("periodic after 4 periods (time.periodic_tolerance = 0.01)")


ADAPTIVE_BEAM = PARTITIONED_BEAM.replace(
    "periods = 1\nsteps_per_period = 20",
    "periods = 12\nsteps_per_period = 10\nperiodic_tolerance = 0.01",
).replace("partitioned = true", "partitioned = true\nexplicit_until_periodic = true")


def test_explicit_windows_until_periodic_then_iterated_ones_and_a_resume_keeps_the_switch(
    tmp_path,
):
    """coupling.explicit_until_periodic: one solve per window until the periods agree to
    EXPLICIT_SWITCH_TOLERANCE twice in a row, then iterated windows until they agree to
    time.periodic_tolerance. The beam in the liquid starts on its linear orbit: periodic in its
    explicit windows after 3 periods (the first that can tell), iterated in period 4, and
    periodic then. A run stopped at the switch and resumed goes on iterating from there."""
    case = tmp_path / "beam"
    case.mkdir()
    (case / "case.toml").write_text(ADAPTIVE_BEAM)
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--json", str(case)]

    def run(output: str, *extra: str) -> tuple[dict, str, np.ndarray, np.ndarray]:
        done = subprocess.run(
            [*cmd, "--output", str(tmp_path / output), *extra], capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr[-2000:]
        with h5py.File(tmp_path / output / "results.h5") as h5:
            iterated = h5["coupling/iterated"][:, 0]
            tip = h5["shell/tip_displacement_m"][:, 2]
        return json.loads(done.stdout), done.stderr, iterated, tip

    summary, said, iterated, tip = run("whole")
    np.testing.assert_array_equal(iterated, [0] * 30 + [1] * 10)
    assert "periodic in its explicit windows after 3 periods" in said
    assert "iterating from window 31 (coupling.explicit_until_periodic)" in said
    assert summary["stopped_periodic"].startswith("periodic after 4 periods")
    assert summary["explicit_windows"] == 30
    _, said, first, _ = run("split", "--set", "time.periods=3")  # ends at the switch
    np.testing.assert_array_equal(first, [0] * 30)
    assert "note: coupling.explicit_until_periodic: every window took one fluid solve" in said
    again, said, resumed, resumed_tip = run("split", "--resume")
    assert "periodic in its explicit windows" not in said  # the checkpoint kept the switch
    np.testing.assert_array_equal(resumed, iterated)
    np.testing.assert_allclose(resumed_tip, tip, rtol=0, atol=1e-9 * np.abs(tip).max())
    assert again["stopped_periodic"] == summary["stopped_periodic"]
    # resumed under explicit-am, the switch does not hold: one solve per window goes on
    run("other", "--set", "time.periods=3")
    explicit = ["coupling.scheme=explicit-am", "coupling.explicit_until_periodic=false"]
    longer = ["time.periods=5", "time.periodic_tolerance=1e-9"]  # no periodic stop at once
    sets = [arg for s in [*explicit, *longer] for arg in ("--set", s)]
    _, _, flags, _ = run("other", "--resume", *sets)
    np.testing.assert_array_equal(flags, [0] * 50)


@pytest.mark.parametrize(
    "sets, named",
    [
        (["coupling.scheme=explicit-am"], 'applies to coupling.scheme = "iqn-ils-am" only'),
        ([], "needs time.periodic_tolerance"),
        (["coupling.explicit_periods=2"], "keep one of them"),
    ],
)
def test_explicit_until_periodic_needs_iterations_a_tolerance_and_no_fixed_start_up(
    tmp_path, sets, named
):
    text = ADAPTIVE_BEAM if sets else ADAPTIVE_BEAM.replace("periodic_tolerance = 0.01\n", "")
    (tmp_path / "case.toml").write_text(text)
    with pytest.raises(CaseError, match="coupling.explicit_until_periodic") as err:
        load_case(tmp_path, sets)
    assert named in str(err.value)


# the tail's mean position and swing per period [mm] of two coarse OpenFOAM runs with
# explicit-am (fsi-sweep cases/fixed_head_3Hz --set fluid.mesh_level=coarse
# --set coupling.scheme=explicit-am, 40 windows per period): the 3 Hz square wave's mean flips
# and grows from period 3 on; the 5 Hz sine's settles (both measured on this machine)
SQUARE_3HZ = ([-0.58, 1.26, 0.32, -1.71, 4.31, -5.31], [12.08, 13.97, 12.39, 12.80, 13.06, 15.22])
SINE_5HZ = (
    [0.36, 1.36, -0.77, -0.45, 0.42, 0.22, -0.11, -0.07],
    [3.75, 4.38, 4.87, 5.03, 4.72, 4.77, 4.69, 4.71],
)


def replay(tmp_path, case, means, swings, per_period=8):
    """Feed a tail history of the given per-period means and swings to the case's stop rules,
    window by window; returns the window after which the growth check raised (None: never)."""
    from fsi_orchestrator.convergence import CouplingDivergenceError

    rule = run_cli.explicit_growth_check(case)
    results = ResultsFile(tmp_path / "results.h5")
    try:
        for k, (mean, swing) in enumerate(zip(means, swings, strict=True)):
            for j in range(per_period):
                z = 1e-3 * (mean + swing * np.sin(2 * np.pi * (j + 0.5) / per_period))
                results.append({"shell/tip_displacement_m": [0.0, 0.0, z]})
                try:
                    if rule is not None:
                        rule(results)
                except CouplingDivergenceError as err:
                    assert "flipped sign in each of the last 3 periods" in str(err)
                    assert "iqn-ils-am" in str(err)
                    return k * per_period + j + 1
    finally:
        results.close()
    return None


@pytest.mark.parametrize(
    "scheme, history, stops_after",
    [
        ("explicit-am", SQUARE_3HZ, 48),  # the end of period 6
        ("explicit-am", SINE_5HZ, None),
        ("iqn-ils-am", SQUARE_3HZ, None),  # iterated windows: the check does not apply
    ],
)
def test_a_tail_mean_flipping_and_growing_over_periods_of_single_solves_stops_the_run(
    tmp_path, scheme, history, stops_after
):
    sets = [f"coupling.scheme={scheme}", "time.periods=8", "time.steps_per_period=8"]
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", sets)
    assert replay(tmp_path, case, *history) == stops_after


def test_an_output_folder_that_cannot_be_used_is_refused_before_the_set_up(tmp_path, capsys):
    """--output naming a file, or --resume where no checkpoint is: one line, before the
    structure (and any fluid) is built."""
    case = beam_case(tmp_path / "case")
    (tmp_path / "a_file").write_text("")
    assert run_cli.main([str(case), "--output", str(tmp_path / "a_file"), "--quiet"]) == 2
    assert run_cli.main([str(case), "--output", str(tmp_path / "new"), "--resume"]) == 1
    assert not (tmp_path / "new").exists()  # nothing was run or written, no folder left
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        f"error: --output {tmp_path / 'a_file'}: cannot write there (it is a file)",
        f"error: {tmp_path / 'new' / 'checkpoint.h5'}: no checkpoint to resume from; {AFRESH}",
    ]


def test_a_newton_failure_on_the_periodic_orbit_names_a_start_from_rest(tmp_path, capsys):
    """The beam in the liquid at 10 Hz, near its wet resonance: the linear orbit swings 79 mm
    on an 87 mm beam and the shell's Newton fails in the first windows. The line names the
    time step and the start from rest, which runs."""
    case, args = str(ROOT / "cases/beam_in_liquid"), ["--set", "actuation.frequency_hz=10"]
    args += ["--set", "time.periods=0.1", "--quiet"]
    code = run_cli.main([case, *args, "--output", str(tmp_path / "orbit")])
    err = capsys.readouterr().err.strip()
    assert code == 1
    assert err.startswith("error: shell: Newton did not converge at t = ")
    assert "--set time.start=rest" in err and "reduce the time step" in err
    assert len(err.splitlines()) == 1
    code = run_cli.main(
        [case, *args, "--set", "time.start=rest", "--output", str(tmp_path / "rest")]
    )
    assert code == 0, capsys.readouterr().err


def test_a_resume_of_a_finished_run_reports_the_runs_wall_time(tmp_path, capsys):
    """wall_s is the recorded windows' wall time (every invocation's) and this call's after
    them: a --resume of a finished run said the few seconds of the resume call instead."""
    case = make(tmp_path, vtk="false")
    assert run_cli.main([str(case), "--json", "--quiet"]) == 0
    fresh = json.loads(capsys.readouterr().out)
    with h5py.File(fresh["results"], "a") as h5:
        assert fresh["wall_s"] >= h5["wall_s"][:, 0].sum()
        h5["wall_s"][:] = 60.0  # as a run of 40 minutes
    assert run_cli.main([str(case), "--json", "--quiet", "--resume"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert 40 * 60.0 <= resumed["wall_s"] < 40 * 60.0 + 30


def test_a_newton_failure_is_told_by_its_type_not_its_words(tmp_path, capsys, monkeypatch):
    """The start-from-rest advice goes with the shell's NewtonNotConverged (a SolverError),
    whatever its words, and not with another SolverError that uses them."""
    from fsi_orchestrator.loop import WindowLoop
    from solid_adapter.solvers import NewtonNotConverged, SolverError

    with pytest.raises(NewtonNotConverged):  # the shell's own, with too few iterations
        run_static(load_case(make(tmp_path), ["analysis.max_newton_iterations=1"]))
    case = beam_case(tmp_path / "beam")
    errors = {
        "newton": NewtonNotConverged("shell: no convergence at t = 0.01 s"),
        "other": SolverError("shell: Newton did not converge, said another solver"),
    }
    advised = {}
    for name, error in errors.items():

        def failing(self, resume=False, error=error):
            raise error

        monkeypatch.setattr(WindowLoop, "run", failing)
        assert run_cli.main([str(case), "--quiet", "--output", str(tmp_path / name)]) == 1
        advised[name] = "--set time.start=rest" in capsys.readouterr().err
    assert advised == {"newton": True, "other": False}


def test_a_run_shorter_than_a_period_says_its_mean_thrust_is_a_part_periods(tmp_path, capsys):
    """A quarter period's mean thrust is not a period's: fsi-run says so in one note and
    reports the span it averaged over; a sweep's row says "shorter than one period"."""
    from fishfsi.cli import sweep as sweep_cli

    quarter = ["--set", "fluid.model=potential", "--set", "mesh.level=coarse"]
    quarter += ["--set", "time.periods=0.25", "--set", "output.vtk=false"]
    case = str(ROOT / "cases/fixed_head_3Hz")
    assert run_cli.main([case, *quarter, "--json", "--output", str(tmp_path / "run")]) == 0
    out, err = capsys.readouterr()
    summary = json.loads(out)
    assert summary["thrust_averaged_over_s"] == pytest.approx(0.25 / 3)
    notes = [line for line in err.splitlines() if "shorter than one period" in line]
    assert len(notes) == 1 and "time.periods >= 1" in notes[0]
    args = [case, "--method", "transient", "--frequencies", "3", "--waveforms", "sine"]
    assert sweep_cli.main([*args, *quarter, "--output", str(tmp_path / "sweep")]) == 0
    rows = (tmp_path / "sweep" / "sweep.csv").read_text()
    assert "ok (shorter than one period)" in rows
