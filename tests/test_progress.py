"""Progress in every log and SIGTERM: a run without a terminal prints one line per window (or
every few seconds), set-up phases with their durations, nothing with --quiet; SIGTERM (SLURM's
time limit) ends a run after the running window with a checkpoint there, and --resume goes on
to the uninterrupted run's results."""

from __future__ import annotations

import io
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from fishfsi.cli.progress import RunProgress, duration, window_line
from fsi_orchestrator.results import read_checkpoint

ROOT = Path(__file__).resolve().parents[1]
FSI_RUN = [sys.executable, "-m", "fishfsi.cli.run"]
VACUUM = [str(ROOT / "cases/fish_vacuum_3Hz"), "--set", "mesh.level=coarse"]


def test_a_window_line_carries_window_time_solves_residual_and_eta():
    row = {"time_s": 0.125, "coupling/fluid_solves": 3, "coupling/residual": 2.1e-5}
    line = window_line(12, 80, row, wall_per_window=3.0)
    assert line.startswith("window 12/80")
    assert "t 0.125 s" in line and "fluid solves 3" in line and "residual 2.10e-05" in line
    assert "3 s/window" in line and line.endswith("ETA 3m24s")  # 68 windows x 3 s


def test_durations_read_as_seconds_minutes_hours():
    assert [duration(s) for s in (3.24, 245, 7380)] == ["3.2 s", "4m05s", "2h03m"]


def test_without_a_terminal_short_windows_are_reported_every_few_seconds():
    stream = io.StringIO()  # not a terminal
    progress = RunProgress(enabled=True, stream=stream)
    with progress.windows(1000) as on_window:
        for k in range(1, 1001):
            on_window(k, 1000, {"time_s": k * 1e-3, "wall_s": 1e-4})
    lines = stream.getvalue().splitlines()
    # the first window, then none within LINE_EVERY_S, and always the last one
    assert lines[0].startswith("window 1/1000") and lines[-1].startswith("window 1000/1000")
    assert len(lines) == 2


def test_long_windows_each_get_a_line_and_quiet_prints_nothing():
    stream = io.StringIO()
    with RunProgress(enabled=True, stream=stream).windows(3) as on_window:
        for k in (1, 2, 3):
            on_window(k, 3, {"time_s": k, "wall_s": 6.0})
    assert [s.split()[1] for s in stream.getvalue().splitlines()] == ["1/3", "2/3", "3/3"]
    held = io.StringIO()
    progress = RunProgress(enabled=True, stream=held, hold=True)
    with progress.phase("set-up"):
        pass
    assert held.getvalue() == ""  # a set-up that fails says so in its error line alone
    with progress.windows(3) as on_window:
        on_window(1, 3, {"wall_s": 6.0})
    assert held.getvalue().splitlines()[0].startswith("set-up: ")
    quiet = io.StringIO()
    progress = RunProgress(enabled=False, stream=quiet)
    with progress.phase("set-up"), progress.windows(3) as on_window:
        on_window(1, 3, {"wall_s": 6.0})
    assert quiet.getvalue() == ""


def test_a_run_in_a_log_announces_its_set_up_and_windows(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run(
        [*FSI_RUN, *VACUUM, "--set", "time.periods=0.25", "--output", str(out), "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    err = done.stderr.splitlines()
    assert re.fullmatch(r"set-up: structure: [0-9.]+ s", err[0])
    assert err[1].startswith("window 1/10 ") and err[-1].startswith("window 10/10 ")
    quiet = subprocess.run(
        [*FSI_RUN, *VACUUM, "--set", "time.periods=0.25", "--output", str(out) + "q", "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert quiet.returncode == 0 and quiet.stderr == ""


def wait_for_rows(results: Path, rows: int, process: subprocess.Popen, limit_s: float = 240):
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline and process.poll() is None:
        try:  # read while the run writes
            with h5py.File(results, "r", locking=False) as h5:
                if h5["time_s"].shape[0] >= rows:
                    return
        except (OSError, KeyError):
            pass
        time.sleep(0.2)
    raise AssertionError(f"{results}: fewer than {rows} rows in {limit_s} s")


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGINT], ids=["sigterm", "ctrl-c"])
def test_sigterm_ends_after_the_running_window_with_a_checkpoint_and_resume_goes_on(tmp_path, stop):
    """checkpoint_every = 1000: without the signal's checkpoint a resume would start at 0.
    SIGTERM (SLURM's time limit) and a first Ctrl-C (SIGINT) both end the running window."""
    settings = [*VACUUM, "--set", "time.periods=1", "--set", "output.checkpoint_every=1000"]
    settings += ["--set", "output.vtk=false", "--quiet"]
    killed = tmp_path / "killed"
    run = subprocess.Popen(
        [*FSI_RUN, *settings, "--output", str(killed)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for_rows(killed / "results.h5", 5, run)
    run.send_signal(stop)
    _, err = run.communicate(timeout=120)
    assert run.returncode == 130, err
    stopped = re.fullmatch(
        rf"interrupted: stopped after window (\d+) \({stop.name}\) with a checkpoint there; "
        r"continue with --resume",
        err.strip(),
    )
    assert stopped, err
    window = int(stopped.group(1))
    assert 5 <= window < 40
    assert read_checkpoint(killed / "checkpoint.h5")[0]["window"] == window

    resumed = subprocess.run(
        [*FSI_RUN, *settings, "--output", str(killed), "--resume"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert resumed.returncode == 0, resumed.stderr
    whole = tmp_path / "whole"
    straight = subprocess.run(
        [*FSI_RUN, *settings, "--output", str(whole)], capture_output=True, text=True, timeout=300
    )
    assert straight.returncode == 0, straight.stderr
    with h5py.File(killed / "results.h5") as a, h5py.File(whole / "results.h5") as b:
        tip_a, tip_b = a["shell/tip_displacement_m"][:], b["shell/tip_displacement_m"][:]
    assert tip_a.shape == tip_b.shape == (40, 3)
    np.testing.assert_allclose(tip_a, tip_b, rtol=0, atol=1e-12)
