"""The two ways of driving pimpleFoam one coupling window at a time, plus a batch run.

``RelaunchDriver``: each window is one pimpleFoam launch from the last converged time folder,
which is the checkpoint: restoring deletes what came after it, so a window can be solved again
with new displacements (implicit coupling). Costs one start-up per window.

``PersistentDriver``: one pimpleFoam process for the whole run. At each window end the
``systemCall`` function object runs a three-line shell handshake over named pipes: it reports
"window done" and blocks until Python says "go". Python reads the window's loads, returns to the
coupling loop, writes the next window's displacement samples, then says "go". It cannot go back
in time (restore raises). ``systemCall`` is disabled for root, so as root the process runs as
``nobody`` (setpriv) on a case folder handed over to it. The sample folders of every planned
window exist from the start (the solver scans them once), see foamrun.py. Drivers turn the
window-end displacements they are given into the window's plate velocity.

``run_batch``: prescribed motion known in advance; every sample written first, one launch.
"""

from __future__ import annotations

import os
import select
import signal
import stat
import subprocess
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from . import runner
from .checkmesh import MeshQuality, parse_steps
from .errors import DriverError
from .foamrun import FoamRun
from .loads import SurfaceLoads

READY, GO = "ready.fifo", "go.fifo"
HANDSHAKE_SCRIPT = "handshake.sh"


def _start_folder(run: FoamRun, t: float, dt: float) -> str:
    return "0" if t == 0.0 else run.time_folder(t, dt)


class RelaunchDriver:
    """One pimpleFoam launch per window, restarting from the last time folder."""

    persistent = False

    def __init__(self, run: FoamRun, dt: float, t0: float = 0.0, u0: NDArray | None = None):
        self.run, self.dt = run, dt
        self.time = t0
        self.displacement = np.zeros_like(run.interface.points0) if u0 is None else u0.copy()
        self.checkpoint: tuple[float, NDArray] | None = None
        self.saved: float | None = None
        if t0 == 0.0:
            run.write_start(t0, dt)

    def advance(self, displacement: NDArray, dt: float) -> SurfaceLoads:
        run, t1 = self.run, self.time + dt
        start = _start_folder(run, self.time, self.dt)
        run.remove_samples(dt, after=self.time)
        run.write_window(self.time, t1, (displacement - self.displacement) / dt)
        run.reset_body_bc(start)
        run.set_window(start, t1, dt)
        runner.run(run.command())
        loads = run.loads(self.time, t1, self.displacement, displacement)
        self.time, self.displacement, self.dt = t1, displacement.copy(), dt
        self._prune()
        return loads

    def advance_prescribed(self, displacements: list[NDArray], dt: float) -> list[SurfaceLoads]:
        """Several windows whose displacements are known in advance, in one launch
        (``run_batch``; only the last time folder is written): each window's loads."""
        t0, path, n = self.time, [self.displacement, *displacements], len(displacements)
        loads = run_batch(self.run, lambda t: path[round((t - t0) / dt)], dt, n, t0)
        self.time, self.displacement, self.dt = t0 + n * dt, path[-1].copy(), dt
        self._prune()
        return loads

    def _kept_times(self) -> list[float]:
        kept = [self.time]
        kept += [self.checkpoint[0]] if self.checkpoint else []
        kept += [self.saved] if self.saved is not None else []
        return kept

    def _prune(self) -> None:
        names = {"0"} | {_start_folder(self.run, t, self.dt) for t in self._kept_times()}
        self.run.remove_times(names)
        self.run.remove_samples(self.dt, before=min(self._kept_times()))
        self.run.remove_load_samples(names - {"0"})

    def store(self) -> None:
        self.checkpoint = (self.time, self.displacement.copy())

    def restore(self) -> None:
        if self.checkpoint is None:
            raise DriverError("restore_checkpoint called before store_checkpoint")
        t, u = self.checkpoint
        self.run.remove_times({"0"}, after=t + 1e-6 * self.dt)
        self.run.remove_samples(self.dt, after=t)
        self.time, self.displacement = t, u.copy()

    def close(self) -> None:
        pass


class PersistentDriver:
    """One pimpleFoam process; a blocking handshake at every window end."""

    persistent = True

    def __init__(
        self,
        run: FoamRun,
        dt: float,
        n_windows: int,
        t0: float = 0.0,
        u0: NDArray | None = None,
    ) -> None:
        self.run, self.dt, self.n_windows = run, dt, n_windows
        self.t0, self.time, self.step = t0, t0, 0
        self.displacement = np.zeros_like(run.interface.points0) if u0 is None else u0.copy()
        self.saved: float | None = None
        self.proc: subprocess.Popen | None = None
        self.timing = {"adapter_s": 0.0, "solver_s": 0.0}  # Python's share vs waiting
        self._checkpoint_time: float | None = None
        self._fds: dict[str, int] = {}
        run.remove_samples(dt, after=t0)
        if t0 == 0.0:
            run.write_start(t0, dt)
        for k in range(1, n_windows + 1):
            run.write_window(self._window_end(k - 1), self._window_end(k), None)

    def _window_end(self, k: int) -> float:
        return self.t0 + k * self.dt

    # ------------------------------------------------------------------ start-up
    def _start(self) -> None:
        run = self.run
        start = _start_folder(run, self.t0, self.dt)
        run.reset_body_bc(start)
        end = self._window_end(self.n_windows)
        run.set_window(start, end, self.dt, handshake=self._handshake_script())
        runner.give_to_nobody(run.path)
        self.proc = runner.launch(run.command(unprivileged=True))

    def _handshake_script(self) -> str:
        for name in (READY, GO):
            path = self.run.path / name
            if path.exists():
                path.unlink()
            os.mkfifo(path)
            os.chmod(path, 0o666)  # umask-proof: the unprivileged solver must open them
            # O_RDWR: never blocks, and the pipe never reports end-of-file to us
            self._fds[name] = os.open(path, os.O_RDWR | os.O_NONBLOCK)
        ready, go = (self.run.path / READY).resolve(), (self.run.path / GO).resolve()
        script = self.run.path / HANDSHAKE_SCRIPT
        script.write_text(
            f'#!/bin/sh\necho ready > "{ready}"\nread answer < "{go}"\ntest "$answer" = go\n'
        )
        script.chmod(0o755)
        return f'"{script.resolve()}"'  # a quoted OpenFOAM string

    # ------------------------------------------------------------------ stepping
    def advance(self, displacement: NDArray, dt: float) -> SurfaceLoads:
        if abs(dt - self.dt) > 1e-9 * self.dt:
            raise DriverError(
                f"the persistent OpenFOAM driver planned windows of {self.dt:g} s, got "
                f'{dt:g} s; use fluid.driver = "relaunch" for varying windows'
            )
        if self.step >= self.n_windows:
            raise DriverError(f"the persistent OpenFOAM driver planned {self.n_windows} windows")
        k = self.step + 1
        start = time.perf_counter()
        velocity = (displacement - self.displacement) / dt
        self.run.write_window(self.time, self._window_end(k), velocity)
        if self.proc is None:
            self._start()
        else:
            self._send_go()
        waited = time.perf_counter()
        self._wait_ready()
        done = time.perf_counter()
        loads = self.run.loads(self.time, self._window_end(k), self.displacement, displacement)
        self.step, self.time = k, self._window_end(k)
        self.displacement = displacement.copy()
        self._prune()
        self.timing["solver_s"] += done - waited
        self.timing["adapter_s"] += (waited - start) + (time.perf_counter() - done)
        return loads

    def _send_go(self) -> None:
        for _ in range(self.run.processes):  # systemCall runs on every rank
            os.write(self._fds[GO], b"go\n")

    def _wait_ready(self) -> None:
        got = 0
        while got < self.run.processes:
            readable, _, _ = select.select([self._fds[READY]], [], [], 0.2)
            if readable:
                got += os.read(self._fds[READY], 4096).count(b"ready")
                continue
            assert self.proc is not None
            if self.proc.poll() is not None:
                runner.check_finished(self.run.command(), self.proc.returncode or 1)
                raise DriverError(f"pimpleFoam in {self.run.path} ended before the window end")
        runner.check_log(self.run.command())

    def _prune(self) -> None:
        keep = [self.time] + ([self.saved] if self.saved is not None else [])
        names = {"0"} | {self.run.time_folder(t, self.dt) for t in keep}
        self.run.remove_times(names)
        self.run.remove_load_samples(names - {"0"})
        self.run.remove_samples(self.dt, before=min(keep))

    def store(self) -> None:
        self._checkpoint_time = self.time

    def restore(self) -> None:
        if self._checkpoint_time != self.time:
            raise DriverError(
                "the persistent OpenFOAM driver cannot go back in time (implicit coupling "
                'needs it); set fluid.driver = "relaunch"'
            )

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        for fd in self._fds.values():
            os.close(fd)
        self._fds.clear()
        for name in (READY, GO):
            path = self.run.path / name
            if path.exists() and stat.S_ISFIFO(path.stat().st_mode):
                path.unlink()
        self.proc = None


def _write_batch_samples(
    run: FoamRun, displacement: Callable[[float], NDArray], dt: float, n_steps: int, t0: float
) -> list[float]:
    run.remove_samples(dt, after=t0)
    times = [t0 + k * dt for k in range(n_steps + 1)]
    if t0 == 0.0:
        run.write_start(t0, dt)
    for a, b in zip(times[:-1], times[1:], strict=True):
        run.write_window(a, b, (displacement(b) - displacement(a)) / dt)
    return times


def run_batch(
    run: FoamRun,
    displacement: Callable[[float], NDArray],
    dt: float,
    n_steps: int,
    t0: float = 0.0,
    write_every: int | None = None,
) -> list[SurfaceLoads]:
    """Prescribed motion: write all samples, run once, read every window's loads. Time folders
    are written every ``write_every`` windows (default: only the last)."""
    times = _write_batch_samples(run, displacement, dt, n_steps, t0)
    start = _start_folder(run, t0, dt)
    run.reset_body_bc(start)
    run.set_window(start, times[-1], dt, write_every=write_every or n_steps)
    runner.run(run.command())
    return [
        run.loads(a, b, displacement(a), displacement(b))
        for a, b in zip(times[:-1], times[1:], strict=True)
    ]


def run_mesh_motion(
    run: FoamRun,
    displacement: Callable[[float], NDArray],
    dt: float,
    n_steps: int,
    counts: tuple[int, int] = (0, 0),
) -> list[MeshQuality]:
    """Move the mesh only (``moveDynamicMesh``, no flow) through a prescribed motion, with a
    full mesh check after every step; returns the checks in time order."""
    _write_batch_samples(run, displacement, dt, n_steps, 0.0)
    run.reset_body_bc("0")
    run.set_window("0", n_steps * dt, dt, write_every=n_steps)
    run.set_controls(adjustTimeStep=False)
    log = runner.run(
        runner.Command(app="moveDynamicMesh", case=run.path, args=("-noFunctionObjects",))
    )
    return parse_steps(log.read_text(), counts)
