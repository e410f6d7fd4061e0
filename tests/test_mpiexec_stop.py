"""A sweep stopped through Open MPI's mpiexec. mpiexec passes a SIGTERM or Ctrl-C on to its
ranks only T s later and kills them T s after that (odls_base_sigkill_timeout, 1 s by default;
orte/mca/odls/base/odls_base_default_fns.c), too short to finish a default-level window: the
sweep says so at launch, and with a longer T every rank ends its window with a checkpoint."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import h5py
import pytest

from fishfsi.cli.sweep import MPIEXEC_GRACE_S, mpiexec_stop_note
from fsi_orchestrator.results import read_checkpoint

ROOT = Path(__file__).resolve().parents[1]
FSI_SWEEP = str(ROOT / ".venv/bin/fsi-sweep")
HNP = "OMPI_MCA_orte_hnp_uri"
GRACE = "OMPI_MCA_odls_base_sigkill_timeout"


@pytest.mark.parametrize(
    ("env", "noted"),
    [
        ({HNP: "1.0;tcp://127.0.0.1:1"}, "1 s"),  # mpiexec's default
        ({HNP: "1.0;tcp://127.0.0.1:1", GRACE: "5"}, "5 s"),
        ({HNP: "1.0;tcp://127.0.0.1:1", GRACE: "not a number"}, "1 s"),
        ({HNP: "1.0;tcp://127.0.0.1:1", GRACE: str(MPIEXEC_GRACE_S)}, None),
        ({GRACE: "1"}, None),  # srun, or one process: no mpiexec in between
    ],
)
def test_the_note_names_mpiexecs_grace_and_the_setting_that_lengthens_it(monkeypatch, env, noted):
    for var in (HNP, GRACE):
        monkeypatch.delenv(var, raising=False)
    for var, value in env.items():
        monkeypatch.setenv(var, value)
    note = mpiexec_stop_note()
    if noted is None:
        assert note is None
    else:
        assert note is not None and note.startswith(f"note: mpiexec gives its ranks {noted} ")
        assert f"export {GRACE}={MPIEXEC_GRACE_S} before mpiexec" in note


def rows(results: Path) -> int:
    try:  # read while the run writes
        with h5py.File(results, "r", locking=False) as h5:
            return int(h5["time_s"].shape[0])
    except (OSError, KeyError):
        return 0


@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="no mpiexec on PATH")
def test_sigterm_to_mpiexec_with_a_grace_ends_every_ranks_window_with_a_checkpoint(tmp_path):
    """Two ranks, one point each (fish in vacuum: ~0.1 s windows); SIGTERM to mpiexec itself."""
    grace_s = 3
    out = tmp_path / "sweep"
    cmd = ["mpiexec", "-n", "2", FSI_SWEEP, str(ROOT / "cases/fish_vacuum_3Hz")]
    cmd += ["--set", "mesh.level=coarse", "--set", "time.periods=20", "--method", "transient"]
    cmd += ["--frequencies", "3,5", "--waveforms", "sine", "--output", str(out)]
    if os.geteuid() == 0:
        cmd.insert(1, "--allow-run-as-root")
    launch = subprocess.Popen(
        cmd,
        env={**os.environ, GRACE: str(grace_s)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 240
    results = [out / "sine_3Hz/results.h5", out / "sine_5Hz/results.h5"]
    while min(rows(r) for r in results) < 5:
        assert launch.poll() is None and time.monotonic() < deadline, "the points never started"
        time.sleep(0.2)
    launch.send_signal(signal.SIGTERM)
    _, err = launch.communicate(timeout=120)
    assert launch.returncode != 0, err
    assert f"note: mpiexec gives its ranks {grace_s} s from SIGTERM to SIGKILL" in err
    stopped = re.findall(
        r"interrupted: sine (\d) Hz: stopped after window (\d+) \(SIGTERM\) with a checkpoint "
        r"there; continue with --resume",
        err,
    )
    assert sorted(f for f, _ in stopped) == ["3", "5"], err
    for frequency, window in stopped:
        checkpoint = read_checkpoint(out / f"sine_{frequency}Hz/checkpoint.h5")[0]
        assert checkpoint["window"] == int(window) >= 5
