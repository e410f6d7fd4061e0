"""The two ways of driving pimpleFoam one coupling window at a time, plus a batch run.

``RelaunchDriver``: each window is one pimpleFoam launch from the last converged time folder,
which is the checkpoint: restoring deletes what came after it, so a window can be solved again
with new displacements (implicit coupling). Costs one start-up per solve.

``PersistentDriver``: pimpleFoam stays loaded between windows. At each window end the
``systemCall`` function object runs a three-line shell handshake over named pipes: it reports
"window done" and blocks until Python says "go". Python reads the window's loads, returns to the
coupling loop, writes the next window's displacement samples, then says "go". Going back in
time ends the process and continues with one started from the checkpoint's folder.
``systemCall`` is disabled for root, so as root the process runs as ``nobody`` (setpriv) on a
case folder handed over to it. The sample folders of every planned window exist from the start
(a process scans them once, at start-up), see foamrun.py.

Prelaunch (both drivers, serial runs, implicit coupling): while a window is solved, the process
that solves it again, should the coupling not have converged, is started from the window's
start folder on another core and waits, loaded, at its start-up gate (runner.open_gate: a FIFO
included from ``constant/fvOptions``); its start-up (0.4 s at the default level) then costs
no wall time. Drivers turn the window-end displacements they are given into the window's plate
velocity.

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
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from . import runner
from .checkmesh import MeshQuality, parse_steps
from .errors import DriverError
from .foamrun import FoamRun
from .loads import SurfaceLoads

READY, GO, GATE = "ready.fifo", "go.fifo", "gate.fifo"
HANDSHAKE_SCRIPT = "handshake.sh"


def _start_folder(run: FoamRun, t: float, dt: float) -> str:
    return "0" if t == 0.0 else run.time_folder(t, dt)


def _fifo(path) -> None:
    """A fresh named pipe (whatever an ended process left in the old one is gone)."""
    if path.exists() or path.is_symlink():
        path.unlink()
    os.mkfifo(path)
    os.chmod(path, 0o666)  # umask-proof: an unprivileged solver must open it


@dataclass(eq=False)
class _Process:
    """One launched pimpleFoam: waiting at its start-up gate, running, or (persistent driver)
    paused in its handshake after the window ending at ``time``."""

    slot: int  # which log, gate, pipes and handshake script it uses (two at most at once)
    command: runner.Command
    proc: subprocess.Popen
    start: float  # the time folder it started from
    time: float
    fds: dict[str, int] = field(default_factory=dict)  # handshake pipes (persistent)


def _launch(
    run: FoamRun, slot: int, start: float, *, gated: bool, handshake: bool = False
) -> _Process:
    """pimpleFoam from the time folder at ``start`` (controlDict already set), with the slot's
    log, gate and handshake pipes: a launch's own files are named in its environment, so two
    processes can run from one controlDict."""
    name = "pimpleFoam" if slot == 0 else f"pimpleFoam.{slot}"
    gate = run.path / f"{GATE}.{slot}" if gated else None
    if gate is not None:
        _fifo(gate)
    fds, pipes = {}, None
    if handshake:
        pipes = (run.path / f"{READY}.{slot}", run.path / f"{GO}.{slot}")
        for key, pipe in zip((READY, GO), pipes, strict=True):
            _fifo(pipe)
            # read-write: never blocks, and the pipe never reports end-of-file to us
            fds[key] = os.open(pipe, os.O_RDWR | os.O_NONBLOCK)
    command = replace(
        run.command(unprivileged=handshake), log_name=name, gate=gate, handshake=pipes
    )
    return _Process(slot, command, runner.launch(command), start, start, fds)


def _remove_fifos(run: FoamRun) -> None:
    for path in run.path.glob("*.fifo.*"):
        if stat.S_ISFIFO(path.lstat().st_mode):
            path.unlink()


def _free_slot(*processes: _Process | None) -> int:
    return min({0, 1} - {p.slot for p in processes if p is not None})


def _end(process: _Process | None) -> None:
    """Stop a process that is not needed any more (waiting at a gate or a handshake: nothing
    is half-written) and close its pipes."""
    if process is None:
        return
    if process.proc.poll() is None:
        os.killpg(process.proc.pid, signal.SIGKILL)
    process.proc.wait()
    for fd in process.fds.values():
        os.close(fd)
    process.fds.clear()


class RelaunchDriver:
    """One pimpleFoam launch per solve, restarting from the last time folder."""

    persistent = False

    def __init__(
        self,
        run: FoamRun,
        dt: float,
        t0: float = 0.0,
        u0: NDArray | None = None,
        prelaunch: bool = False,
    ):
        self.run, self.dt = run, dt
        self.time = t0
        self.prelaunch = prelaunch
        self.displacement = np.zeros_like(run.interface.points0) if u0 is None else u0.copy()
        self.checkpoint: tuple[float, NDArray] | None = None
        self.saved: float | None = None
        self.ahead: _Process | None = None  # gated, from self.time: this window solved again
        self.launches = 0
        if prelaunch:
            runner.write_start_up_gate(run.path)
        if t0 == 0.0:
            run.write_start(t0, dt)

    def advance(self, displacement: NDArray, dt: float) -> SurfaceLoads:
        run, t1 = self.run, self.time + dt
        start = _start_folder(run, self.time, self.dt)
        run.remove_samples(dt, after=self.time)
        run.write_window(self.time, t1, (displacement - self.displacement) / dt)
        run.set_window(start, t1, dt)
        ahead, self.ahead = self.ahead, None
        if ahead is not None and ahead.start == self.time and ahead.time == t1:
            runner.open_gate(ahead.command, ahead.proc)  # its start folder is unchanged
            process = ahead
        else:
            _end(ahead)
            run.reset_body_bc(start)
            process = _launch(run, 0, self.time, gated=False)
            process.time = t1
            self.launches += 1
        if self.prelaunch and run.processes == 1:
            self.ahead = _launch(run, _free_slot(process), self.time, gated=True)
            self.ahead.time = t1
            self.launches += 1
        try:
            runner.wait_finished(process.command, process.proc)
        except Exception:
            _end(self.ahead)
            self.ahead = None
            raise
        loads = run.loads(self.time, t1, self.displacement, displacement)
        self.time, self.displacement, self.dt = t1, displacement.copy(), dt
        self._prune()
        return loads

    def advance_prescribed(self, displacements: list[NDArray], dt: float) -> list[SurfaceLoads]:
        """Several windows whose displacements are known in advance, in one launch
        (``run_batch``; only the last time folder is written): each window's loads."""
        _end(self.ahead)
        self.ahead = None
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
        if self.ahead is not None and self.ahead.start != self.time:
            _end(self.ahead)  # the window it was started for has converged
            self.ahead = None

    def restore(self) -> None:
        if self.checkpoint is None:
            raise DriverError("restore_checkpoint called before store_checkpoint")
        t, u = self.checkpoint
        self.run.remove_times({"0"}, after=t + 1e-6 * self.dt)
        self.run.remove_load_samples(set(), after=t + 1e-6 * self.dt)
        self.run.remove_samples(self.dt, after=t)
        self.time, self.displacement = t, u.copy()

    def release(self) -> None:
        """End the process loaded ahead: the next solve launches from the time folders as
        they are on disk (after the mesh's points were reset there)."""
        _end(self.ahead)
        self.ahead = None

    def close(self) -> None:
        self.release()
        _remove_fifos(self.run)


class PersistentDriver:
    """pimpleFoam processes that stay loaded: a blocking handshake after every window. A
    repeated window ends the process, which is past it, and goes on with the one prelaunched
    from the checkpoint (or a new one)."""

    persistent = True

    def __init__(
        self,
        run: FoamRun,
        dt: float,
        n_windows: int,
        t0: float = 0.0,
        u0: NDArray | None = None,
        prelaunch: bool = False,
    ) -> None:
        self.run, self.dt, self.n_windows = run, dt, n_windows
        self.t0, self.time, self.step = t0, t0, 0
        self.prelaunch = prelaunch
        self.displacement = np.zeros_like(run.interface.points0) if u0 is None else u0.copy()
        self.saved: float | None = None
        self.live: _Process | None = None  # paused at self.time, or about to solve from it
        self.spare: _Process | None = None  # gated, from the checkpoint
        self.launches = 0
        self.timing = {"adapter_s": 0.0, "solver_s": 0.0}  # Python's share vs waiting
        self._checkpoint: tuple[float, int, NDArray] | None = None
        self._script = self._write_handshake_script()
        if prelaunch:
            runner.write_start_up_gate(run.path)
        if t0 == 0.0:
            run.write_start(t0, dt)
        self._write_placeholders()

    def _window_end(self, k: int) -> float:
        return self.t0 + k * self.dt

    def _write_placeholders(self) -> None:
        """Every later window's sample folders (a process scans them once, at start-up)."""
        self.run.remove_samples(self.dt, after=self.time)
        for k in range(self.step + 1, self.n_windows + 1):
            self.run.write_window(self._window_end(k - 1), self._window_end(k), None)

    # ------------------------------------------------------------------ processes
    def _launch(self, *, gated: bool) -> _Process:
        """A process from the time folder at ``self.time``, in the slot no other one uses."""
        run = self.run
        folder = _start_folder(run, self.time, self.dt)
        run.reset_body_bc(folder)
        run.set_window(folder, self._window_end(self.n_windows), self.dt, handshake=self._script)
        runner.give_to_nobody(run.path)
        self.launches += 1
        slot = _free_slot(self.live, self.spare)
        return _launch(run, slot, self.time, gated=gated, handshake=True)

    def _write_handshake_script(self) -> str:
        """The handshake (its pipes come from the process's environment, runner.Command)."""
        script = self.run.path / HANDSHAKE_SCRIPT
        script.write_text(
            '#!/bin/sh\necho ready > "$FISHFSI_READY"\nread answer < "$FISHFSI_GO"\n'
            'test "$answer" = go\n'
        )
        script.chmod(0o755)
        return f'"{script.resolve()}"'  # a quoted OpenFOAM string

    def _solve_next_window(self) -> _Process:
        """Set the process for the next window going: the live one (paused at this time),
        the spare prelaunched from it, or a new one (which solves at once: the samples are
        written)."""
        live = self.live
        if live is not None and live.time == self.time and live.proc.poll() is None:
            for _ in range(self.run.processes):  # systemCall runs on every rank
                os.write(live.fds[GO], b"go\n")
            return live
        _end(live)
        self.live = None
        if self.spare is not None and self.spare.start == self.time:
            self.live, self.spare = self.spare, None
            runner.open_gate(self.live.command, self.live.proc)
        else:
            self.live = self._launch(gated=False)
        return self.live

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
        live = self._solve_next_window()
        repeatable = self._checkpoint is not None and self._checkpoint[0] == self.time
        if self.prelaunch and self.run.processes == 1 and self.spare is None and repeatable:
            self.spare = self._launch(gated=True)  # in case this window is solved again
        waited = time.perf_counter()
        self._wait_ready(live)
        done = time.perf_counter()
        loads = self.run.loads(self.time, self._window_end(k), self.displacement, displacement)
        self.step, self.time = k, self._window_end(k)
        live.time = self.time
        self.displacement = displacement.copy()
        self._prune()
        self.timing["solver_s"] += done - waited
        self.timing["adapter_s"] += (waited - start) + (time.perf_counter() - done)
        return loads

    def advance_prescribed(self, displacements: list[NDArray], dt: float) -> list[SurfaceLoads]:
        """Windows whose displacements are known in advance: one batch launch (no handshakes);
        the next window starts a process from its last time folder."""
        self.close()
        t0, path, n = self.time, [self.displacement, *displacements], len(displacements)
        loads = run_batch(self.run, lambda t: path[round((t - t0) / dt)], dt, n, t0)
        self.step, self.time = self.step + n, t0 + n * dt
        self.displacement = path[-1].copy()
        self._write_placeholders()
        self._prune()
        return loads

    def _wait_ready(self, process: _Process) -> None:
        got = 0
        while got < self.run.processes:
            readable, _, _ = select.select([process.fds[READY]], [], [], 0.2)
            if readable:
                got += os.read(process.fds[READY], 4096).count(b"ready")
                continue
            if process.proc.poll() is not None:
                runner.check_finished(process.command, process.proc.returncode or 1)
                raise DriverError(
                    f"pimpleFoam in {self.run.path} ended before the window end; see "
                    f"{process.command.log}"
                )
        runner.check_log(process.command)

    def _prune(self) -> None:
        keep = [self.time, self.saved, self._checkpoint[0] if self._checkpoint else None]
        times = [t for t in keep if t is not None]
        names = {"0"} | {_start_folder(self.run, t, self.dt) for t in times}
        self.run.remove_times(names)
        self.run.remove_load_samples(names - {"0"})
        self.run.remove_samples(self.dt, before=min(times))

    def store(self) -> None:
        self._checkpoint = (self.time, self.step, self.displacement.copy())
        if self.spare is not None and self.spare.start != self.time:
            _end(self.spare)  # the window it was started for has converged
            self.spare = None

    def restore(self) -> None:
        if self._checkpoint is None:
            raise DriverError("restore_checkpoint called before store_checkpoint")
        t, step, u = self._checkpoint
        if t == self.time:
            return
        _end(self.live)  # it is past the checkpoint and cannot go back
        self.live = None
        self.run.remove_times({"0"}, after=t + 1e-6 * self.dt)
        self.run.remove_load_samples(set(), after=t + 1e-6 * self.dt)
        self.time, self.step, self.displacement = t, step, u.copy()

    def release(self) -> None:
        """End the loaded processes: the next window launches from the time folders as they
        are on disk (after the mesh's points were reset there)."""
        _end(self.live)
        _end(self.spare)
        self.live = self.spare = None

    def close(self) -> None:
        self.release()
        _remove_fifos(self.run)


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
    write_every: int | None = None,
) -> list[MeshQuality]:
    """Move the mesh only (``moveDynamicMesh``, no flow) through a prescribed motion, with a
    full mesh check after every step; returns the checks in time order. Time folders are
    written every ``write_every`` steps (default: only the last)."""
    _write_batch_samples(run, displacement, dt, n_steps, 0.0)
    run.reset_body_bc("0")
    run.set_window("0", n_steps * dt, dt, write_every=write_every or n_steps)
    run.set_controls(adjustTimeStep=False)
    log = runner.run(
        runner.Command(
            app="moveDynamicMesh",
            case=run.path,
            args=("-noFunctionObjects",),
            processes=run.processes,
        )
    )
    return parse_steps(log.read_text(), counts)
