"""The time-window loop: drives participants window by window, records results as they come,
writes restart checkpoints and resumes from them.

This module knows solvers only through the Participant protocol.
"""

from __future__ import annotations

import dataclasses
import time as wallclock
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .coupling import Coupling
from .participant import (
    DISPLACEMENT,
    Monitored,
    Participant,
    ParticipantStopped,
    WritesFlowFields,
)
from .provenance import IDENTITY_ATTR, identity_changes
from .results import (
    CHECKPOINT_FILE,
    RESULTS_FILE,
    CorruptFile,
    PvdSeries,
    ResultsFile,
    VtkSeries,
    is_write_fault,
    read_checkpoint,
    stored_rows,
    write_checkpoint,
    write_failure,
)

# a stop before the first checkpoint: nothing to continue (fsi-sweep words it for a point)
NO_CHECKPOINT = "no checkpoint was written yet: run it again with --overwrite"


class ResumeError(RuntimeError):
    """No usable checkpoint to resume from."""


# what a run that cannot be resumed can do instead (its folder holds an earlier run's files)
AFRESH = "start it afresh: without --resume, with --overwrite to replace the folder's files"


@dataclass(frozen=True, kw_only=True)
class Schedule:
    dt: float
    n_windows: int


@dataclass(frozen=True, kw_only=True)
class OutputSettings:
    directory: Path
    vtk: bool = True
    vtk_every: int = 1
    checkpoint_every: int = 10
    # windows between a fluid's flow fields (participants with ``flow_fields()``); 0: none
    flow_every: int = 0
    attributes: dict[str, Any] = field(default_factory=dict)
    # the case's identity (provenance.case_identity): a checkpoint of another case is refused
    case_identity: str | None = None


# (windows done, windows in all, the window's results row)
ProgressFn = Callable[[int, int, dict[str, Any]], None]
# may end a run before its last window: (the results so far) -> why, or None to go on
StopRule = Callable[[ResultsFile], str | None]


class WindowLoop:
    """Runs ``solid`` alone, or coupled to a fluid through ``coupling``, over the schedule."""

    def __init__(
        self,
        solid: Participant,
        schedule: Schedule,
        output: OutputSettings,
        progress: ProgressFn | None = None,
        coupling: Coupling | None = None,
        stop: StopRule | None = None,
        interrupted: Callable[[], str | None] | None = None,
    ) -> None:
        self.solid, self.schedule, self.output = solid, schedule, output
        self.progress = progress or (lambda done, total, row: None)
        # asked to stop (the name of the signal that asked, e.g. SIGTERM): end after the
        # running window, with a checkpoint
        self.interrupted = interrupted or (lambda: None)
        self.coupling = coupling
        self.stop = stop or (lambda results: None)
        self.stopped: str | None = None  # why the run ended before its last window
        self.window = 0
        self._checkpointed: int | None = None  # the window of the last checkpoint written
        self._flow: dict[str, PvdSeries] = {}
        self._flow_keep_until: float | None = None

    @property
    def participants(self) -> dict[str, Participant]:
        found = {self.solid.name: self.solid}
        if self.coupling is not None:
            found[self.coupling.fluid.name] = self.coupling.fluid
        return found

    def _solve_window(self) -> dict[str, float]:
        if self.coupling is None:
            self.solid.solve(self.schedule.dt)
            return {}
        return self.coupling.solve_window(self.solid, self.schedule.dt, self.window)

    def run(self, resume: bool = False) -> Path:
        out = self.output.directory
        out.mkdir(parents=True, exist_ok=True)
        if resume:
            self._resume(out / CHECKPOINT_FILE)
            _check_results_reach(out / RESULTS_FILE, self.window)
        try:
            results = ResultsFile(out / RESULTS_FILE, resume_rows=self.window if resume else None)
        except (OSError, KeyError, ValueError) as err:  # checked above; e.g. another writer
            raise ResumeError(_unreadable_results(out / RESULTS_FILE, err)) from None
        results.set_attributes(self.output.attributes)
        vtk = self._vtk_writers(out / "vtk", keep_until=self.solid.time if resume else None)
        self._flow_keep_until = self.solid.time if resume else None
        try:
            if self.window > 0:  # a resumed run that had already ended stays ended
                self.stopped = self.stop(results)
            while self.window < self.schedule.n_windows and self.stopped is None:
                start = wallclock.perf_counter()
                running = self.window + 1
                try:
                    stats = self._solve_window()
                    self.window += 1
                    row = self._record(results, vtk, wallclock.perf_counter() - start, stats)
                except ParticipantStopped as err:  # the job's time limit reached the solver
                    raise KeyboardInterrupt(self._stopped_in_window(running, err)) from None
                except Exception as err:
                    # a solver the same SIGTERM stopped may only say that it failed (mpirun
                    # exits 1 when it is signalled itself): the run was asked to stop
                    if not self.interrupted():
                        raise
                    raise KeyboardInterrupt(self._stopped_in_window(running, err)) from None
                self.stopped = self.stop(results)
                interrupted = self.interrupted()
                if (
                    self.window % self.output.checkpoint_every == 0
                    or self.window == self.schedule.n_windows
                    or self.stopped is not None
                    or interrupted
                ):
                    self._checkpoint(out / CHECKPOINT_FILE)
                self.progress(self.window, self.schedule.n_windows, row)
                if interrupted:
                    raise KeyboardInterrupt(
                        f"stopped after window {self.window} ({interrupted}) with a checkpoint "
                        "there; continue with --resume"
                    )
        except OSError as err:  # a VTU, PVD or flow file that could not be written
            if not is_write_fault(err):
                raise
            where = Path(err.filename) if err.filename else out
            kept = f"the results up to window {results.rows} and the last checkpoint are kept"
            raise write_failure(where, err, kept) from None
        finally:
            results.close()
        return out / RESULTS_FILE

    # ----------------------------------------------------------------- recording
    def _record(
        self,
        results: ResultsFile,
        vtk: dict[str, VtkSeries],
        wall_s: float,
        stats: dict[str, float],
    ) -> dict[str, object]:
        row: dict[str, object] = {"time_s": self.solid.time, "wall_s": wall_s, **stats}
        for name, p in self.participants.items():
            if isinstance(p, Monitored):
                row.update({f"{name}/{k}": v for k, v in p.monitor().items()})
        results.append(row)
        if vtk and self.window % self.output.vtk_every == 0:
            for name, series in vtk.items():
                data = self.participants[name].write_data()
                series.write(
                    self.window,
                    self.solid.time,  # the run's clock (a fluid's may count its lead-in)
                    data.get(DISPLACEMENT, np.zeros_like(series.mesh.points)),
                    data,
                )

        if self.output.flow_every and self.window % self.output.flow_every == 0:
            self._write_flow_fields()
        return row

    def _write_flow_fields(self) -> None:
        """Flow fields a fluid writes itself (e.g. OpenFOAM's slices), moved into the PVD
        series. A failure costs the pictures, not the run: one warning, no more attempts."""
        for p in self.participants.values():
            if not isinstance(p, WritesFlowFields):
                continue
            sample = p.flow_fields
            try:
                files = sample()
            except RuntimeError as err:
                warnings.warn(
                    f"flow fields of window {self.window} not written, none will be for the "
                    f"rest of the run (set output.flow_every = 0 to skip them): {err}",
                    RuntimeWarning,
                    stacklevel=2,
                )
                self.output = dataclasses.replace(self.output, flow_every=0)
                return
            for name, path in files.items():
                if name not in self._flow:
                    directory = self.output.directory / "vtk"
                    self._flow[name] = PvdSeries(directory, name, self._flow_keep_until)
                self._flow[name].add_file(self.window, self.solid.time, path)

    def _vtk_writers(self, directory: Path, keep_until: float | None) -> dict[str, VtkSeries]:
        if not self.output.vtk:
            return {}
        return {
            name: VtkSeries(directory, name, p.interface(), keep_until)
            for name, p in self.participants.items()
        }

    # ----------------------------------------------------------------- checkpoints
    def _stopped_in_window(self, window: int, err: BaseException) -> str:
        first = (str(err).splitlines() or [type(err).__name__])[0]
        where = f"window {window} did not finish: {first}"
        if self._checkpointed is None:
            return f"{where}; {NO_CHECKPOINT}"
        return (
            f"{where}; the checkpoint after window {self._checkpointed} is kept: "
            "continue with --resume"
        )

    def _checkpoint(self, path: Path) -> None:
        loop_state: dict[str, Any] = {"window": self.window, "dt_s": self.schedule.dt}
        if self.coupling is not None:
            loop_state["coupling"] = self.coupling.save_state()
        identity = self.output.case_identity
        attributes = {IDENTITY_ATTR: identity} if identity is not None else {}
        write_checkpoint(path, loop_state, {self.solid.name: self.solid.save_state()}, attributes)
        self._checkpointed = self.window

    def _resume(self, path: Path) -> None:
        self.window = load_checkpoint(
            path, self.solid, self.coupling, self.schedule.dt, self.output.case_identity
        )
        self._checkpointed = self.window


def load_checkpoint(
    path: Path,
    solid: Participant,
    coupling: Coupling | None,
    dt: float | None = None,
    identity: str | None = None,
) -> int:
    """Restore the structure and the coupling (with its fluid) from a checkpoint written
    with windows of ``dt`` (None: any) for the case of ``identity`` (None: any); returns the
    number of windows it had done."""
    if not path.exists():
        raise ResumeError(f"{path}: no checkpoint to resume from; {AFRESH}")
    try:
        loop_state, states, attrs = read_checkpoint(path)
        int(loop_state["window"])
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as err:
        # truncated, emptied, zeroed or overwritten: h5py cannot open it, or the checksum
        # or a state's finiteness says it is not what was written
        why = str(err) if isinstance(err, CorruptFile) else "truncated or corrupt"
        raise ResumeError(
            f"{path}: not a readable checkpoint ({why}); restore it, or {AFRESH}"
        ) from None
    changed = f"resume with the settings it was written with, or {AFRESH}"
    stored = attrs.get(IDENTITY_ATTR)
    changes = identity_changes(stored, identity) if identity and stored else []
    if changes:
        keys = ", ".join(changes)
        raise ResumeError(
            f"{path}: belongs to another case ({keys} changed since it was written); {changed}"
        )
    saved_dt = float(loop_state.get("dt_s", np.nan))  # older checkpoints: not saved
    if dt is not None and abs(saved_dt - dt) > 1e-9 * dt:
        raise ResumeError(
            f"{path}: was written with windows of {saved_dt:.6g} s, this case has {dt:.6g} s "
            "(actuation.frequency_hz, time.steps_per_period or time.step_s changed); "
            f"{changed}"
        )
    if solid.name not in states:
        raise ResumeError(f"{path}: holds no state for participant '{solid.name}'; {changed}")
    if coupling is not None and "coupling" not in loop_state:
        raise ResumeError(f"{path}: was written by an uncoupled run; {changed}")
    try:
        solid.load_state(states[solid.name])
        if coupling is not None:
            coupling.load_state(loop_state["coupling"], solid)
    except (KeyError, ValueError, IndexError) as err:  # another mesh, fluid or model
        raise ResumeError(
            f"{path}: does not fit this case ({err}): the case changed since it was written; "
            f"{changed}"
        ) from err
    return int(loop_state["window"])


def _check_results_reach(path: Path, windows: int) -> None:
    """The results a resumed run appends to must hold every window the checkpoint did."""
    if not path.exists():
        raise ResumeError(
            f"{path}: missing, where the checkpoint holds {windows} windows: the run's results "
            f"are gone, so it cannot go on from there; {AFRESH}"
        )
    try:
        rows = stored_rows(path)
    except (OSError, KeyError, ValueError) as err:
        raise ResumeError(_unreadable_results(path, err)) from None
    if rows < windows:
        raise ResumeError(
            f"{path}: holds {rows} windows, the checkpoint {windows}: the run's results are "
            f"incomplete, so it cannot go on from there; {AFRESH}"
        )


def _unreadable_results(path: Path, err: Exception) -> str:
    return (
        f"{path}: not a readable results file (truncated or corrupt: {err}); rerun without "
        "--resume into a new --output (or with --overwrite), or restore it"
    )
