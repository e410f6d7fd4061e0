"""fsi-sweep as a cluster job (issue 27, part 2): rows written as each point finishes, --resume,
a launch whose MPI world does not match its tasks, a NaN never leaving with exit 0, one
progress line per point in logs, and scripts/slurm_sweep.sh under a real SLURM."""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli import run as run_cli
from fishfsi.cli import sweep as sweep_cli
from fishfsi.cli.common import EXIT_FAILED, EXIT_INTERRUPTED
from fsi_orchestrator.results import CHECKPOINT_FILE, read_checkpoint

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "cases/beam_in_liquid"
# the beam in liquid, its mean voltage held by no bond (the seed's strip buckles under the
# full mean: solid_adapter/buckling.py), and transient runs of two windows
BEAM_SET = ["--set", "actuation.mean_strain_transfer=0"]
SHORT_RUN = ["--set", "time.periods=0.25", "--set", "time.steps_per_period=8"]


def status(row: dict) -> str:
    """A row's status less the note a run shorter than one period carries (SHORT_RUN's)."""
    return row["status"].replace(" (shorter than one period)", "")


FSI_SWEEP = str(ROOT / ".venv/bin/fsi-sweep")


def table(folder: Path) -> list[dict]:
    with open(folder / "sweep.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def stubbed_transient_sweep(out: Path, frequencies: str) -> list[str]:
    """fsi-sweep's argv for the beam's transient sine sweep into ``out`` (run_dynamic stubbed)."""
    args = [str(BEAM), *BEAM_SET, "--frequencies", frequencies, "--waveforms", "sine", "--quiet"]
    return [*args, "--method", "transient", "--output", str(out)]


def points(rows: list[dict]) -> list[tuple[str, float]]:
    return [(r["waveform"], float(r["frequency_hz"])) for r in rows]


def linear_frequencies_run(monkeypatch, interrupt_at: int | None = None) -> list[float]:
    """Spy on the linear sweep's per-point step (the slender-body thrust): the frequencies it
    ran, in order; ``interrupt_at``: a Ctrl-C (as a kill) at that call."""
    import fluid_adapter.slender_body as slender_body

    real = slender_body.mean_thrust_from_shell
    ran: list[float] = []

    def spy(*args, **kwargs):
        if kwargs.get("shedding_kc", 0.0) == 0.0:  # Lighthill's, once per point
            ran.append(round(1.0 / kwargs["period_s"], 9))
            if interrupt_at is not None and len(ran) == interrupt_at:
                raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(slender_body, "mean_thrust_from_shell", spy)
    return ran


def test_a_killed_linear_sweep_keeps_its_rows_and_resume_runs_only_the_missing_points(
    tmp_path, monkeypatch, capsys
):
    """Killed at its 3rd point, the sweep's table holds the 2 finished rows; --resume runs
    the 3rd only and the table is whole; a resume with another waveform runs only its points.
    Each finished point gives one line on stderr (not a terminal here)."""
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2,8,20", "--waveforms", "sine"]
    args += ["--output", str(out)]
    ran = linear_frequencies_run(monkeypatch, interrupt_at=3)
    assert sweep_cli.main(args) == EXIT_INTERRUPTED
    assert ran == [2.0, 8.0, 20.0]
    assert points(table(out)) == [("sine", 2.0), ("sine", 8.0)]
    killed = table(out)
    err = capsys.readouterr().err
    assert not sys.stderr.isatty()
    lines = [line for line in err.splitlines() if line.startswith("sweep: point")]
    assert [line.split(":")[1] for line in lines] == [
        " point 1/3 sine 2 Hz",
        " point 2/3 sine 8 Hz",
    ]
    assert "tip amplitude" in lines[0] and "thrust" in lines[0] and lines[0].endswith(" s")

    ran = linear_frequencies_run(monkeypatch)
    assert sweep_cli.main([*args, "--resume"]) == 0
    assert ran == [20.0]
    rows = table(out)
    assert points(rows) == [("sine", 2.0), ("sine", 8.0), ("sine", 20.0)]
    assert rows[:2] == killed
    err = capsys.readouterr().err
    assert "3 points (linear) into" in err and "2 done before (--resume)" in err
    assert "sweep: point 3/3 sine 20 Hz" in err

    ran = linear_frequencies_run(monkeypatch)
    both = [a if a != "sine" else "both" for a in args]
    assert sweep_cli.main([*both, "--resume", "--quiet", "--json"]) == 0
    assert ran == [2.0, 8.0, 20.0]  # the square points only
    out_rows = json.loads(capsys.readouterr().out)["rows"]
    assert points(out_rows) == [(w, f) for w in ("sine", "square") for f in (2.0, 8.0, 20.0)]
    assert len(table(out)) == 6
    assert "sweep:" not in capsys.readouterr().err  # --quiet


def test_a_resume_of_another_case_is_refused_naming_what_changed(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "5", "--waveforms", "sine"]
    args += ["--output", str(out), "--quiet"]
    assert sweep_cli.main(args) == 0
    capsys.readouterr()
    assert sweep_cli.main([*args, "--resume", "--set", "fluid.damping_ratio=0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert err.startswith(f"error: --resume: {out} holds a sweep of another case")
    assert "fluid.damping_ratio: 0.05 -> 0.1" in err


def test_a_resume_ignores_the_title_and_keys_of_a_section_the_sweep_does_not_read(tmp_path, capsys):
    """case.title is free text; a beam sweep reads no [swimming] key, so a sweep made before
    one was added there (sweep_case.json without it) resumes."""
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "5", "--waveforms", "sine"]
    args += ["--output", str(out), "--quiet"]
    assert sweep_cli.main(args) == 0
    stored = json.loads((out / "sweep_case.json").read_text())
    del stored["case"]["swimming"]["section_added_mass"]
    (out / "sweep_case.json").write_text(json.dumps(stored))
    capsys.readouterr()
    assert sweep_cli.main([*args, "--resume", "--set", "case.title='renamed'"]) == 0, (
        capsys.readouterr().err
    )


def test_a_resume_into_a_folder_of_another_version_is_refused_naming_it(
    tmp_path, monkeypatch, capsys
):
    """A sweep folder written by another version of fishfsi: --resume does not mix its rows
    with this version's, in one line naming the version."""
    import fsi_orchestrator

    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "5", "--waveforms", "sine"]
    args += ["--output", str(out), "--quiet"]
    assert sweep_cli.main(args) == 0
    capsys.readouterr()
    old = fsi_orchestrator.__version__
    monkeypatch.setattr(fsi_orchestrator, "__version__", f"{old}.post1")
    assert sweep_cli.main([*args, "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert err.startswith(f"error: --resume: {out} holds a sweep of another case")
    assert f"version: '{old}' -> '{old}.post1'" in err


@pytest.mark.parametrize("held", [["sweep.csv"], ["sweep.json"], ["sweep.csv", "sweep.json"]])
def test_a_resume_into_tables_without_a_sweep_case_is_refused_before_any_point(
    tmp_path, monkeypatch, capsys, held
):
    """A folder with sweep.csv / sweep.json but no sweep_case.json (an older version's, or not
    fsi-sweep's): --resume cannot tell its rows are this case's, so it is refused in one line
    naming the folder and the tables, before any point runs or anything there is written."""
    out = tmp_path / "old"
    out.mkdir()
    for name in held:
        (out / name).write_text("waveform,frequency_hz\nsine,5\n")
    ran = linear_frequencies_run(monkeypatch)
    args = [str(BEAM), *BEAM_SET, "--frequencies", "5", "--waveforms", "sine"]
    assert sweep_cli.main([*args, "--output", str(out), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert err.startswith(f"error: --resume: {out} holds {' and '.join(held)} but no ")
    assert "sweep_case.json" in err and "another --output" in err and "--overwrite" in err
    assert ran == []
    assert sorted(p.name for p in out.iterdir()) == sorted(held)  # nothing written there
    assert all((out / n).read_text() == "waveform,frequency_hz\nsine,5\n" for n in held)


def stub_linear(monkeypatch) -> list[list[str]]:
    """linear_sweep stubbed (no solver): each call's points run, in order; a point's row
    holds its call's number (``tip_amplitude_m`` = call, in mm)."""
    calls: list[list[str]] = []

    def stub(case, frequencies, waveforms, done=frozenset(), on_row=None):
        calls.append([])
        jobs = [(w, f) for w in waveforms for f in frequencies]
        for w, f in jobs:
            name = sweep_cli.point_name(w, f)
            if name in done:
                continue
            calls[-1].append(name)
            row = {"waveform": w.value, "frequency_hz": f, "tip_amplitude_m": 1e-3 * len(calls)}
            row.update(slender_body_mean_thrust_n=0.0, status="ok")
            if on_row is not None:
                on_row(name, row, 0.0)
        return []

    monkeypatch.setattr(sweep_cli, "linear_sweep", stub)
    return calls


def snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != ".sweep.lock"
    }


def test_a_fresh_sweep_into_a_folder_holding_a_sweep_is_refused_and_overwrite_replaces_it(
    tmp_path, monkeypatch, capsys
):
    """Nothing computed is lost: a fresh sweep (no --resume) into a folder holding a sweep's
    tables is refused in one line naming the folder and what it holds, before any point runs
    or anything there is written (exit 2); of another case, it names what changed; with
    --overwrite the earlier tables and rows are replaced by the new sweep's."""
    calls = stub_linear(monkeypatch)
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--waveforms", "sine", "--output", str(out), "--quiet"]
    assert sweep_cli.main([*args, "--frequencies", "2,5"]) == 0
    before = snapshot(out)
    capsys.readouterr()

    assert sweep_cli.main([*args, "--frequencies", "2,5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"error: --output {out}: holds an earlier sweep (sweep.csv, sweep.json, 2 rows in "
        "sweep_rows/); continue it with --resume, write elsewhere with --output, or replace it "
        "with --overwrite"
    )
    assert sweep_cli.main([*args, "--frequencies", "8", "--set", "fluid.damping_ratio=0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--resume" not in err  # another case's rows cannot be continued
    assert err.startswith(f"error: --output {out}: holds a sweep of another case (")
    assert "fluid.damping_ratio: 0.05 -> 0.1; sweep.csv, sweep.json" in err
    assert err.endswith("write elsewhere with --output, or replace it with --overwrite")
    assert calls == [["sine_2Hz", "sine_5Hz"]]  # no point ran
    assert snapshot(out) == before  # the folder untouched

    assert sweep_cli.main([*args, "--frequencies", "8", "--overwrite"]) == 0
    assert calls[-1] == ["sine_8Hz"]
    assert [(r["frequency_hz"], r["tip_amplitude_m"]) for r in table(out)] == [("8.0", "0.002")]
    assert sorted(p.name for p in (out / "sweep_rows").iterdir()) == ["sine_8Hz.json"]


def test_an_array_task_is_refused_only_by_its_own_result_or_another_case(
    tmp_path, monkeypatch, capsys
):
    """--point K (a SLURM array task; the tasks write into one folder, at once or one after
    another) runs beside its siblings' rows and runs, but is refused (exit 2, nothing run or
    written) where its own row or run is there already (--resume continues it, --overwrite
    replaces that row alone) or the folder holds a sweep of another case."""
    calls = stub_linear(monkeypatch)
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2,5", "--waveforms", "sine"]
    args += ["--output", str(out), "--quiet"]
    assert sweep_cli.main([*args, "--point", "0"]) == 0
    assert sweep_cli.main([*args, "--point", "1"]) == 0  # its sibling's row is there
    assert calls == [["sine_2Hz"], ["sine_5Hz"]]
    assert points(table(out)) == [("sine", 2.0), ("sine", 5.0)]
    before = snapshot(out)
    capsys.readouterr()

    assert sweep_cli.main([*args, "--point", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"error: --output {out}: holds point 1's earlier result (sweep_rows/sine_5Hz.json); "
        "continue it with --resume, write elsewhere with --output, or replace it with "
        "--overwrite"
    )
    assert sweep_cli.main([*args, "--point", "0", "--set", "fluid.damping_ratio=0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: --output {out}: holds a sweep of another case (fluid.")
    assert sweep_cli.main([*args, "--point", "1", "--resume"]) == 0  # done: nothing runs
    assert calls[2:] == [[]]
    assert snapshot(out) == before

    assert sweep_cli.main([*args, "--point", "1", "--overwrite"]) == 0
    assert calls[-1] == ["sine_5Hz"]
    rows = table(out)
    assert [(r["frequency_hz"], r["tip_amplitude_m"]) for r in rows] == [
        ("2.0", "0.001"),  # the sibling's row stays
        ("5.0", "0.004"),
    ]

    # a transient task killed in its point (a checkpoint, no row): its run counts, not a
    # sibling's
    calls_t: list = []
    stub_runs(monkeypatch, calls_t, {3.0: KeyboardInterrupt()})
    transient = [str(BEAM), *BEAM_SET, "--frequencies", "1,3", "--waveforms", "sine"]
    transient += ["--method", "transient", "--output", str(tmp_path / "t"), "--quiet"]
    assert sweep_cli.main([*transient, "--point", "1"]) == EXIT_INTERRUPTED
    capsys.readouterr()
    assert sweep_cli.main([*transient, "--point", "1"]) == 2
    assert "holds point 1's earlier result (sine_3Hz/); continue it with --resume" in (
        capsys.readouterr().err
    )
    assert sweep_cli.main([*transient, "--point", "0"]) == 0
    assert sweep_cli.main([*transient]) == 2  # the whole sweep: its row and the killed run
    assert "(sweep.csv, sweep.json, 1 row in sweep_rows/, sine_1Hz/ and 1 more point runs)" in (
        capsys.readouterr().err
    )
    assert calls_t == [("sine_3Hz", False), ("sine_1Hz", False)]


def test_a_refusal_under_mpi_stops_every_rank(tmp_path, monkeypatch, capsys):
    """Rank 0 checks the folder; its refusal reaches the other ranks (no rank left waiting
    for the points): rank 0 says it in one line, the others exit 2 without a word."""
    stub_linear(monkeypatch)
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2", "--waveforms", "sine"]
    args += ["--output", str(out), "--quiet"]
    assert sweep_cli.main(args) == 0
    capsys.readouterr()
    sent: list = []

    def world(rank: int) -> types.SimpleNamespace:
        def bcast(value, root):
            sent.append(value)
            return value if rank == 0 else sent[0]

        return types.SimpleNamespace(Get_rank=lambda: rank, Get_size=lambda: 2, bcast=bcast)

    monkeypatch.setattr(sweep_cli, "mpi_world", lambda: world(0))
    assert sweep_cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: --output {out}: holds an earlier sweep") and "\n" not in err
    monkeypatch.setattr(sweep_cli, "mpi_world", lambda: world(1))
    assert sweep_cli.main(args) == 2
    assert capsys.readouterr().err == ""
    assert sent[0][0] is None and sent[0][1] == err.removeprefix("error: ")


def stub_runs(monkeypatch, calls: list, fail: dict[float, BaseException] | None = None):
    """run_dynamic stubbed: records (point folder name, resume), writes a checkpoint into the
    point's folder first (as a real run does every few windows), then raises ``fail[f]``."""

    def stub(case, output, resume, show_progress):
        f = case.actuation.frequency_hz
        calls.append((output.name, resume))
        output.mkdir(parents=True, exist_ok=True)
        (output / "checkpoint.h5").write_bytes(b"")
        if fail and f in fail:
            raise fail[f]
        return {"tip_amplitude_m": 1e-3 * f, "mean_thrust_n": 1e-4 * f}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)


def test_mpi_ranks_take_the_next_free_point_not_every_other_one(tmp_path, monkeypatch):
    """Two ranks (threads sharing a fake MPI world): a rank held by a long point leaves the
    short ones to the other, where round-robin would give it every other point; every point
    runs once, rank 0 gathers the rows in order, and the launch's claims are cleared after
    (a killed launch's stay, and do not hold this one's points)."""
    import threading

    from fsi_orchestrator.case import load_case
    from fsi_orchestrator.case.schema import Waveform

    sync = threading.Barrier(2)
    parts: dict[int, list] = {}

    class World:
        def __init__(self, rank: int) -> None:
            self.rank = rank

        def Get_rank(self) -> int:
            return self.rank

        def Get_size(self) -> int:
            return 2

        def bcast(self, value, root):
            if self.rank == root:
                parts[-1] = value
            sync.wait(timeout=60)
            return parts[-1]

        def gather(self, value, root):
            parts[self.rank] = value
            sync.wait(timeout=60)
            return [parts[0], parts[1]] if self.rank == root else None

    ran: dict[float, str] = {}

    def stub(case, output, resume, show_progress):
        f = case.actuation.frequency_hz
        ran[f] = threading.current_thread().name
        time.sleep(1.5 if f == 1.0 else 0.05)
        return {"tip_amplitude_m": 1e-3 * f, "mean_thrust_n": 1e-4 * f}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    case = load_case(BEAM, ["actuation.mean_strain_transfer=0"])
    out = tmp_path / "sweep"
    killed = out / sweep_cli.PointClaims.FOLDER / "killed"
    killed.mkdir(parents=True)
    (killed / "sine_3Hz").touch()
    rows: dict[int, list] = {}

    def rank(r: int) -> None:
        rows[r] = sweep_cli.transient_sweep(
            case, [1.0, 2.0, 3.0, 4.0, 5.0], [Waveform.SINE], out, comm=World(r)
        )

    threads = [threading.Thread(target=rank, args=(r,), name=f"rank{r}") for r in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert sorted(ran) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert [f for f, name in ran.items() if name == ran[1.0]] == [1.0]
    assert [r["frequency_hz"] for r in rows[0]] == [1.0, 2.0, 3.0, 4.0, 5.0] and rows[1] == []
    assert [p.name for p in (out / sweep_cli.PointClaims.FOLDER).iterdir()] == ["killed"]


def test_a_resumed_transient_sweep_reruns_failed_and_continues_killed_points(
    tmp_path, monkeypatch, capsys
):
    """A transient sweep killed at its 3rd point (2 Hz done, 4 Hz failed, 6 Hz killed with a
    checkpoint): --resume runs 4 Hz afresh, continues 6 Hz from its checkpoint (fsi-run's
    --resume) in its stable folder, runs 8 Hz, and leaves 2 Hz alone."""
    out = tmp_path / "sweep"
    args = ["--frequencies", "2,4,6,8", "--waveforms", "sine", "--method", "transient"]
    args = [str(BEAM), *BEAM_SET, *args, "--output", str(out)]
    calls: list = []
    crash = RuntimeError("pimpleFoam diverged\nmore")
    stub_runs(monkeypatch, calls, {4.0: crash, 6.0: KeyboardInterrupt()})
    assert sweep_cli.main(args) == EXIT_INTERRUPTED
    assert calls == [("sine_2Hz", False), ("sine_4Hz", False), ("sine_6Hz", False)]
    rows = table(out)
    assert [(r["frequency_hz"], status(r)) for r in rows] == [
        ("2.0", "ok"),
        ("4.0", "failed: pimpleFoam diverged"),
    ]
    err = capsys.readouterr().err
    assert "sweep: point 2/4 sine 4 Hz" in err and "failed: pimpleFoam diverged" in err
    assert f"(output kept in {out / 'sine_4Hz'}; the whole error in failure.txt there)" in err
    # the row keeps the first line; the point's folder the whole error (the log it quotes is
    # overwritten when the point reruns)
    assert (out / "sine_4Hz" / "failure.txt").read_text() == "pimpleFoam diverged\nmore\n"

    (out / "sine_4Hz" / "checkpoint.h5").unlink()  # it failed before its first checkpoint
    calls.clear()
    stub_runs(monkeypatch, calls)
    assert sweep_cli.main([*args, "--resume"]) == 0
    assert calls == [("sine_4Hz", False), ("sine_6Hz", True), ("sine_8Hz", False)]
    rows = table(out)
    assert points(rows) == [("sine", f) for f in (2.0, 4.0, 6.0, 8.0)]
    assert all(status(r) == "ok" for r in rows)
    assert [float(r["tip_amplitude_m"]) for r in rows] == pytest.approx([2e-3, 4e-3, 6e-3, 8e-3])
    assert not (out / "sine_4Hz" / "failure.txt").exists()  # the rerun went through

    calls.clear()  # all done: nothing runs
    assert sweep_cli.main([*args, "--resume"]) == 0
    assert calls == []
    calls.clear()  # without --resume the folder is refused; --overwrite runs everything afresh
    assert sweep_cli.main(args) == 2
    assert calls == []
    assert sweep_cli.main([*args, "--overwrite"]) == 0
    assert calls == [(f"sine_{f}Hz", False) for f in (2, 4, 6, 8)]


def test_sigterm_stops_the_sweep_with_its_rows_kept_and_says_resume(tmp_path, monkeypatch, capsys):
    """SLURM's time limit (and scancel) sends SIGTERM: the sweep stops in one line, exit 130,
    its finished rows kept; afterwards SIGTERM is back to what it was."""
    calls: list = []

    def stub(case, output, resume, show_progress):
        calls.append(output.name)
        if case.actuation.frequency_hz == 4.0:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the signal arrives first
        return {"tip_amplitude_m": 1e-3}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    out = tmp_path / "sweep"
    args = stubbed_transient_sweep(out, "2,4,6")
    assert sweep_cli.main(args) == EXIT_INTERRUPTED
    assert calls == ["sine_2Hz", "sine_4Hz"]
    assert points(table(out)) == [("sine", 2.0)]
    err = capsys.readouterr().err.strip()
    assert err == "interrupted: results so far are kept; continue with --resume"
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_point_stopped_before_its_first_checkpoint_says_resume_not_overwrite(
    tmp_path, monkeypatch, capsys
):
    """fsi-run tells a run stopped before its first checkpoint to start again with --overwrite;
    in a sweep that flag would throw the finished points away, and --resume reruns the point."""
    from fsi_orchestrator.loop import NO_CHECKPOINT
    from fsi_orchestrator.participant import ParticipantStopped

    stops = {
        4.0: KeyboardInterrupt(f"window 1 did not finish: pimpleFoam stopped; {NO_CHECKPOINT}")
    }

    def stub(case, output, resume, show_progress):
        if stop := stops.pop(case.actuation.frequency_hz, None):
            raise stop
        return {"tip_amplitude_m": 1e-3}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    out = tmp_path / "sweep"
    args = stubbed_transient_sweep(out, "2,4,6")
    assert sweep_cli.main(args) == EXIT_INTERRUPTED
    assert capsys.readouterr().err.strip() == (
        "interrupted: sine 4 Hz: window 1 did not finish: pimpleFoam stopped; no checkpoint "
        "yet: --resume runs it again"
    )
    assert points(table(out)) == [("sine", 2.0)]
    # a solver stopped outside the windows keeps its kind: the line says what is kept
    stops[6.0] = ParticipantStopped("pimpleFoam was stopped by SIGTERM in c")
    assert sweep_cli.main([*args, "--resume"]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err.strip() == (
        "interrupted: sine 6 Hz: pimpleFoam was stopped by SIGTERM in c; results so far are "
        "kept; continue with --resume"
    )
    assert points(table(out)) == [("sine", 2.0), ("sine", 4.0)]


def test_a_point_another_launch_is_running_is_left_to_it(tmp_path, monkeypatch, capsys):
    """Two launches into one --output (a job submitted twice, a --resume while the first still
    runs) ran the same point in the same folder, and its solver failed under the other. A
    point whose folder another process holds is left to that one; a later --resume runs it."""
    import fcntl

    calls: list = []

    def stub(case, output, resume, show_progress):
        calls.append(output.name)
        return {"tip_amplitude_m": 1e-3}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    out = tmp_path / "sweep"
    (out / "sine_4Hz").mkdir(parents=True)
    other = os.open(out / "sine_4Hz" / ".running", os.O_CREAT | os.O_WRONLY)
    fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)  # the other launch, running it
    args = stubbed_transient_sweep(out, "2,4,6")
    try:
        assert sweep_cli.main(args) == EXIT_FAILED  # a point has no row yet
    finally:
        os.close(other)
    assert calls == ["sine_2Hz", "sine_6Hz"]
    err = capsys.readouterr().err
    assert "note: sine 4 Hz: another fsi-sweep is running it in " in err
    assert err.strip().endswith(
        "sweep: 1 point(s) left to another launch running them (sine_4Hz): no row yet; "
        "--resume once it has ended"
    )
    assert points(table(out)) == [("sine", 2.0), ("sine", 6.0)]
    calls.clear()
    assert sweep_cli.main([*args, "--resume"]) == 0
    assert calls == ["sine_4Hz"]
    assert points(table(out)) == [("sine", f) for f in (2.0, 4.0, 6.0)]


def test_a_file_system_without_locks_runs_the_points_unlocked_with_a_note(
    tmp_path, monkeypatch, capsys
):
    """Lustre without its flock option refuses flock (ENOSYS): the sweep runs, says once that
    its points are not locked, and exits 0."""
    import errno
    import fcntl

    def no_locks(fd, op):
        raise OSError(errno.ENOSYS, "Function not implemented")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    monkeypatch.setattr(
        run_cli, "run_dynamic", lambda case, output, resume, show_progress: {"tip_amplitude_m": 1}
    )
    args = stubbed_transient_sweep(tmp_path / "sweep", "2,4")
    assert sweep_cli.main(args) == 0
    err = capsys.readouterr().err
    assert err.count("cannot lock ([Errno 38] Function not implemented); points run unlocked") == 1


def test_sigterm_stops_a_linear_sweep_of_a_fish_in_the_tank_in_one_line(tmp_path):
    """The potential flow's gmsh mesher left SIGTERM at its C default, and a linear sweep was
    killed without a word (exit 143): the handler is put back after meshing."""
    out = tmp_path / "sweep"
    sweep = subprocess.Popen(
        [sys.executable, "-m", "fishfsi.cli.sweep", str(ROOT / "cases/fixed_head_3Hz")]
        + ["--set", "fluid.edge_drag=true", "--frequencies", "1:25:0.5", "--output", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert sweep.stderr is not None
    for line in sweep.stderr:  # the mesh is built before the first point
        if line.startswith("sweep: point 1/"):
            break
    sweep.send_signal(signal.SIGTERM)
    rest = sweep.stderr.read().strip().splitlines()
    assert sweep.wait(timeout=60) == EXIT_INTERRUPTED
    assert rest[-1] == "interrupted: results so far are kept; continue with --resume"
    assert (out / "sweep.csv").is_file()  # the finished points' rows


def test_a_transient_point_with_a_nan_result_fails_the_sweep(tmp_path, monkeypatch, capsys):
    """A run that returns NaN (no exception) is a failed row: exit 1, the other rows kept. A
    figure the run does not give (a beam's thrust) stays NaN without failing."""

    def stub(case, output, resume, show_progress):
        f = case.actuation.frequency_hz
        return {"tip_amplitude_m": float("nan") if f == 4.0 else 1e-3}

    monkeypatch.setattr(run_cli, "run_dynamic", stub)
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2,4,6", "--waveforms", "sine"]
    args += ["--method", "transient", "--output", str(out), "--quiet"]
    assert sweep_cli.main(args) == EXIT_FAILED
    rows = table(out)
    assert [status(r) for r in rows] == [
        "ok",
        "failed: tip_amplitude_m not finite (the run's result)",
        "ok",
    ]
    err = capsys.readouterr().err
    assert "sweep: point 2/3 sine 4 Hz" in err  # shown although --quiet
    assert "1 of 3 points failed" in err


def test_a_singular_tangent_stops_the_linear_sweep_in_one_line(tmp_path, monkeypatch, capsys):
    """A wet mode at 0 Hz (what a mechanism, or a plate buckled by the mean voltages, gives:
    the integrative preset divided by it and printed NaN with exit 0): one line naming the
    step, exit 1, no NumPy warnings."""
    from solid_adapter.harmonic import ModalSweep

    real = ModalSweep.build.__func__

    def singular(cls, *args, **kwargs):
        sweep = real(cls, *args, **kwargs)
        omegas = sweep.omegas.copy()
        omegas[0] = 0.0
        return dataclasses.replace(
            sweep, omegas=omegas, zetas=np.where(omegas > 0, sweep.zetas, np.nan)
        )

    monkeypatch.setattr(ModalSweep, "build", classmethod(singular))
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2,8", "--waveforms", "sine", "--quiet"]
    assert sweep_cli.main([*args, "--output", str(tmp_path / "sweep")]) == EXIT_FAILED
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip()
    assert "\n" not in err and "Warning" not in err
    assert err.startswith("error: linear sweep, modal step: the tangent about the mean-voltage")
    assert "singular or indefinite (wet mode 1 at 0 Hz" in err


def test_a_nan_point_of_the_linear_sweep_fails_it_and_keeps_the_other_rows(
    tmp_path, monkeypatch, capsys
):
    import fluid_adapter.slender_body as slender_body

    real = slender_body.mean_thrust_from_shell

    def nan_at_8hz(*args, **kwargs):
        value = real(*args, **kwargs)
        return float("nan") if abs(kwargs["period_s"] - 1 / 8) < 1e-12 else value

    monkeypatch.setattr(slender_body, "mean_thrust_from_shell", nan_at_8hz)
    out = tmp_path / "sweep"
    args = [str(BEAM), *BEAM_SET, "--frequencies", "2,8,20", "--waveforms", "sine"]
    assert sweep_cli.main([*args, "--output", str(out), "--json"]) == EXIT_FAILED
    rows = table(out)
    assert [status(r) for r in rows] == [
        "ok",
        "failed: slender_body_mean_thrust_n, mean_thrust_n not finite (linear response)",
        "ok",
    ]
    assert float(rows[2]["tip_amplitude_m"]) > 0
    assert len(json.loads(capsys.readouterr().out)["rows"]) == 3


def fake_mpi4py(size: int) -> types.ModuleType:
    world = types.SimpleNamespace(Get_size=lambda: size, Get_rank=lambda: 0)
    module = types.ModuleType("mpi4py")
    module.MPI = types.SimpleNamespace(COMM_WORLD=world)
    return module


LAUNCHER_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS", "PMIX_RANK")


@pytest.mark.parametrize(
    "env, mpi4py, expected",
    [
        (
            {"OMPI_COMM_WORLD_SIZE": "4"},
            1,
            "launched as 4 tasks (OMPI_COMM_WORLD_SIZE=4) but mpi4py sees an MPI world of 1",
        ),
        (
            {"PMI_SIZE": "3"},
            1,
            "launched as 3 tasks (PMI_SIZE=3) but mpi4py sees an MPI world of 1",
        ),
        (
            {"SLURM_STEP_NUM_TASKS": "2", "SLURM_NTASKS": "2"},
            None,
            "launched as 2 tasks (SLURM_STEP_NUM_TASKS=2) but mpi4py is not installed",
        ),
        (
            {"SLURM_STEP_NUM_TASKS": "4"},
            2,
            "launched as 4 tasks (SLURM_STEP_NUM_TASKS=4) but mpi4py sees an MPI world of 2",
        ),
    ],
)
def test_a_launch_that_mpi4py_does_not_see_is_refused_in_one_line(
    tmp_path, monkeypatch, capsys, env, mpi4py, expected
):
    for var in LAUNCHER_VARS:
        monkeypatch.delenv(var, raising=False)
    for var, value in env.items():
        monkeypatch.setenv(var, value)
    monkeypatch.setitem(sys.modules, "mpi4py", None if mpi4py is None else fake_mpi4py(mpi4py))
    args = [str(BEAM), "--frequencies", "2", "--output", str(tmp_path / "sweep")]
    assert sweep_cli.main(args) == EXIT_FAILED
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"error: {expected}")
    assert "install mpi4py built against the launcher's MPI" in err
    assert "run fsi-sweep as one task" in err
    assert not (tmp_path / "sweep").exists()  # before any work


@pytest.mark.parametrize(
    "env, mpi4py, size",
    [
        ({}, 1, None),  # no launcher: mpi4py is not even asked
        ({"SLURM_NTASKS": "4"}, 1, None),  # a batch script itself: one process, no step
        ({"OMPI_COMM_WORLD_SIZE": "1"}, 1, None),
        ({"SLURM_STEP_NUM_TASKS": "2"}, 2, 2),
    ],
)
def test_a_matching_launch_gives_its_world(monkeypatch, env, mpi4py, size):
    for var in LAUNCHER_VARS:
        monkeypatch.delenv(var, raising=False)
    for var, value in env.items():
        monkeypatch.setenv(var, value)
    monkeypatch.setitem(sys.modules, "mpi4py", fake_mpi4py(mpi4py))
    world = sweep_cli.mpi_world()
    assert (world.Get_size() if world is not None else None) == size


def test_a_real_mismatched_launch_exits_non_zero(tmp_path):
    """The real mpi4py (a one-process world here) under a launcher's variable: the command
    stops at once in one line, exit 1."""
    env = {k: v for k, v in os.environ.items() if k not in LAUNCHER_VARS}
    proc = subprocess.run(
        [FSI_SWEEP, str(BEAM), "--frequencies", "2", "--output", str(tmp_path / "s")],
        env={**env, "PMI_SIZE": "2"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 1
    assert proc.stderr.startswith("error: launched as 2 tasks (PMI_SIZE=2) but mpi4py sees")
    assert proc.stderr.count("\n") == 1


@pytest.mark.slow
def test_a_sweep_killed_by_sigkill_keeps_its_rows_and_resumes(tmp_path):
    """A real transient sweep, killed (SIGKILL: no clean-up at all) after its first point:
    its table holds that row; --resume runs the other points only (stderr, not a terminal,
    names each point that ran)."""
    out = tmp_path / "sweep"
    cmd = [FSI_SWEEP, str(BEAM), *BEAM_SET, *SHORT_RUN, "--method", "transient"]
    cmd += ["--frequencies", "2,8,20", "--waveforms", "sine", "--output", str(out)]
    log = open(tmp_path / "killed.log", "w")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 600
    while not (out / "sweep.csv").is_file():  # merged right after the first row is written
        assert proc.poll() is None, (tmp_path / "killed.log").read_text()
        assert time.monotonic() < deadline
        time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    first = table(out)
    assert points(first) == [("sine", 2.0)]
    resumed = subprocess.run([*cmd, "--resume"], capture_output=True, text=True, timeout=900)
    assert resumed.returncode == 0, resumed.stderr
    ran = [line.split(":")[1] for line in resumed.stderr.splitlines() if "sweep: point" in line]
    assert ran == [" point 2/3 sine 8 Hz", " point 3/3 sine 20 Hz"]
    rows = table(out)
    assert points(rows) == [("sine", 2.0), ("sine", 8.0), ("sine", 20.0)]
    assert rows[0] == first[0]


# small, well-converged transient points (a tenth of the drive: a few Newton iterations per
# window), two periods each, a checkpoint every 4 of their 16 windows
RESUME_RUN = [
    *BEAM_SET,
    *("--set", "fluid.model=potential", "--set", "time.periods=2"),
    *("--set", "time.steps_per_period=8", "--set", "output.checkpoint_every=4"),
    *("--set", "actuation.left_volts=[-50,150]", "--set", "actuation.right_volts=[-50,150]"),
    *("--method", "transient", "--frequencies", "2,3", "--waveforms", "sine", "--quiet"),
]


def assert_rows_match(got: list[dict], want: list[dict], rel: float = 1e-6) -> float:
    """Every column of every row: text equal, numbers to ``rel`` (absolute where the value
    is ~0, NaN where the other is NaN); returns the largest relative difference seen."""
    assert [list(r) for r in got] == [list(r) for r in want]
    worst = 0.0
    for a, b in zip(got, want, strict=True):
        for key, value in b.items():
            try:
                x, y = float(a[key]), float(value)
            except ValueError:  # waveform, thrust_source, status
                assert a[key] == value, key
                continue
            if np.isnan(y) or np.isinf(y):
                assert str(x) == str(y), (key, a[key], value)
                continue
            scale = max(abs(y), 1e-12)
            worst = max(worst, abs(x - y) / scale)
            assert abs(x - y) <= rel * scale, (a["frequency_hz"], key, a[key], value)
    return worst


@pytest.mark.slow
def test_a_killed_and_resumed_transient_sweep_gives_the_uninterrupted_rows(
    tmp_path, capsys, monkeypatch
):
    """Issue 27's target: a sweep killed mid-way (SIGKILL after its first row, in its second
    point between two checkpoints) and resumed gives the uninterrupted sweep's rows to 1e-6.
    The resume covers both paths: the finished point is skipped, the killed one continues
    from its checkpoint (window 4..15 of 16). About 40 s on one core."""
    whole = tmp_path / "whole"
    assert sweep_cli.main([str(BEAM), *RESUME_RUN, "--output", str(whole)]) == 0
    capsys.readouterr()

    out = tmp_path / "killed"
    cmd = [FSI_SWEEP, str(BEAM), *RESUME_RUN, "--output", str(out)]
    log = open(tmp_path / "killed.log", "w")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    checkpoint = out / "sine_3Hz" / CHECKPOINT_FILE
    deadline = time.monotonic() + 300
    while not ((out / "sweep.csv").is_file() and checkpoint.is_file()):
        assert proc.poll() is None, (tmp_path / "killed.log").read_text()
        assert time.monotonic() < deadline
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    log.close()
    assert points(table(out)) == [("sine", 2.0)]
    killed_at = int(read_checkpoint(checkpoint)[0]["window"])
    assert 4 <= killed_at < 16  # the second point was killed between its checkpoints

    from fsi_orchestrator.loop import WindowLoop

    solve, solved = WindowLoop._solve_window, []

    def counted(loop):
        solved.append(loop.window)
        return solve(loop)

    monkeypatch.setattr(WindowLoop, "_solve_window", counted)
    assert sweep_cli.main([str(BEAM), *RESUME_RUN, "--output", str(out), "--resume"]) == 0
    assert "afresh" not in capsys.readouterr().err
    assert solved == list(range(killed_at, 16))  # 2 Hz skipped, 3 Hz from its checkpoint

    got, want = table(out), table(whole)
    assert points(want) == [("sine", 2.0), ("sine", 3.0)]
    worst = assert_rows_match(got, want)
    print(f"killed at window {killed_at}/16; largest relative difference {worst:.2e}")


# --- a real one-node SLURM (docs: /work/shared/notes/slurm-local.md) ---------------------


@pytest.fixture(scope="module")
def slurm(tmp_path_factory):
    """slurmctld, slurmd (and munged if none runs) started by hand on this machine; the
    environment to submit with. Skips, with the reason, where that cannot be done."""
    missing = [
        b
        for b in ("slurmctld", "slurmd", "munged", "sbatch", "sinfo", "munge")
        if shutil.which(b) is None
    ]
    if missing:
        pytest.skip(
            f"no SLURM here ({', '.join(missing)} missing: apt-get install -y "
            "slurm-wlm munge libpmix-dev)"
        )
    if os.geteuid() != 0:
        pytest.skip("starting slurmd by hand needs root")
    if not Path("/etc/munge/munge.key").is_file():
        pytest.skip("no /etc/munge/munge.key")
    base = tmp_path_factory.mktemp("slurm")
    for sub in ("state", "spool", "log"):
        (base / sub).mkdir()
    host = socket.gethostname().split(".")[0]
    node = subprocess.run(["slurmd", "-C"], capture_output=True, text=True).stdout.splitlines()
    if not node or not node[0].startswith("NodeName="):
        pytest.skip("slurmd -C did not describe this node")
    conf = base / "slurm.conf"
    conf.write_text(
        "\n".join(
            [
                "ClusterName=t",
                f"SlurmctldHost={host}",
                "SlurmUser=root",
                "AuthType=auth/munge",
                f"StateSaveLocation={base}/state",
                f"SlurmdSpoolDir={base}/spool",
                f"SlurmctldPidFile={base}/ctld.pid",
                f"SlurmdPidFile={base}/d.pid",
                f"SlurmctldLogFile={base}/log/ctld.log",
                f"SlurmdLogFile={base}/log/d.log",
                "ProctrackType=proctrack/linuxproc",
                "TaskPlugin=task/none",
                "JobAcctGatherType=jobacct_gather/none",
                "SelectType=select/cons_tres",
                "SelectTypeParameters=CR_CPU",
                "MpiDefault=pmix",
                "ReturnToService=2",
                "MailProg=/bin/true",
                "MinJobAge=5",
                "SchedulerParameters=batch_sched_delay=0",
                node[0],
                f"PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP",
                "",
            ]
        )
    )
    env = {**os.environ, "SLURM_CONF": str(conf)}
    for var in LAUNCHER_VARS:
        env.pop(var, None)
    started = []
    if subprocess.run(["munge", "-n"], capture_output=True).returncode != 0:
        Path("/run/munge").mkdir(parents=True, exist_ok=True)
        shutil.chown("/run/munge", "munge", "munge")
        started.append(
            subprocess.Popen(
                ["setpriv", "--reuid=munge", "--regid=munge", "--init-groups", "munged", "-F"],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
        time.sleep(0.3)
    for daemon in ("slurmctld", "slurmd"):
        started.append(
            subprocess.Popen(
                [daemon, "-D"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
            )
        )

    def stop():
        for proc in reversed(started):
            proc.terminate()
        for proc in reversed(started):
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    deadline = time.monotonic() + 20
    while True:
        state = subprocess.run(
            ["sinfo", "-h", "-o", "%T"], env=env, capture_output=True, text=True
        ).stdout.strip()
        if state == "idle":
            break
        if time.monotonic() > deadline or any(p.poll() is not None for p in started):
            stop()
            log = base / "log/ctld.log"
            tail = log.read_text().splitlines()[-1:] if log.exists() else []
            pytest.skip(f"slurmctld/slurmd did not come up (sinfo: {state!r}) {tail}")
        time.sleep(0.2)
    yield env
    stop()


@pytest.mark.slow
@pytest.mark.slurm
def test_slurm_sweep_script_runs_under_sbatch_and_resumes(slurm, tmp_path):
    """sbatch scripts/slurm_sweep.sh (2 tasks, srun + mpi4py over PMIx) on a tiny transient
    sweep: the batch script (a spool copy) finds the repository from $SLURM_SUBMIT_DIR, the
    two ranks share the points, every row is in sweep.csv and the log has a line per point; a
    resubmission with --resume runs nothing."""
    out = tmp_path / "sweep"
    log = tmp_path / "job.log"
    extra = [str(BEAM), *BEAM_SET, *SHORT_RUN, "--frequencies", "2,8", "--waveforms", "sine"]
    extra += ["--output", str(out)]
    submit = ["sbatch", "--wait", "--ntasks=2", "--time=20", f"--output={log}"]
    job = subprocess.run(
        [*submit, "scripts/slurm_sweep.sh", *extra],
        cwd=ROOT,
        env=slurm,
        capture_output=True,
        text=True,
        timeout=900,
    )
    text = log.read_text() if log.exists() else ""
    assert job.returncode == 0, job.stderr + text
    assert points(table(out)) == [("sine", 2.0), ("sine", 8.0)]
    assert all(status(r) == "ok" for r in table(out))
    assert "sweep: 2 points (transient, 2 MPI ranks)" in text
    done = [line.split(":")[1].split() for line in text.splitlines() if "sweep: point" in line]
    assert sorted(d[1] for d in done) == ["1/2", "2/2"]  # counted over both ranks
    assert sorted(d[3] for d in done) == ["2", "8"]
    log.unlink()
    job = subprocess.run(
        [*submit, "scripts/slurm_sweep.sh", *extra, "--resume"],
        cwd=ROOT,
        env=slurm,
        capture_output=True,
        text=True,
        timeout=300,
    )
    text = log.read_text()
    assert job.returncode == 0, job.stderr + text
    assert "2 done before (--resume)" in text and "sweep: point" not in text


@pytest.mark.slow
@pytest.mark.slurm
def test_slurm_array_script_runs_one_point_per_task_into_one_table(slurm, tmp_path):
    """sbatch --array=0-1 scripts/slurm_array.sh: each array task runs its own point
    (fsi-sweep --point $SLURM_ARRAY_TASK_ID) from $SLURM_SUBMIT_DIR, and both rows merge into
    one sweep.csv; a third task beyond the points fails in one line."""
    out = tmp_path / "sweep"
    extra = [str(BEAM), *BEAM_SET, *SHORT_RUN, "--output", str(out)]
    env = {**slurm, "FREQUENCIES": "2,8", "WAVEFORMS": "sine"}
    log = tmp_path / "task_%a.log"
    job = subprocess.run(
        ["sbatch", "--wait", "--array=0-2", "--time=20", f"--output={log}"]
        + ["--export=ALL", "scripts/slurm_array.sh", *extra],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    logs = [(tmp_path / f"task_{k}.log").read_text() for k in range(3)]
    assert job.returncode != 0  # the job array's state: one task failed
    assert points(table(out)) == [("sine", 2.0), ("sine", 8.0)], logs
    assert all(status(r) == "ok" for r in table(out))
    assert "sweep: 1 point (transient)" in logs[0] and "sweep: 1 point (transient)" in logs[1]
    assert (
        logs[2].strip().splitlines()[-1].startswith("error: --point 2: this sweep has points 0..1")
    )


@pytest.mark.slow
@pytest.mark.slurm
def test_a_two_level_array_starts_each_point_on_its_first_level_orbit(slurm, tmp_path, capsys):
    """The two-level curve on a cluster: a second job array with --dependency=aftercorr on the
    first and --start-from its folder starts each task when its own first-level point has
    finished, on that point's orbit. On the same model the started point continues the
    first-level run: its period is the second period of a two-period run, to 1e-6."""
    windows = ["--set", "time.steps_per_period=8"]
    one_period = [str(BEAM), *BEAM_SET, *windows, "--set", "time.periods=1"]
    env = {**slurm, "FREQUENCIES": "2,8", "WAVEFORMS": "sine"}
    first, second = tmp_path / "first", tmp_path / "second"
    submitted = subprocess.run(
        ["sbatch", "--parsable", "--array=0-1", "--time=20", f"--output={tmp_path}/a_%a.log"]
        + ["--export=ALL", "scripts/slurm_array.sh", *one_period, "--output", str(first)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert submitted.returncode == 0, submitted.stderr
    job = submitted.stdout.strip().split(";")[0]
    then = subprocess.run(
        ["sbatch", "--wait", "--array=0-1", f"--dependency=aftercorr:{job}", "--time=20"]
        + ["--kill-on-invalid-dep=yes"]
        + [f"--output={tmp_path}/b_%a.log", "--export=ALL", "scripts/slurm_array.sh"]
        + [*one_period, "--start-from", str(first), "--output", str(second)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    logs = "".join((tmp_path / f"b_{k}.log").read_text() for k in range(2))
    assert then.returncode == 0, then.stderr + logs
    assert "starts as usual" not in logs  # each found its first-level point finished
    assert all(status(r) == "ok" for r in table(first) + table(second))
    args = [str(BEAM), *BEAM_SET, *windows, "--set", "time.periods=2"]
    args += ["--set", "actuation.frequency_hz=2", "--json", "--quiet"]
    assert run_cli.main([*args, "--output", str(tmp_path / "two")]) == 0
    two_periods = json.loads(capsys.readouterr().out)["tip_amplitude_per_period_m"]
    started = {float(r["frequency_hz"]): float(r["tip_amplitude_m"]) for r in table(second)}
    assert started[2.0] == pytest.approx(two_periods[1], rel=1e-6)
    assert started[2.0] != pytest.approx(two_periods[0], rel=1e-3)  # not a start from scratch


def test_point_selects_one_point_and_frequencies_keep_the_key_range():
    from fishfsi.cli.sweep import parse_frequencies, select_point
    from fsi_orchestrator.case import CaseError
    from fsi_orchestrator.case.schema import Waveform

    both = [Waveform.SINE, Waveform.SQUARE]
    assert select_point([1.0, 3.0, 5.0], both, 4) == ([3.0], [Waveform.SQUARE])
    assert select_point([1.0], both, None) == ([1.0], both)
    with pytest.raises(CaseError, match=r"--point 6: this sweep has points 0..5"):
        select_point([1.0, 3.0, 5.0], both, 6)
    with pytest.raises(CaseError, match=r"--frequencies '1,2000': actuation.frequency_hz must"):
        parse_frequencies("1,2000")
