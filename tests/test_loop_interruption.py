"""A solver stopped from outside (SLURM's time limit signals every process of the job, the
solver too) ends a run as an interruption: one line naming the window that did not finish and
the checkpoint kept. A failure while the run itself was asked to stop is the same stop (mpirun
signalled itself exits 1, saying nothing of the signal); without that request it stays a
failure. tests/test_openfoam_coupled.py stops a real pimpleFoam.

Toy participant (the claim is about the loop): a structure whose window is a time step.
"""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.loop import OutputSettings, Schedule, WindowLoop
from fsi_orchestrator.participant import DISPLACEMENT, InterfaceMesh, ParticipantStopped

POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])


class Stopping:
    """Fails in window ``at`` (1-based) with ``error``."""

    name = "solid"

    def __init__(self, at: int, error: BaseException) -> None:
        self.time, self.windows, self.at, self.error = 0.0, 0, at, error
        self.failed = False

    def interface(self):
        return InterfaceMesh(POINTS.copy(), np.array([[0, 1, 2, 3]]), "quad")

    def read_data(self, data):
        pass

    def solve(self, dt):
        if self.windows + 1 == self.at:
            self.failed = True
            raise self.error
        self.time += dt
        self.windows += 1

    def write_data(self):
        return {DISPLACEMENT: np.zeros((4, 3))}

    def save_state(self):
        return {"time": self.time}

    def load_state(self, state):
        self.time = float(state["time"])


def run(tmp_path, at: int, error: BaseException, asked_to_stop: bool = False) -> None:
    """``asked_to_stop``: the SIGTERM reaches the run as its solver fails."""
    output = OutputSettings(directory=tmp_path / "out", vtk=False, checkpoint_every=2)
    solid = Stopping(at, error)
    loop = WindowLoop(
        solid,
        Schedule(dt=0.5, n_windows=10),
        output,
        interrupted=lambda: asked_to_stop and solid.failed,
    )
    loop.run()


STOPPED = "pimpleFoam was stopped by SIGTERM (a scheduler's time limit, scancel or Ctrl-C) in c"


def test_a_stopped_solver_names_the_window_and_the_checkpoint_kept(tmp_path):
    with pytest.raises(KeyboardInterrupt) as stop:
        run(tmp_path, 5, ParticipantStopped(STOPPED))
    assert str(stop.value) == (
        f"window 5 did not finish: {STOPPED}; the checkpoint after window 4 is kept: "
        "continue with --resume"
    )


def test_a_stop_before_any_checkpoint_says_to_run_again_over_the_folder(tmp_path):
    with pytest.raises(KeyboardInterrupt) as stop:
        run(tmp_path, 1, ParticipantStopped(STOPPED))
    assert str(stop.value).endswith("no checkpoint was written yet: run it again with --overwrite")


def test_a_failure_while_asked_to_stop_is_the_stop_and_otherwise_a_failure(tmp_path):
    failed = RuntimeError("pimpleFoam failed (exit 1) in c; case folder kept.\nlog tail")
    with pytest.raises(KeyboardInterrupt) as stop:
        run(tmp_path / "asked", 3, failed, asked_to_stop=True)
    assert str(stop.value) == (
        "window 3 did not finish: pimpleFoam failed (exit 1) in c; case folder kept.; the "
        "checkpoint after window 2 is kept: continue with --resume"
    )
    with pytest.raises(RuntimeError, match="exit 1"):
        run(tmp_path / "not_asked", 3, failed)


# fsi-run: what a Ctrl-C outside the windows says it keeps (the command's word, not the loop's)


def _stop_run(monkeypatch, tmp_path, case, *flags, writes_checkpoint=False, error=None):
    from fishfsi.cli import run as run_cli

    output = tmp_path / "out"

    def stopped(*args, **kwargs):
        if writes_checkpoint:
            (output / "checkpoint.h5").write_bytes(b"")
        raise error or KeyboardInterrupt

    monkeypatch.setattr(run_cli, "execute", stopped)
    return run_cli.main([str(case), "--output", str(output), "--quiet", *flags]), output


def test_a_dynamic_run_stopped_in_its_set_up_says_what_it_keeps(tmp_path, capsys, monkeypatch):
    import os
    from pathlib import Path

    dynamic = Path(__file__).resolve().parents[1] / "cases" / "fixed_head_3Hz"
    code, out = _stop_run(monkeypatch, tmp_path / "a", dynamic)
    assert code == 130
    assert capsys.readouterr().err == (
        "interrupted: stopped before the first checkpoint: nothing to resume; run it again\n"
    )
    # --overwrite over an earlier run: its checkpoint is older than this run, and stays its
    (tmp_path / "b" / "out").mkdir(parents=True)
    (tmp_path / "b" / "out" / "checkpoint.h5").write_bytes(b"")
    os.utime(tmp_path / "b" / "out" / "checkpoint.h5", (1e9, 1e9))
    code, _ = _stop_run(monkeypatch, tmp_path / "b", dynamic, "--overwrite")
    assert code == 130 and "the earlier run in the folder is as it was" in capsys.readouterr().err
    # a checkpoint this run wrote is continued
    (tmp_path / "c" / "out").mkdir(parents=True)
    code, _ = _stop_run(monkeypatch, tmp_path / "c", dynamic, writes_checkpoint=True)
    assert code == 130 and capsys.readouterr().err.endswith("continue with --resume\n")


def test_a_stopped_solver_in_a_run_without_checkpoints_says_to_run_it_again(
    tmp_path, capsys, monkeypatch
):
    from pathlib import Path

    modal = Path(__file__).resolve().parents[1] / "cases" / "swim_original_18Hz"
    code, _ = _stop_run(monkeypatch, tmp_path, modal, error=ParticipantStopped(STOPPED))
    assert code == 130
    assert capsys.readouterr().err == f"interrupted: {STOPPED}; nothing was written; run it again\n"
