"""File faults around fsi-run (a damaged checkpoint or results file, a folder that cannot be
written, a full disk, an earlier run in the folder, a NaN) each end in one line naming the
file, with a non-zero exit and nothing already written lost; and results.h5 records what made
it (provenance attributes, units)."""

from __future__ import annotations

import contextlib
import datetime
import errno
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

import fsi_orchestrator
from fishfsi.cli import design as design_cli
from fishfsi.cli import modal as modal_cli
from fishfsi.cli import post as post_cli
from fishfsi.cli import run as run_cli
from fishfsi.cli import sweep as sweep_cli
from fsi_orchestrator import results as results_mod
from fsi_orchestrator.case import CaseError, load_case
from fsi_orchestrator.provenance import case_dict
from fsi_orchestrator.results import OutputError, ResultsFile

ROOT = Path(__file__).resolve().parents[1]

# the piezo-driven beam alone: 10 windows in about a second, checkpoints after 5 and 10
BEAM = """
[geometry]
kind = "beam"
[actuation]
frequency_hz = 10.0
[time]
periods = 0.5
steps_per_period = 20
[mesh]
level = "coarse"
[output]
vtk = false
checkpoint_every = 5
"""


def run(capsys, *args: str) -> tuple[int, list[str]]:
    """fsi-run in this process: exit code and the lines on stderr."""
    code = run_cli.main([*map(str, args), "--quiet", "--json"])
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A case folder and the output of its finished run (copied by each test)."""
    root = tmp_path_factory.mktemp("finished")
    (root / "case").mkdir()
    (root / "case" / "case.toml").write_text(BEAM)
    assert run_cli.main([str(root / "case"), "--quiet", "--set", "output.vtk=true"]) == 0
    return root


@pytest.fixture
def done(finished, tmp_path) -> tuple[Path, Path]:
    """(case folder, output folder of a finished run) of one's own."""
    shutil.copytree(finished, tmp_path, dirs_exist_ok=True)
    return tmp_path / "case", tmp_path / "case" / "output"


def one_line_naming(lines: list[str], path: Path, *words: str) -> str:
    assert len(lines) == 1, lines
    assert str(path) in lines[0] and "Traceback" not in lines[0]
    for word in words:
        assert word in lines[0]
    return lines[0]


# ------------------------------------------------------------------ damaged files on --resume
def _truncate(p: Path) -> None:
    os.truncate(p, p.stat().st_size // 3)


def _empty(p: Path) -> None:
    p.write_bytes(b"")


def _zero(p: Path) -> None:
    p.write_bytes(bytes(p.stat().st_size))


def _random_bytes(p: Path) -> None:
    data = bytearray(p.read_bytes())
    rng = np.random.default_rng(0)
    start = len(data) // 2  # in the data, past the superblock: h5py still opens the file
    data[start : start + 64] = rng.integers(0, 256, 64, dtype=np.uint8).tobytes()
    p.write_bytes(bytes(data))


def _changed_value(p: Path) -> None:
    """A well-formed file whose numbers are not the ones written."""
    with h5py.File(p, "a") as h5:
        h5["participants/shell/x"][0] += 1e-3


def _nan_state(p: Path) -> None:
    """NaN in the structure's state, the checksum made to fit: caught as not finite."""
    with h5py.File(p, "a") as h5:
        x = h5["participants/shell/x"]
        x[0] = np.nan
        h5.attrs[results_mod.CHECKSUM_ATTR] = results_mod.checksum(h5)


@pytest.mark.parametrize(
    ("damage", "why"),
    [
        (_truncate, "truncated or corrupt"),
        (_empty, "truncated or corrupt"),
        (_zero, "truncated or corrupt"),
        (_random_bytes, ""),
        (_changed_value, "checksum does not match"),
        (_nan_state, "not finite"),
    ],
    ids=["truncated", "emptied", "zeroed", "random-bytes", "changed-value", "nan"],
)
def test_a_damaged_checkpoint_is_refused_on_resume_in_one_line(done, capsys, damage, why):
    case, out = done
    checkpoint, results = out / "checkpoint.h5", out / "results.h5"
    before = results.read_bytes()
    damage(checkpoint)
    code, lines = run(capsys, case, "--resume")
    assert code == 1
    one_line_naming(lines, checkpoint, "not a readable checkpoint", why, "without --resume")
    assert results.read_bytes() == before  # nothing loaded, nothing written


def test_a_checkpoint_of_another_case_is_refused(done, capsys):
    """Same shapes, another material: resuming would mix two cases."""
    case, out = done
    code, lines = run(capsys, case, "--resume", "--set", "material.youngs_modulus_pa=2e9")
    assert code == 1
    one_line_naming(lines, out / "checkpoint.h5", "another case", "material.youngs_modulus_pa")


def test_a_damaged_results_file_is_refused_on_resume_in_one_line(done, capsys):
    case, out = done
    checkpoint = out / "checkpoint.h5"
    kept = checkpoint.read_bytes()
    _truncate(out / "results.h5")
    code, lines = run(capsys, case, "--resume")
    assert code == 1
    one_line_naming(lines, out / "results.h5", "not a readable results file")
    assert checkpoint.read_bytes() == kept


def test_fsi_post_names_a_cut_results_file_as_a_damaged_run(done, capsys):
    _, out = done
    _truncate(out / "results.h5")
    assert post_cli.main([str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    one_line_naming(lines, out / "results.h5", "not a readable results file", "cut short")


def test_a_checkpoint_resumed_under_another_fluid_model_is_refused(done, capsys):
    """Half the windows with one fluid, half with another, under one label: refused."""
    case, out = done
    before = (out / "results.h5").read_bytes()
    code, lines = run(capsys, case, "--resume", "--set", "fluid.model=slender_body")
    assert code == 1
    one_line_naming(lines, out / "checkpoint.h5", "another case", "fluid.model")
    assert (out / "results.h5").read_bytes() == before


def test_a_results_file_holding_nan_is_refused_on_resume_before_the_set_up(
    done, capsys, monkeypatch
):
    """Damaged data that h5py still reads (NaN in a recorded series) is refused at once, not
    reported as a diverged run after the resumed windows."""
    case, out = done
    with h5py.File(out / "results.h5", "a") as h5:
        h5["shell/tip_displacement_m"][3] = np.nan
    built = []
    monkeypatch.setattr(run_cli, "run_dynamic", lambda *a, **k: built.append(1))
    code, lines = run(capsys, case, "--resume")
    assert code == 1 and not built
    one_line_naming(
        lines, out / "results.h5", "not a readable results file", "window 4", "--overwrite"
    )


def test_a_run_into_a_sweeps_folder_is_refused(tmp_path, capsys):
    """fsi-sweep refuses a run's folder; fsi-run refuses a sweep's."""
    (tmp_path / "case").mkdir()
    (tmp_path / "case" / "case.toml").write_text(BEAM)
    (tmp_path / "sweep").mkdir()
    (tmp_path / "sweep" / "sweep.csv").write_text("waveform,frequency_hz,tip_amplitude_m\n")
    code, lines = run(capsys, tmp_path / "case", "--output", tmp_path / "sweep")
    assert code == 2
    one_line_naming(lines, tmp_path / "sweep", "holds a sweep of fsi-sweep (sweep.csv)")
    assert sorted(p.name for p in (tmp_path / "sweep").iterdir()) == ["sweep.csv"]


def test_a_resume_where_no_run_was_leaves_no_folder(tmp_path, capsys):
    (tmp_path / "case").mkdir()
    (tmp_path / "case" / "case.toml").write_text(BEAM)
    fresh = tmp_path / "never_ran"
    code, lines = run(capsys, tmp_path / "case", "--resume", "--output", fresh)
    assert code == 1
    one_line_naming(lines, fresh / "checkpoint.h5", "no checkpoint to resume from")
    assert not fresh.exists()


# ------------------------------------------------------------------ folders that cannot be written
def make_read_only(folder: Path, monkeypatch) -> None:
    """As root the mode bits do not stop a write (a read-only mount would): there the probe
    write is made to fail as the mount would make it."""
    if os.geteuid() == 0:

        def refused(directory):
            raise PermissionError(errno.EROFS, os.strerror(errno.EROFS), str(directory))

        monkeypatch.setattr(results_mod, "probe_write", refused)
    else:
        folder.chmod(0o555)


def test_a_read_only_output_folder_is_refused_before_the_set_up(done, capsys, monkeypatch):
    """Bad input (exit 2), as an --output that cannot be made."""
    case, out = done
    fresh = out.parent / "read_only"
    fresh.mkdir()
    make_read_only(fresh, monkeypatch)
    built = []
    monkeypatch.setattr(run_cli, "run_dynamic", lambda *a, **k: built.append(1))
    try:
        code, lines = run(capsys, case, "--output", fresh)
    finally:
        fresh.chmod(0o755)
    assert code == 2 and not built
    one_line_naming(lines, fresh, "not writable", "nothing was run")
    assert list(fresh.iterdir()) == []


def test_a_read_only_output_folder_is_refused_before_a_swimming_run(tmp_path, capsys, monkeypatch):
    """A kind whose answer is its summary alone is refused before its work, as a dynamic run."""
    fresh = tmp_path / "read_only"
    fresh.mkdir()
    make_read_only(fresh, monkeypatch)
    ran = []
    monkeypatch.setattr(run_cli, "execute", lambda *a, **k: ran.append(1))
    try:
        code, lines = run(capsys, ROOT / "cases/swim_original_18Hz", "--output", fresh)
    finally:
        fresh.chmod(0o755)
    assert code == 2 and not ran
    one_line_naming(lines, fresh, "not writable", "nothing was run")


def test_a_read_only_output_folder_is_bad_input_to_fsi_sweep_as_to_fsi_run(
    done, capsys, monkeypatch
):
    """fsi-sweep refuses it with exit 2 too (fsi-run said 1): an empty one, and one holding
    an earlier sweep's rows folder (its mkdir passes), before --overwrite deletes anything."""
    case, out = done
    empty, earlier = out.parent / "read_only", out.parent / "read_only_sweep"
    empty.mkdir()
    (earlier / "sweep_rows").mkdir(parents=True)
    (earlier / "sweep.csv").write_text("waveform,frequency_hz\n")
    codes = []
    for folder, flags in ((empty, []), (earlier, ["--overwrite"])):
        make_read_only(folder, monkeypatch)
        try:
            codes.append(
                sweep_cli.main([str(case), "--frequencies", "5", "--output", str(folder), *flags])
            )
        finally:
            folder.chmod(0o755)
    lines = capsys.readouterr().err.strip().splitlines()
    assert codes == [2, 2]
    assert len(lines) == 2, lines
    for line, folder in zip(lines, (empty, earlier), strict=True):
        assert line.startswith(f"error: --output {folder}: cannot write there ("), line
    assert list(empty.iterdir()) == []
    assert sorted(p.name for p in earlier.iterdir()) == ["sweep.csv", "sweep_rows"]


def test_a_read_only_results_file_is_refused_before_the_set_up(done, capsys, monkeypatch):
    """Resuming where results.h5 cannot be opened for writing: bad input, as a read-only
    folder."""
    case, out = done
    results = out / "results.h5"
    real_open = os.open

    def guarded_open(path, flags, *args, **kwargs):
        if Path(path) == results and flags & (os.O_WRONLY | os.O_RDWR):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(results_mod.os, "open", guarded_open)
    code, lines = run(capsys, case, "--resume")
    assert code == 2
    one_line_naming(lines, results, "not writable")


def test_a_full_disk_from_the_start_is_refused_and_leaves_no_results_file(
    finished, tmp_path, capsys, monkeypatch
):
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(results_mod.shutil, "disk_usage", lambda p: usage._replace(free=4096))
    code, lines = run(capsys, finished / "case", "--output", tmp_path / "out")
    assert code == 1
    one_line_naming(lines, tmp_path / "out", "disk full", "nothing was run")
    assert list((tmp_path / "out").iterdir()) == []


def test_a_results_file_that_cannot_be_created_is_not_left_empty(tmp_path, monkeypatch):
    path = tmp_path / "results.h5"

    def full(name, mode, **kwargs):
        Path(name).write_bytes(b"")  # HDF5 creates the file, then fails to write it
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(results_mod.h5py, "File", full)
    with pytest.raises(OutputError, match="results.h5: disk full"):
        ResultsFile(path)
    assert not path.exists()


def test_a_full_disk_during_a_checkpoint_keeps_the_previous_one_and_resumes(
    done, capsys, monkeypatch
):
    """The second checkpoint's write fails for lack of space (an injected ENOSPC): one line,
    exit 1, the first checkpoint and the results kept; with room again --resume finishes the
    run exactly as the uninterrupted one."""
    case, reference = done
    out = reference.parent / "full"
    expected = h5py.File(reference / "results.h5", "r")["shell/tip_displacement_m"][:]
    real_put, calls = results_mod._put, []

    def put(group, key, value):
        if key == "window":
            calls.append(value)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_put(group, key, value)

    monkeypatch.setattr(results_mod, "_put", put)
    code, lines = run(capsys, case, "--output", out)
    assert code == 1
    one_line_naming(lines, out / "checkpoint.h5", "disk full", "previous checkpoint", "--resume")
    assert sorted(p.name for p in out.iterdir()) == ["checkpoint.h5", "results.h5"]
    assert results_mod.read_checkpoint(out / "checkpoint.h5")[0]["window"] == 5
    assert results_mod.stored_rows(out / "results.h5") == 10

    monkeypatch.setattr(results_mod, "_put", real_put)
    code, lines = run(capsys, case, "--output", out, "--resume")
    assert code == 0, lines
    with h5py.File(out / "results.h5", "r") as h5:
        np.testing.assert_allclose(h5["shell/tip_displacement_m"][:], expected, atol=1e-12)


def test_a_full_disk_while_recording_stops_in_one_line(tmp_path, monkeypatch):
    """Results are refused while there is room for HDF5 to fail cleanly: the rows so far
    stay readable."""
    results = ResultsFile(tmp_path / "results.h5")
    results.append({"time_s": 0.1, "shell/tip_displacement_m": [0.0, 0.0, 1e-3]})
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(results_mod.shutil, "disk_usage", lambda p: usage._replace(free=1000))
    with pytest.raises(OutputError, match="results.h5: disk full; the results up to window 1"):
        results.append({"time_s": 0.2, "shell/tip_displacement_m": [0.0, 0.0, 2e-3]})
    results.close()
    assert results_mod.stored_rows(tmp_path / "results.h5") == 1


# ------------------------------------------------------------------ an earlier run, a NaN
def test_a_rerun_into_a_folder_holding_results_is_refused_unless_overwrite(done, capsys):
    case, out = done
    before = (out / "results.h5").read_bytes()
    code, lines = run(capsys, case)
    assert code == 2
    one_line_naming(lines, out, "--resume", "--output", "--overwrite")
    assert (out / "results.h5").read_bytes() == before
    stale = out / "vtk" / "shell_999999.vtu"  # a window of a longer earlier run
    stale.write_text("")
    code, lines = run(capsys, case, "--overwrite")
    assert code == 0, lines
    assert not stale.exists()


def test_a_modal_run_into_a_folder_holding_a_run_is_refused_unless_overwrite(done, capsys):
    """A modal, static or swimming run keeps only its summary.json: it replaced an earlier
    run's summary beside that run's results.h5 without a word."""
    case, out = done
    before = (out / "summary.json").read_bytes()
    modal = ("--output", out, "--set", "analysis.kind=modal")
    code, lines = run(capsys, case, *modal)
    assert code == 2
    one_line_naming(lines, out, "holds an earlier run", "--overwrite")
    assert (out / "summary.json").read_bytes() == before
    code, lines = run(capsys, case, *modal, "--resume")
    assert code == 2 and "--resume: a modal run keeps no checkpoint" in lines[0]
    code, lines = run(capsys, case, *modal, "--overwrite")
    assert code == 0, lines
    assert "dry_hz" in json.loads((out / "summary.json").read_text())
    assert not (out / "results.h5").exists() and not (out / "checkpoint.h5").exists()
    assert not (out / "vtk").exists()  # the earlier run's pictures went with it
    code, lines = run(capsys, case, *modal)  # its own summary is an earlier run too
    assert code == 2 and "summary.json" in lines[0]
    code, lines = run(capsys, case, "--output", out)  # a dynamic run over the modal one
    assert code == 2 and "holds an earlier run (summary.json)" in lines[0]
    assert "dry_hz" in json.loads((out / "summary.json").read_text())


def test_a_nan_result_never_exits_zero(done, capsys, monkeypatch):
    case, out = done
    with h5py.File(out / "results.h5", "a") as h5:
        h5["shell/tip_displacement_m"][7, 2] = np.nan
    summary = {"results": str(out / "results.h5"), "tip_amplitude_m": float("nan")}
    monkeypatch.setattr(run_cli, "run_dynamic", lambda *a, **k: summary)
    code, lines = run(capsys, case, "--overwrite")
    assert code == 1
    one_line_naming(lines, out / "results.h5", "shell/tip_displacement_m", "window 8", "time step")


def test_a_tank_too_small_for_the_mesh_grading_names_the_keys():
    import dataclasses

    from fluid_adapter.openfoam.fishmesh import LEVELS, tank_geometry, tank_topology
    from fsi_orchestrator.case.schema import MeshLevel

    geo = tank_geometry(load_case(ROOT / "cases" / "fixed_head_3Hz"))
    res = LEVELS[MeshLevel.DEFAULT]
    for changed, key in [
        (dataclasses.replace(geo, x_front=-1e-4), "fluid.tank_length_m"),
        (dataclasses.replace(geo, depth=0.03), "fluid.tank_depth_m"),
        (dataclasses.replace(geo, width=1e-3), "fluid.tank_width_m"),
    ]:
        with pytest.raises(CaseError, match=rf"{key}.*at least"):
            tank_topology(changed, res)


# ------------------------------------------------------------------ provenance
def test_results_record_what_made_them(tmp_path, capsys):
    """Root attributes: the resolved case as TOML (it loads back to the same case), the
    overrides, the version, the fluid model, the thrust source, time and host; a unit on
    every dataset; newton_iterations said to be cumulative."""
    sets = ["time.periods=0.1", "output.vtk=false"]
    args = [ROOT / "cases" / "beam_in_liquid", "--output", tmp_path / "out"]
    code, _ = run(capsys, *args, *[x for s in sets for x in ("--set", s)])
    assert code == 0
    with h5py.File(tmp_path / "out" / "results.h5", "r") as h5:
        attrs = dict(h5.attrs)
        units = {}
        h5.visititems(
            lambda n, o: units.update({n: dict(o.attrs)}) if isinstance(o, h5py.Dataset) else None
        )
    case = load_case(ROOT / "cases" / "beam_in_liquid", sets)
    assert tomllib.loads(attrs["case_toml"])["time"]["periods"] == 0.1
    (tmp_path / "again").mkdir()
    (tmp_path / "again" / "case.toml").write_text(attrs["case_toml"])
    assert case_dict(load_case(tmp_path / "again")) == case_dict(case)
    assert json.loads(attrs["overrides"]) == sets
    assert attrs["version"].startswith(fsi_orchestrator.__version__)
    assert attrs["fluid_model"] == "potential"
    assert attrs["thrust_source"] == "slender_body" or attrs["thrust_source"] == "none"
    created = datetime.datetime.fromisoformat(attrs["created"])
    assert abs(datetime.datetime.now(datetime.UTC) - created).total_seconds() < 600
    assert attrs["host"]
    assert units["time_s"]["units"] == "s" and units["wall_s"]["units"] == "s"
    assert units["shell/tip_displacement_m"]["units"] == "m"
    assert all("units" in a for a in units.values())
    newton = units["shell/newton_iterations"]
    assert newton["units"] == "1" and "cumulative" in newton["description"]


def test_a_case_that_a_sweep_made_with_numpy_numbers_is_written_as_toml_that_loads_back(tmp_path):
    """A sweep's frequencies come from numpy (``--frequencies 1:25:2``): the resolved case
    written into results.h5 held ``frequency_hz = np.float64(1.0)``, which no TOML reader
    takes, so fsi-post could not read the drive's period back."""
    import dataclasses

    from fsi_orchestrator.provenance import case_toml

    case = load_case(ROOT / "cases" / "fixed_head_3Hz")
    swept = dataclasses.replace(
        case,
        actuation=dataclasses.replace(case.actuation, frequency_hz=np.float64(7.0)),
        time=dataclasses.replace(case.time, periods=np.float64(2.0)),
    )
    text = case_toml(swept)
    assert tomllib.loads(text)["actuation"]["frequency_hz"] == 7.0
    (tmp_path / "case.toml").write_text(text)
    assert case_dict(load_case(tmp_path)) == case_dict(swept)


def test_a_runs_summary_is_kept_beside_its_results_and_in_an_asked_output(tmp_path, capsys):
    """fsi-run --output on a modal case wrote nothing there; a dynamic run's summary (what
    --json prints) was only on stdout. Both are kept as summary.json now."""
    code = run_cli.main(
        [
            str(ROOT / "cases" / "beam_in_liquid"),
            "--json",
            "--quiet",
            "--set",
            "time.periods=0.1",
            "--set",
            "output.vtk=false",
            "--output",
            str(tmp_path / "dyn"),
        ]
    )
    printed = json.loads(capsys.readouterr().out)
    assert code == 0
    assert json.loads((tmp_path / "dyn" / "summary.json").read_text()) == printed
    code = run_cli.main(
        [
            str(ROOT / "cases" / "beam_in_liquid"),
            "--json",
            "--quiet",
            "--set",
            "analysis.kind=modal",
            "--output",
            str(tmp_path / "modal"),
        ]
    )
    printed = json.loads(capsys.readouterr().out)
    assert code == 0 and printed["dry_hz"]
    assert json.loads((tmp_path / "modal" / "summary.json").read_text()) == printed
    (tmp_path / "afile").write_text("")
    code = run_cli.main(
        [
            str(ROOT / "cases" / "beam_in_liquid"),
            "--quiet",
            "--set",
            "analysis.kind=modal",
            "--output",
            str(tmp_path / "afile"),
        ]
    )
    assert code == 2
    assert capsys.readouterr().err.strip().startswith(f"error: --output {tmp_path / 'afile'}: ")


def test_results_can_be_read_by_another_process_while_the_run_writes(tmp_path):
    """The writer takes no HDF5 file lock and flushes every window: a reader in another
    process (default h5py settings) sees the rows written so far."""
    path = tmp_path / "results.h5"
    results = ResultsFile(path)
    reader = [sys.executable, "-c", f"import h5py; print(h5py.File({str(path)!r}, 'r')"]
    reader[-1] += "['time_s'].shape[0])"
    seen = []
    for k in range(3):
        results.append({"time_s": 0.1 * k, "shell/tip_displacement_m": [0.0, 0.0, k]})
        done = subprocess.run(reader, capture_output=True, text=True, check=False)
        assert done.returncode == 0, done.stderr
        seen.append(int(done.stdout))
    results.close()
    assert seen == [1, 2, 3]


@pytest.mark.parametrize(
    "main", [run_cli.main, modal_cli.main, sweep_cli.main, post_cli.main, design_cli.main]
)
def test_every_command_has_version(main, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert fsi_orchestrator.__version__ in capsys.readouterr().out


def test_a_reader_that_leaves_early_ends_the_command_without_a_traceback():
    """`fsi-modal --json | head -c 10`: the closed pipe is exit 141 (128 + SIGPIPE), as a
    shell's own tools end, and stderr stays empty."""
    modal = subprocess.Popen(
        [sys.executable, "-m", "fishfsi.cli.modal", str(ROOT / "cases/fish_modal_free")]
        + ["--quiet", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert modal.stdout is not None
    modal.stdout.close()  # nothing reads: the first write breaks the pipe
    _, err = modal.communicate(timeout=300)
    assert modal.returncode == 141
    assert err.decode() == ""


# ------------------------------------------------------------------ write faults past the checks
def test_a_write_fault_past_the_up_front_checks_is_one_line_naming_the_file(tmp_path, capsys):
    """A disk that fills after a command's checks (a sweep's row, a study's table) ends in
    one line naming the file, what is kept and what to do; the temporary file is removed."""
    from fishfsi.cli.common import atomic_write, guarded

    target = tmp_path / "sweep.csv"

    def fill_up() -> int:
        with mock_full_disk():
            atomic_write(target, "waveform,frequency_hz\n")
        return 0

    assert guarded(fill_up) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0] == (
        f"error: {target}: disk full; "
        "results so far are kept; free space, then continue with --resume"
    )
    assert list(tmp_path.iterdir()) == []


@contextlib.contextmanager
def mock_full_disk():
    """Every write to a file fails as on a full disk."""
    real = os.fsync

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    os.fsync = full
    try:
        yield
    finally:
        os.fsync = real


def test_fsi_post_says_its_own_output_is_full_not_that_the_input_is_bad(done, capsys, monkeypatch):
    case, out = done
    picture = out / "run.png"

    def full(fig, path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(post_cli, "save_figure", full)
    assert post_cli.main([str(out)]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    one_line_naming(lines, picture, "disk full", "the inputs are untouched")
    assert "not a table" not in lines[0] and not picture.exists()


def test_fsi_post_draws_a_results_file_only_up_to_its_first_nan(done, capsys):
    """NaN never leaves with exit 0: the picture shows the windows before it, and it says so."""
    case, out = done
    with h5py.File(out / "results.h5", "a") as h5:
        h5["shell/tip_displacement_m"][6] = np.nan
    assert post_cli.main([str(out)]) == 1  # as fsi-run ends a diverged run
    lines = capsys.readouterr().err.strip().splitlines()
    line = one_line_naming(lines, out / "results.h5", "shell/tip_displacement_m", "window 7")
    assert "run.png shows the 6 windows before it" in line
    assert (out / "run.png").stat().st_size > 0


def test_fsi_post_takes_a_denied_read_for_the_inputs_fault_not_a_write(
    tmp_path, capsys, monkeypatch
):
    (tmp_path / "sweep.csv").write_text("waveform,frequency_hz,tip_amplitude_m\nsine,3,0.01\n")

    def denied(path):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))

    monkeypatch.setattr(post_cli, "read_sweep", denied)
    assert post_cli.main([str(tmp_path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    one_line_naming(lines, tmp_path / "sweep.csv", "Permission denied")
    assert "not writable" not in lines[0]


def test_a_failed_atomic_write_leaves_no_temporary_file_and_names_the_target(tmp_path):
    """A row's temporary name never ends in .json, so a folder's *.json never lists it."""
    from fishfsi.cli.common import WriteFault, replaced_atomically

    target = tmp_path / "sine_5Hz.json"
    with replaced_atomically(target) as tmp:
        assert not tmp.name.endswith(".json")
        tmp.write_text("{}")
    assert [p.name for p in tmp_path.iterdir()] == ["sine_5Hz.json"]
    with pytest.raises(WriteFault) as caught, replaced_atomically(tmp_path / "b.json") as tmp:
        tmp.write_text("{")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert caught.value.filename == str(tmp_path / "b.json")
    assert [p.name for p in tmp_path.iterdir()] == ["sine_5Hz.json"]


def test_a_checkpoint_written_before_a_key_existed_resumes_while_the_key_is_at_its_default():
    """A checkpoint's case identity holds the keys of its day. A key added later (here
    boundary.pin_x_m), at its default, changes nothing the checkpoint stood for; away from
    its default it does, and so does any key the checkpoint holds."""
    from fsi_orchestrator.provenance import (
        IDENTITY_SECTIONS,
        case_dict,
        case_identity,
        identity_changes,
    )

    case = load_case(ROOT / "cases" / "fixed_head_3Hz")
    current = case_identity(case)
    raw = case_dict(case)  # as the older version stored it: every boundary key
    older = {s: raw[s] for s in IDENTITY_SECTIONS} | {"fluid": {"model": "openfoam"}}
    del older["boundary"]["pin_x_m"]
    assert identity_changes(json.dumps(older), current) == []
    pinned = load_case(
        ROOT / "cases" / "fixed_head_3Hz", ["boundary.head=pinned", "boundary.pin_x_m=0.01"]
    )
    assert identity_changes(json.dumps(older), case_identity(pinned)) == [
        "boundary.head",
        "boundary.pin_x_m",
    ]
    clamp = load_case(ROOT / "cases" / "fixed_head_3Hz", ["boundary.clamp_length_m=0.02"])
    assert identity_changes(json.dumps(older), case_identity(clamp)) == ["boundary.clamp_length_m"]


def test_a_hinged_run_resumes_with_a_changed_key_the_hinge_does_not_read():
    """boundary.clamp_length_m and support_stiffness_n_per_m hold nothing on a hinge
    (boundary.head = "pinned"): a change to them changes no run, a change of the hinge's
    place does."""
    from fsi_orchestrator.provenance import case_identity, identity_changes

    rig = ROOT / "cases" / "seed" / "thrust_rig"
    stored = case_identity(load_case(rig))
    for unread in ("boundary.clamp_length_m=0.03", "boundary.support_stiffness_n_per_m=5e3"):
        assert identity_changes(stored, case_identity(load_case(rig, [unread]))) == []
    moved = case_identity(load_case(rig, ["boundary.pin_x_m=0.01"]))
    assert identity_changes(stored, moved) == ["boundary.pin_x_m"]
    clamped = case_identity(load_case(rig, ["boundary.head=clamped"]))
    assert identity_changes(stored, clamped) == ["boundary.clamp_length_m", "boundary.head"]
