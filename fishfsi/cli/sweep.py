"""``fsi-sweep CASE``: tail amplitude and slender-body thrust over driving frequencies.

``--method linear`` (default, seconds): the wet shell's linear periodic response per frequency
and harmonic (the added mass is computed once), thrust by Lighthill's theory on that motion
with the shedding efficiency (Lighthill's alone beside it).
``--method transient``: the nonlinear time-domain run per frequency (as ``fsi-run``); with
OpenFOAM and iqn-ils-am each point starts from the quasi-Newton Jacobian the previous point on
the same MPI rank learned (``coupling.jacobian_from``: fewer fluid solves, the same result to
the coupling tolerance).
Writes ``sweep.csv`` and ``sweep.json`` to the output folder and prints a table.

Each finished point writes its row at once (``OUTPUT/sweep_rows/<waveform>_<f>Hz.json``,
atomically, by whichever MPI rank ran it) and ``sweep.csv`` / ``sweep.json`` are merged from
those rows after every point, so a killed sweep keeps every finished row (the tables hold every
finished row of that case in the folder: also an earlier sweep's other frequencies, or other
array tasks' points). ``--resume`` skips
the points whose rows are done for the same case (``OUTPUT/sweep_case.json``) and continues a
killed transient point from its checkpoint (its run folder is ``OUTPUT/<waveform>_<f>Hz``).
Without ``--resume`` a folder holding a sweep's results is refused (``--overwrite`` replaces
them); ``--point K`` (an array task) is refused only by another case's sweep there or by its
own point's row or run, not by its siblings' rows.
A point whose windows of one fluid solve diverge (explicit-am: a sine above 13-15 Hz, a
square wave's steps) is rerun with longer windows (with_fewer_windows,
coupling.explicit_fallback_windows) and, where those diverge too, with iterated windows
(with_iterated_windows); its status says which. A point started on an earlier sweep's orbit
(``--start-from``) starts at the windows that sweep's point fell back to, and where they
diverge from that orbit it runs from its usual start before its windows are iterated.
One line per finished point goes to stderr (``--quiet``: none).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import fcntl
import hashlib
import io
import json
import os
import shutil
import sys
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import h5py
import numpy as np

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.params import coerce
from fsi_orchestrator.case.schema import (
    AnalysisKind,
    FluidModel,
    GeometryKind,
    Waveform,
    key_spec,
)

from .common import (
    EXIT_BAD_INPUT,
    EXIT_FAILED,
    EXIT_OK,
    atomic_write,
    base_parser,
    cannot_write,
    emit,
    json_text,
    load,
    output_folder,
    plain,
    plural,
    run_main,
)
from .fast_model import SweepError, with_drive, without_cfd
from .linear import OnRow, linear_sweep, not_finite_status, point_name
from .swimming import SWIMMING_KEYS

ROWS_FOLDER = "sweep_rows"  # one finished point's row per file
SWEEP_CASE_FILE = "sweep_case.json"  # what was swept: --resume refuses another case
# a launcher's task count: Open MPI's mpirun, MPICH/Intel MPI (Hydra, PMI), SLURM's srun step
LAUNCHER_TASKS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS")

MAX_POINTS = 1000  # frequencies in one sweep

# Open MPI's (<= 4) mpiexec passes a SIGTERM or Ctrl-C on to its ranks T s later and kills
# them T s after that (odls_base_sigkill_timeout, 1 s by default). T must outlast one window and its
# checkpoint: an iterated default-level window takes 9-14 s.
MPIEXEC_GRACE_S = 30

PERIODIC_KEYS = (
    "tip_amplitude_periodic_m",
    "tip_amplitude_periodic_uncertainty_m",
    "mean_thrust_periodic_n",
    "mean_thrust_periodic_uncertainty_n",
)


def parse_frequencies(text: str) -> list[float]:
    """ "1:25:2" -> 1, 3, ..., 25; "3,5,10" -> those."""
    spec = key_spec("actuation.frequency_hz")  # each point is a case: the key's own range holds
    usage = (
        f"--frequencies {text!r}: use start:stop:step or a,b,c (Hz, each from {spec.ge:g} to "
        f"{spec.le:g})"
    )
    try:
        if ":" in text:
            start, stop, step = (float(v) for v in text.split(":"))
            if not step > 0:
                raise ValueError
            count = (stop - start) / step + 1
            frequencies = (
                [] if count > MAX_POINTS else list(np.arange(start, stop + step / 2, step))
            )
        else:
            count = text.count(",") + 1
            frequencies = [float(v) for v in text.split(",")]
    except ValueError:
        raise CaseError(usage) from None
    if count > MAX_POINTS:  # a mistyped step: refused before np.arange builds it
        raise CaseError(
            f"--frequencies {text!r}: more than {MAX_POINTS} points in one sweep (check the step)"
        )
    frequencies = [float(f) for f in frequencies]  # not numpy's: they go into TOML and JSON
    if ":" in text:  # 12 digits drop arange's float noise (1:2:0.1 gives 1.2000000000000002)
        frequencies = [float(f"{f:.12g}") for f in frequencies]
    if not frequencies or not all(np.isfinite(f) and f > 0 for f in frequencies):
        raise CaseError(usage)
    seen: dict[str, float] = {}
    for f in frequencies:  # a point's folder and row are named by f to 6 digits
        name = f"{f:g}"
        if name in seen:
            same = "twice" if seen[name] == f else f"as {seen[name]!r} and {f!r} (the same point)"
            raise CaseError(f"--frequencies {text!r}: {name} Hz is given {same}")
        seen[name] = f
    for f in frequencies:
        try:
            coerce("actuation.frequency_hz", float(f), float, spec)
        except CaseError as err:
            raise CaseError(f"--frequencies {text!r}: {err}") from None
    return frequencies


def select_point(
    frequencies: list[float], waveforms: list[Waveform], index: int | None
) -> tuple[list[float], list[Waveform]]:
    """--point K: only the K-th (0-based) of the sweep's points, waveform by waveform and
    frequency by frequency (a SLURM array task runs ``--point $SLURM_ARRAY_TASK_ID``)."""
    if index is None:
        return frequencies, waveforms
    points = [(w, f) for w in waveforms for f in frequencies]
    if not 0 <= index < len(points):
        raise CaseError(
            f"--point {index}: this sweep has points 0..{len(points) - 1} "
            f"({plural(len(waveforms), 'waveform')} x {plural(len(frequencies), 'frequency')}); "
            "a SLURM job array's --array must match them"
        )
    waveform, frequency = points[index]
    return [frequency], [waveform]


def transient_sweep(
    case: Case,
    frequencies: list[float],
    waveforms: list[Waveform],
    output: Path,
    *,
    comm=None,
    done: frozenset[str] | set[str] = frozenset(),
    resume: bool = False,
    on_row: OnRow | None = None,
    start_from: Path | None = None,
    finished: Callable[[], dict[str, dict]] | None = None,
) -> list[dict]:
    """One nonlinear run per (waveform, frequency) not ``done`` (point_name), in the stable
    folder ``output/<point name>``; each row is handed to ``on_row`` as it is finished. With
    ``comm`` (mpi_world(); the same ``done`` on every rank) each rank takes the next point no
    rank has taken (PointClaims), and the rows are gathered on rank 0; other ranks return [].
    ``resume``: a point whose folder holds a checkpoint continues from it (fsi-run --resume).
    ``start_from``: an earlier sweep's folder, whose point of the same name (a finished run)
    each point starts on (started_from). ``finished``: the sweep's finished rows by point name
    (SweepTable.rows), whose windows per period a higher frequency starts at."""
    from fluid_adapter.openfoam.errors import MeshFoldedError
    from fsi_orchestrator.convergence import CouplingDivergenceError
    from fsi_orchestrator.loop import AFRESH, NO_CHECKPOINT, ResumeError
    from fsi_orchestrator.results import CHECKPOINT_FILE
    from solid_adapter.solvers import SolverError

    from .run import run_dynamic

    def run_or_afresh(point: Case, folder: Path, continued: bool) -> dict:
        """The point's run, continued from its checkpoint where asked and possible."""
        try:
            return run_dynamic(point, folder, resume=continued, show_progress=False)
        except ResumeError as err:
            if not continued:
                raise
            why = str(err).split(f"; {AFRESH}")[0]  # the sweep starts it afresh itself
            print(f"note: {folder}: {why}; running the point afresh", file=sys.stderr)
            return run_dynamic(point, folder, resume=False, show_progress=False)

    jobs = [(w, f) for w in waveforms for f in frequencies if point_name(w, f) not in done]
    if start_from is not None:  # the shell the earlier sweep's runs must have
        from solid_adapter.build import build_shell_model

        ndof = build_shell_model(case).ndof
    claims = PointClaims(output, comm) if comm is not None else None
    mine = []
    learned = None  # the last finished point's output: its quasi-Newton Jacobian
    learned_iterated = None  # the same, of the last point rerun with iterated windows
    steady: dict[Waveform, tuple[float, int]] = {}  # (f, windows per period) it ran with
    running = RunningPoint()
    try:
        for index, (waveform, f) in enumerate(jobs):
            if claims is not None and not claims.take(point_name(waveform, f)):
                continue  # another rank runs it
            folder = output / point_name(waveform, f)
            if not running.take(folder):
                print(
                    f"note: {waveform.value} {f:g} Hz: another fsi-sweep is running it in "
                    f"{folder}; this launch leaves it to that one",
                    file=sys.stderr,
                )
                continue
            point = with_drive(case, f, waveform)
            source_windows = None  # the windows per period its start's source fell back to
            if start_from is not None:
                source = start_from / point_name(waveform, f)
                point, source_windows = started_from(point, source, ndof)
            if learned is not None:
                point = chained(point, learned)
            start = time.perf_counter()
            iterated = with_iterated_windows(point)
            if iterated is not None and learned_iterated is not None:
                iterated = chained(iterated, learned_iterated)
            needed = fewest_needed(steady.get(waveform), finished, waveform, f)
            counts = [needed[1]] if needed is not None and f > needed[0] else []
            counts += [source_windows] if source_windows is not None else []
            started = start_from is not None and bool(point.time.start_from)
            attempts, iterated, redone = point_attempts(
                point, folder, resume, counts, iterated, started
            )
            try:  # one failed frequency (a CFD crash near resonance) must not lose the others
                continued = resume and (folder / CHECKPOINT_FILE).is_file()
                notes = []
                for k, attempt in enumerate(attempts):
                    try:
                        summary = run_or_afresh(attempt, folder, continued and k == 0)
                        break
                    except (CouplingDivergenceError, MeshFoldedError) as err:
                        if isinstance(err, MeshFoldedError) and (
                            own_motion := folded_on_a_steady_swing(folder, attempt)
                        ):
                            first_line = str(err).splitlines()[0]
                            raise MeshFoldedError(f"{first_line} ({own_motion})") from err
                        why = f"{waveform.value} {f:g} Hz: {str(err).splitlines()[0]}"
                        if k + 1 < len(attempts):
                            n = attempts[k + 1].time.steps_per_period
                            if attempt.time.start_from and not attempts[k + 1].time.start_from:
                                how = f"its usual start, not the earlier sweep's orbit ({n} "
                                how += "windows per period)"
                                start_rerun(folder, why, how, USUAL_START_MARK, f"{err}\n")
                                continue
                            how = f"{n} windows per period (time.steps_per_period; "
                            how += "coupling.explicit_fallback_windows)"
                            start_rerun(folder, why, how, WINDOWS_MARK, f"{n}\n{err}\n")
                            continue
                        if iterated is None:
                            raise
                        # one solve per window is unstable at this point (explicit added-mass
                        # instability, or a solver failing on its growing force): iterate its
                        # windows
                        how = (
                            f'iterated windows (coupling.scheme = "{iterated.coupling.scheme}", '
                            "coupling.explicit_periods = 0, "
                            "coupling.explicit_until_periodic = false)"
                        )
                        start_rerun(folder, why, how, ITERATED_MARK, f"{err}\n")
                        summary = run_dynamic(iterated, folder, resume=False, show_progress=False)
                        redone = True
                if redone:
                    notes.append("iterated windows")
                    learned_iterated = folder
                else:
                    if attempt.time.steps_per_period != point.time.steps_per_period:
                        notes.append(f"{attempt.time.steps_per_period} windows per period")
                        steady[waveform] = (f, attempt.time.steps_per_period)
                    if point.time.start_from and not attempt.time.start_from:
                        notes.append("its start on the earlier orbit diverged")
                if "start_from_rest" in summary:
                    notes.insert(0, "started from rest")
                if "thrust_averaged_over_s" in summary:  # its means are a part period's
                    notes.append("shorter than one period")
                status = f"ok ({'; '.join(notes)})" if notes else "ok"
                (folder / FAILURE_NOTE).unlink(missing_ok=True)  # an earlier attempt's
                learned = folder
            except KeyboardInterrupt as err:  # --overwrite would throw the finished points away
                if text := str(err).replace(
                    NO_CHECKPOINT, "no checkpoint yet: --resume runs it again"
                ):
                    err.args = (f"{waveform.value} {f:g} Hz: {text}",)
                raise
            except (SolverError, RuntimeError) as err:
                summary, status = {}, f"failed: {err}".splitlines()[0]
                if folder.is_dir():
                    atomic_write(folder / FAILURE_NOTE, f"{err}\n")
                if on_row is None:
                    print(
                        f"{waveform.value} {f:g} Hz {status} (output kept in {folder}; the "
                        f"whole error in {FAILURE_NOTE} there)",
                        file=sys.stderr,
                    )
            # a failed run's figures are NaN (its status says why); a figure an ok run did not
            # give (a fast fluid's per-period thrust, a beam's thrust) is left out, never NaN
            nan = float("nan") if not summary else None
            row = {
                "waveform": waveform.value,
                "frequency_hz": float(f),
                "tip_amplitude_m": summary.get("tip_amplitude_m", nan),
                "mean_thrust_n": summary.get("mean_thrust_n", nan),
                "thrust_source": summary.get("thrust_source", ""),
                "slender_body_mean_thrust_n": summary.get("slender_body_mean_thrust_n", nan),
                "windows_per_period": summary.get("windows_per_period", nan),
                "mean_fluid_solves_per_window": summary.get(
                    "mean_fluid_solves_per_window", 1.0 if summary else float("nan")
                ),
                # a start-up not yet settled (fsi-run's note): the point's figures are
                # its last period's, not the periodic state's
                "tip_amplitude_change_last_period": summary.get(
                    "tip_amplitude_change_last_period", nan
                ),
                "status": status,
            }
            # the periodic estimate from the run's per-period sequence (fsi_orchestrator.periodic)
            for key in PERIODIC_KEYS:
                row[key] = summary.get(key, nan)
            row["periodic"] = bool(summary.get("periodic", False))
            row = {k: v for k, v in row.items() if v is not None}
            # a figure the run gave as NaN fails the point (one it did not give stays NaN: a beam
            # has no thrust)
            row["status"] = not_finite_status(
                {**summary, "status": status},
                ("tip_amplitude_m", "mean_thrust_n"),
                "the run's result",
            )
            if on_row is not None:
                on_row(point_name(waveform, f), row, time.perf_counter() - start)
            mine.append((index, row))
    finally:  # also where a stop or a failure leaves the loop
        running.release()
    if comm is None:
        return [row for _, row in mine]
    gathered = comm.gather(mine, root=0)
    if comm.Get_rank() != 0:
        return []
    assert claims is not None
    claims.clear()  # every rank is past its last claim
    return [row for _, row in sorted(item for part in gathered for item in part)]


class RunningPoint:
    """The point this process runs, locked (flock on OUTPUT/<point>/.running) while it runs,
    so that another launch into the same --output (a job submitted twice, a --resume while
    the first launch still runs) leaves it alone instead of running it in the same folder.
    The lock goes with the process; the empty file stays."""

    NAME = ".running"

    def __init__(self) -> None:
        self._fd: int | None = None
        self.unlocked = False  # the file system refused a lock: said once

    def take(self, folder: Path) -> bool:
        """Lock ``folder`` (releasing the point held before); False where another holds it."""
        self.release()
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(folder / self.NAME, os.O_CREAT | os.O_WRONLY, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        except OSError as err:  # a file system without locks (Lustre without -o flock)
            os.close(fd)
            if not self.unlocked:
                print(
                    f"note: {folder}: cannot lock ({err}); points run "
                    "unlocked: do not start a second launch into this --output while this runs",
                    file=sys.stderr,
                )
            self.unlocked = True
            return True
        self._fd = fd
        return True

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


class PointClaims:
    """MPI ranks take a sweep's points as they free up: each rank runs the next point that no
    rank has taken, claimed by creating its file in this launch's ``OUTPUT/.claims/<id>``
    (exclusive create, also on a shared file system), so a rank that drew short points runs
    more of them. Rank 0 removes the launch's folder after the last claim."""

    FOLDER = ".claims"

    def __init__(self, output: Path, comm) -> None:
        launch = comm.bcast(uuid.uuid4().hex if comm.Get_rank() == 0 else None, root=0)
        self.folder = output / self.FOLDER / launch

    def take(self, name: str) -> bool:
        for _ in range(2):  # the folder is made by whichever rank claims first
            try:
                os.close(os.open(self.folder / name, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
                return True
            except FileExistsError:
                return False
            except FileNotFoundError:
                self.folder.mkdir(parents=True, exist_ok=True)
        raise OSError(f"{self.folder}: cannot claim {name}")

    def clear(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)
        with contextlib.suppress(OSError):  # other launches' claims (killed ones) stay
            self.folder.parent.rmdir()


def point_attempts(
    point: Case,
    folder: Path,
    resume: bool,
    counts: list[int],
    iterated: Case | None,
    started: bool,
) -> tuple[list[Case], Case | None, bool]:
    """The runs a point tries in turn until one does not diverge, its iterated rerun after
    them (None: none), and whether its run was already redone iterated (--resume).
    ``counts``: windows per period it starts at no more than (a lower frequency's, its
    start's source's); ``started``: on an earlier sweep's orbit (--start-from). Writes the
    marks a --resume reads, and drops an earlier sweep's without --resume."""
    from fsi_orchestrator.results import CHECKPOINT_FILE

    # one solve per window steadies with longer windows: those tried before iterating; a
    # higher frequency of the same waveform starts at the count a lower one needed, a started
    # point at the count its source fell back to (the same drive on another mesh: its own
    # count would diverge first)
    attempts = [point, *with_fewer_windows(point)]
    if counts and not (resume and (folder / CHECKPOINT_FILE).is_file()):
        # (a checkpoint continues at the count it was written with)
        fewest = min(counts)
        fitting = [a for a in attempts if a.time.steps_per_period <= fewest]
        attempts = fitting or attempts[-1:]
    if not resume:  # an earlier sweep's marks (--overwrite) say nothing of this run
        for mark in (ITERATED_MARK, WINDOWS_MARK, USUAL_START_MARK):
            (folder / mark).unlink(missing_ok=True)
    if resume and iterated is not None and (folder / ITERATED_MARK).is_file():
        return [iterated], None, True  # its run was already redone
    if resume and (marked := marked_windows(folder)) is not None:  # fewer windows
        attempts = [a for a in attempts if a.time.steps_per_period <= marked] or attempts
    if attempts[0] is not point:  # a --resume must start at this count
        first = attempts[0].time.steps_per_period
        if marked_windows(folder) != first:
            folder.mkdir(parents=True, exist_ok=True)
            text = f"{first}\nstarted with the windows a lower frequency needed or the "
            text += "start's source fell back to\n"
            atomic_write(folder / WINDOWS_MARK, text)
    if started:
        # diverging from the earlier orbit at its last count, the point runs from its usual
        # start at that count before its windows are iterated (a start from rest ramps the
        # motion up: it may steady where the orbit's full swing does not)
        attempts.append(with_usual_start(attempts[-1]))
        if resume and (folder / USUAL_START_MARK).is_file():
            attempts = attempts[-1:]
    return attempts, iterated, False


def fewest_needed(
    own: tuple[float, int] | None,
    finished: Callable[[], dict[str, dict]] | None,
    waveform: Waveform,
    f: float,
) -> tuple[float, int] | None:
    """The windows per period that the highest lower frequency of this waveform needed: as
    this rank ran it (``own``: frequency, windows) or as any rank's finished row says (a row
    rerun with fewer windows); None where none needed fewer."""
    found = [own] if own is not None and own[0] < f else []
    for row in (finished() if finished is not None else {}).values():
        lower = row.get("waveform") == waveform.value and row.get("frequency_hz", f) < f
        if lower and (n := fell_back_to(row)) is not None:
            found.append((row["frequency_hz"], n))
    return max(found, default=None)


def fell_back_to(row: dict) -> int | None:
    """The windows per period a finished point's row says it fell back to
    (coupling.explicit_fallback_windows), None where it ran its case's own or iterated."""
    status = row.get("status", "")
    if not (status.startswith("ok") and "windows per period" in status):
        return None
    try:
        return int(row["windows_per_period"])
    except (KeyError, TypeError, ValueError, OverflowError):  # absent, or NaN
        return None


ITERATED_MARK = "iterated_windows.txt"  # in a point's folder: its run was redone iterated
# in a failed point's folder: the whole error (a row's status keeps its first line, and a
# solver's log, whose last lines the error quotes, is overwritten when the point reruns)
FAILURE_NOTE = "failure.txt"
WINDOWS_MARK = "fewer_windows.txt"  # in a point's folder: rerun with these windows per period
# in a point's folder: its start on an earlier sweep's orbit diverged, rerun from the usual start
USUAL_START_MARK = "usual_start.txt"


def start_rerun(folder: Path, why: str, how: str, mark: str, text: str) -> None:
    """Say why a point runs again and how; drop the failed run's checkpoint (the rerun must
    not continue it) and mark the folder, so --resume continues the rerun."""
    from fsi_orchestrator.results import CHECKPOINT_FILE

    print(f"note: {why}; running the point again with {how}", file=sys.stderr)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / CHECKPOINT_FILE).unlink(missing_ok=True)
    atomic_write(folder / mark, text)


def marked_windows(folder: Path) -> int | None:
    """The windows per period a point's rerun was started with (WINDOWS_MARK), None if none
    (or an unreadable mark: the point then tries its counts again)."""
    try:
        return int((folder / WINDOWS_MARK).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def with_fewer_windows(case: Case) -> list[Case]:
    """The point's case with each of coupling.explicit_fallback_windows below its own
    time.steps_per_period, longest windows first: the reruns of a sine point whose windows of
    one fluid solve diverge, before its windows are iterated. None ([]) for an iterating
    scheme (also one with explicit start-up periods: its iterated figures would change with
    the time step), a coupling without a partitioned fluid, a time step given in seconds, or
    a square wave (measured with sines only)."""
    c, t = case.coupling, case.time
    if with_iterated_windows(case) is None or t.step_s is not None:
        return []
    if c.scheme.iterates or case.actuation.waveform is not Waveform.SINE:
        return []
    counts = sorted({n for n in c.explicit_fallback_windows if n < t.steps_per_period})[::-1]
    if t.periodic_feedback_mirror:  # its half period must be whole windows
        counts = [n for n in counts if n % 2 == 0]
    return [
        dataclasses.replace(case, time=dataclasses.replace(t, steps_per_period=n)) for n in counts
    ]


def with_usual_start(case: Case) -> Case:
    """The point's case without the earlier sweep's orbit to start on (time.start_from)."""
    return dataclasses.replace(case, time=dataclasses.replace(case.time, start_from=""))


def started_from(case: Case, source: Path, ndof: int) -> tuple[Case, int | None]:
    """The point started on the orbit an earlier sweep's point of the same drive ended on
    (time.start_from), where that sweep finished the point (its row ok) with a run that can
    start this one (a shell of ``ndof`` unknowns, whole periods), and the windows per period
    that run fell back to (None where it ran its case's own, or iterated); else the point as
    it is, with a note saying why, and None."""
    from .compose import recorded_start

    row = source.parent / ROWS_FOLDER / f"{source.name}.json"
    why = None
    try:
        fields = json.loads(row.read_text())["row"]
        status = fields.get("status", "")
    except (OSError, ValueError, KeyError, TypeError, AttributeError):  # none, or not a row
        fields, status = {}, ""
    windows = fell_back_to(fields)
    if not status.startswith("ok"):
        why = "holds no finished run"
    else:
        candidate = dataclasses.replace(
            case, time=dataclasses.replace(case.time, start_from=str(source.resolve()))
        )
        try:
            recorded_start(candidate, ndof)
            return candidate, windows
        except CaseError as err:
            why = f"cannot start it ({str(err).removeprefix('time.start_from: ')})"
    print(f"note: {source} {why}; the point starts as usual", file=sys.stderr)
    return case, None


# a swing that grew by less than this from its second-to-last whole period to the rest of the
# run is the motion's own (a fold then is not the coupling's instability, whose force and
# mean position grow by far more per period)
STEADY_GROWTH = 1.25


def folded_on_a_steady_swing(folder: Path, case: Case) -> str | None:
    """Why a point whose mesh folded is not rerun (with fewer or iterated windows, which
    move the plate the same way and fold it again), or None: its run recorded at least two
    whole periods, and the tail's reach over the last whole period and the windows after it
    stayed within STEADY_GROWTH of its reach over the period before."""
    from fsi_orchestrator.results import RESULTS_FILE

    from .run import windows_per_period

    try:
        with h5py.File(folder / RESULTS_FILE, "r", locking=False) as h5:
            tip = h5["shell/tip_displacement_m"][:, 2]
    except (OSError, KeyError):
        return None
    n = windows_per_period(case)
    whole = len(tip) // n
    if whole < 2:
        return None
    before = np.abs(tip[(whole - 2) * n : (whole - 1) * n]).max()  # second-to-last period
    since = np.abs(tip[(whole - 1) * n :]).max()
    if since > STEADY_GROWTH * before:
        return None
    return (
        f"after {whole} whole periods of a steady {before * 1e3:.1f} mm tail swing: the "
        "motion itself folds this mesh, so the point is not rerun"
    )


def with_iterated_windows(case: Case) -> Case | None:
    """The point's case with every window iterated to the coupling tolerance (iqn-ils-am, or
    its own iterating scheme, with no explicit start-up periods); None where the case already
    iterates every window or has no partitioned coupling to iterate. A sweep point whose
    one-solve windows diverge (explicit-am on the coarse fish above 15 Hz) is rerun this way,
    so one sweep spans the stable and the unstable frequencies."""
    from fsi_orchestrator.case.schema import CouplingScheme

    c = case.coupling
    if case.fluid.model is not FluidModel.OPENFOAM and not c.partitioned:
        return None
    if c.scheme.iterates and c.explicit_periods == 0 and not c.explicit_until_periodic:
        return None
    scheme = c.scheme if c.scheme.iterates else CouplingScheme.IQN_ILS_AM
    coupling = dataclasses.replace(
        c, scheme=scheme, explicit_periods=0, explicit_until_periodic=False
    )
    return dataclasses.replace(case, coupling=coupling)


def chained(case: Case, previous: Path) -> Case:
    """The next point of a sweep starts its quasi-Newton Jacobian from the one the previous
    point learned (same shell, another drive: coarse fish, 3 -> 5 Hz, 3.53 -> 3.20 fluid
    solves per window in period 1), unless the case names its own coupling.jacobian_from.
    The results agree to the coupling tolerance with a cold start."""
    from fsi_orchestrator.case.schema import CouplingScheme
    from fsi_orchestrator.results import CHECKPOINT_FILE

    c = case.coupling
    chainable = (
        c.scheme is CouplingScheme.IQN_ILS_AM
        and not c.jacobian_from
        and case.fluid.model is FluidModel.OPENFOAM
        and (previous / CHECKPOINT_FILE).is_file()
    )
    if not chainable:
        return case
    coupling = dataclasses.replace(c, jacobian_from=str(previous.resolve()))
    return dataclasses.replace(case, coupling=coupling)


def check_start_from(case: Case, folder: Path, method: str) -> None:
    """--start-from's one-line refusals: another method, no folder, a case whose points
    cannot start on an orbit (the loader's checks of time.start_from)."""
    from fsi_orchestrator.case.schema import StartMode

    where = f"--start-from {folder}"
    if method != "transient":
        raise CaseError(f"{where} starts transient runs: add --method transient")
    if not folder.is_dir():
        raise CaseError(f"{where}: no such sweep folder")
    t = case.time
    if t.step_s is not None or t.start is not StartMode.PERIODIC or case.actuation.ramp_periods:
        raise CaseError(
            f"{where} starts each point on a periodic orbit of whole periods: remove "
            "time.step_s, time.start = rest or actuation.ramp_periods"
        )


def launcher_tasks() -> tuple[str, int] | None:
    """(variable, tasks) when a launcher started this process as one of several tasks:
    mpirun/mpiexec (Open MPI, MPICH/Intel MPI) or an srun step; None for one process (also a
    SLURM batch script itself, which has SLURM_NTASKS but no step)."""
    for var in LAUNCHER_TASKS:
        try:
            tasks = int(os.environ.get(var, ""))
        except ValueError:
            continue
        if tasks > 1:
            return var, tasks
    return None


def mpiexec_stop_note() -> str | None:
    """The one-line note for a launch by Open MPI's mpiexec whose ranks would be killed before
    a stop signal lets them finish their window; None under srun (SLURM's KillWait applies)
    or when the grace is long enough."""
    if "OMPI_MCA_orte_hnp_uri" not in os.environ:  # set by Open MPI <= 4's own launcher only
        return None
    try:
        grace = float(os.environ.get("OMPI_MCA_odls_base_sigkill_timeout", "1"))
    except ValueError:
        grace = 1.0
    if grace >= MPIEXEC_GRACE_S:
        return None
    return (
        f"note: mpiexec gives its ranks {grace:g} s from SIGTERM to SIGKILL, too short to "
        "finish a window: a Ctrl-C or kill of mpiexec loses the windows since the last "
        f"checkpoint; export OMPI_MCA_odls_base_sigkill_timeout={MPIEXEC_GRACE_S} before "
        f"mpiexec (a stop then takes up to {2 * MPIEXEC_GRACE_S} s)"
    )


def mpi_world():
    """MPI.COMM_WORLD when launched by mpiexec/srun with more than one task, else None.

    A launch whose tasks mpi4py does not see as one MPI world (mpi4py missing, or built
    against another MPI than the launcher's: each task sees a world of 1) would run every
    point in every task, into the same folders: SweepError, in one line."""
    launched = launcher_tasks()
    if launched is None:
        if "PMIX_RANK" not in os.environ:  # a PMIx launch that names no size
            return None
        try:
            from mpi4py import MPI
        except ImportError:
            return None
        return MPI.COMM_WORLD if MPI.COMM_WORLD.Get_size() > 1 else None
    var, tasks = launched
    fix = (
        "install mpi4py built against the launcher's MPI (with its mpicc on PATH: pip install "
        "--no-binary=mpi4py --force-reinstall mpi4py), or run fsi-sweep as one task"
    )
    try:
        from mpi4py import MPI
    except ImportError:
        raise SweepError(
            f"launched as {tasks} tasks ({var}={tasks}) but mpi4py is not installed: every "
            f"task would run every point into the same folders; {fix}"
        ) from None
    size = MPI.COMM_WORLD.Get_size()
    if size != tasks:
        raise SweepError(
            f"launched as {tasks} tasks ({var}={tasks}) but mpi4py sees an MPI world of {size}"
            f" (not the launcher's MPI): tasks would run the same points into the same "
            f"folders; {fix}"
        )
    return MPI.COMM_WORLD


def write_tables(rows: list[dict], output: Path) -> None:
    """``sweep.csv`` and ``sweep.json``, each replaced atomically (a reader, or a kill, never
    meets half a table)."""
    output.mkdir(parents=True, exist_ok=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    text = io.StringIO(newline="")
    # "\n" line ends, as every other text file the tool writes (csv's default is "\r\n")
    writer = csv.DictWriter(text, fieldnames=fields, restval="", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write(output / "sweep.csv", text.getvalue())
    atomic_write(output / "sweep.json", json_text(rows, indent=1))


@contextlib.contextmanager
def folder_lock(folder: Path) -> Iterator[None]:
    """An exclusive lock among the MPI ranks (and array tasks) that merge into one folder;
    where the file system has no locks the merge goes on unlocked (the row files stay the
    record: the last merge, at the end, is complete)."""
    try:
        import fcntl

        fh = open(folder / ".sweep.lock", "a")
    except (ImportError, OSError):
        yield
        return
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX)
        except OSError:
            pass
        yield


def sweep_identity(case: Case, method: str) -> dict:
    """What a sweep's rows depend on besides their point: the case (without its drive
    frequency and waveform, nor its folder), the method and this version."""
    from fsi_orchestrator import __version__

    fields = plain(dataclasses.asdict(case))  # NaN and inf kept: the key of older sweeps
    fields.pop("directory", None)
    for key in ("frequency_hz", "waveform"):
        fields["actuation"].pop(key, None)
    if method == "transient" and case.fluid.model is FluidModel.OPENFOAM:
        from fluid_adapter.openfoam.build import UNUSED_KEYS

        # keys the CFD does not read (the fast thrust's KC0) are in none of its rows, and a
        # sweep made before such a key resumes
        for key in UNUSED_KEYS:
            fields["fluid"].pop(key, None)
    identity = {"version": __version__, "method": method, "case": fields}
    return json.loads(json.dumps(identity, default=str))


def comparable(identity: dict, current: dict) -> dict:
    """A sweep's identity less what changes none of its rows: the case's title (free text),
    and the swimming section where the current sweep is not of a swimming case (a key added
    there must not refuse a sweep that never reads it)."""
    case = identity.get("case")
    if not isinstance(case, dict):
        return identity
    case = {k: v for k, v in case.items() if k != "case"}
    if current.get("case", {}).get("analysis", {}).get("kind") != "swimming":
        case.pop("swimming", None)
    return {**identity, "case": case}


def identity_changes(old: dict, new: dict, limit: int = 3) -> str:
    """``section.key: old -> new`` for the first few differences."""

    def flat(value, prefix=""):
        if isinstance(value, dict):
            return {
                k: v for key, sub in value.items() for k, v in flat(sub, f"{prefix}{key}.").items()
            }
        return {prefix.rstrip("."): value}

    a, b = flat(old), flat(new)
    keys = [
        k.removeprefix("case.")
        for k in sorted(set(a) | set(b), key=lambda k: (k != "version", k))
        if a.get(k) != b.get(k)
    ]
    shown = []
    for key in keys[:limit]:
        full = key if key in ("version", "method") else f"case.{key}"
        shown.append(f"{key}: {a.get(full, '(none)')!r} -> {b.get(full, '(none)')!r}")
    more = f" and {len(keys) - limit} more" if len(keys) > limit else ""
    return ", ".join(shown) + more


class SweepTable:
    """A sweep's rows on disk: one JSON file per finished point in ``OUTPUT/sweep_rows``
    (written atomically by the rank that ran it), merged under a lock into ``sweep.csv`` and
    ``sweep.json`` after every point. Rows count only for the case in ``sweep_case.json``."""

    def __init__(self, output: Path, identity: dict, waveforms: Sequence[Waveform]) -> None:
        self.output, self.identity = output, identity
        self.key = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:16]
        self.rows_dir = output / ROWS_FOLDER
        order = [w.value for w in waveforms] + [w.value for w in Waveform]
        self._sort = lambda row: (order.index(row["waveform"]), row["frequency_hz"])

    def prepare(
        self,
        names: Sequence[str],
        resume: bool,
        overwrite: bool = False,
        point: int | None = None,
    ) -> set[str]:
        """On one rank, before any point runs: the names of the points already done
        (``resume``), else none. Nothing computed is lost: a fresh sweep into a folder holding
        a sweep's results (tables, rows, point runs) is refused unless ``overwrite`` replaces
        them; a ``point`` (an array task: its siblings write their rows into the same folder)
        is refused only where the folder's sweep is another case's (or of unknown case) or
        that point's own row or run is there. A ``resume`` into a folder whose tables have no
        ``sweep_case.json`` is refused: its rows cannot be told to be this case's. Each
        refusal comes before anything there is written."""
        from fsi_orchestrator.results import CHECKPOINT_FILE, RESULTS_FILE, probe_write

        from .outputs import RUN_FILES

        run_files = (RESULTS_FILE, CHECKPOINT_FILE, *RUN_FILES)
        run = [n for n in run_files if (self.output / n).is_file()]
        if run:  # fsi-post would draw the sweep and no longer find the run
            raise CaseError(
                f"--output {self.output}: holds a run of fsi-run ({', '.join(run)}); sweep "
                "into another folder"
            )
        case_file = self.output / SWEEP_CASE_FILE
        if resume and not case_file.is_file():
            tables = [n for n in ("sweep.csv", "sweep.json") if (self.output / n).is_file()]
            if tables:
                held, them = " and ".join(tables), "them" if len(tables) > 1 else "it"
                raise CaseError(
                    f"--resume: {self.output} holds {held} but no {SWEEP_CASE_FILE} (made by "
                    f"an older version or not by fsi-sweep); sweep into another --output, or "
                    f"replace {them} with --overwrite"
                )
        if not resume and not overwrite:
            self._refuse_to_replace(names, point)
        try:
            # a read-only folder that is there already passes a mkdir: refused before an
            # --overwrite deletes anything or a point runs
            for folder in (self.output, self.rows_dir):
                folder.mkdir(parents=True, exist_ok=True)
                probe_write(folder)
        except OSError as err:
            raise CaseError(cannot_write(self.output, err)) from None
        done: set[str] = set()
        if resume:
            if case_file.is_file():
                changes = self._changes()
                if changes is not None:
                    raise CaseError(
                        f"--resume: {self.output} holds a sweep of another case ({changes}); "
                        "sweep into another --output, or replace it with --overwrite"
                    )
            finished = self.rows()
            done = {n for n in names if finished.get(n, {}).get("status", "").startswith("ok")}
        elif overwrite and point is None:  # the earlier sweep's tables and rows go
            for path in [self.output / "sweep.csv", self.output / "sweep.json"]:
                path.unlink(missing_ok=True)
            for path in self.rows_dir.glob("*.json"):
                path.unlink(missing_ok=True)
        else:  # this point's own row only: the sibling tasks' rows stay
            for name in names:
                (self.rows_dir / f"{name}.json").unlink(missing_ok=True)
        atomic_write(case_file, json.dumps(self.identity, indent=1))
        return done

    def _changes(self) -> str | None:
        """How the case in ``sweep_case.json`` differs from this one (None: the same)."""
        case_file = self.output / SWEEP_CASE_FILE
        try:
            old = json.loads(case_file.read_text())
        except (OSError, ValueError):
            old = None
        if old == self.identity:
            return None
        if isinstance(old, dict):
            old, new = comparable(old, self.identity), comparable(self.identity, self.identity)
            return None if old == new else identity_changes(old, new)
        return f"{case_file} is unreadable"

    def held(self, names: Sequence[str] | None = None) -> list[str]:
        """What of a sweep's results the folder holds: its tables, rows and point runs (with
        ``names``: only those points' rows and runs)."""
        from fsi_orchestrator.results import CHECKPOINT_FILE, RESULTS_FILE

        run_files = (RESULTS_FILE, CHECKPOINT_FILE)
        if names is None:
            found = [n for n in ("sweep.csv", "sweep.json") if (self.output / n).is_file()]
            rows = len(list(self.rows_dir.glob("*.json")))
            if rows:
                found.append(f"{rows} row{'s' if rows > 1 else ''} in {ROWS_FOLDER}/")
            folders = sorted({p for w in Waveform for p in self.output.glob(f"{w.value}_*Hz")})
        else:
            found = [
                f"{ROWS_FOLDER}/{n}.json" for n in names if (self.rows_dir / f"{n}.json").is_file()
            ]
            folders = [self.output / n for n in names]
        runs = [p.name for p in folders if any((p / f).is_file() for f in run_files)]
        if runs:
            more = len(runs) - 1
            found.append(f"{runs[0]}/" + (f" and {more} more point runs" if more else ""))
        return found

    def _refuse_to_replace(self, names: Sequence[str], point: int | None) -> None:
        """A fresh sweep (no --resume, no --overwrite) stops here in one line where it would
        replace a sweep's results; see prepare."""
        where = f"--output {self.output}"
        recorded = (self.output / SWEEP_CASE_FILE).is_file()
        changes = self._changes() if recorded else None
        held = self.held()
        if recorded and changes is not None and (held or point is not None):
            what = f"{changes}; {', '.join(held)}" if held else changes
            raise CaseError(
                f"{where}: holds a sweep of another case ({what}); write elsewhere with "
                "--output, or replace it with --overwrite"
            )
        if not recorded and held:
            raise CaseError(
                f"{where}: holds an earlier sweep ({', '.join(held)}) but no {SWEEP_CASE_FILE} "
                "(made by an older version or not by fsi-sweep); write elsewhere with --output, "
                "or replace it with --overwrite"
            )
        if point is not None:  # the siblings' rows are theirs: only this point's own counts
            own = self.held(names)
            if own:
                raise CaseError(
                    f"{where}: holds point {point}'s earlier result ({', '.join(own)}); "
                    "continue it with --resume, write elsewhere with --output, or replace it "
                    "with --overwrite"
                )
        elif held:
            raise CaseError(
                f"{where}: holds an earlier sweep ({', '.join(held)}); continue it with "
                "--resume, write elsewhere with --output, or replace it with --overwrite"
            )

    def rows(self) -> dict[str, dict]:
        """This case's finished rows on disk, by point name."""
        found = {}
        for path in sorted(self.rows_dir.glob("*.json")):
            try:
                record = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
            if isinstance(record, dict) and record.get("sweep") == self.key:
                found[path.stem] = record["row"]
        return found

    def put(self, name: str, row: dict) -> dict[str, dict]:
        """Record a finished point and merge the tables; every finished row, by name."""
        record = {"sweep": self.key, "row": row}
        atomic_write(self.rows_dir / f"{name}.json", json_text(record))
        return self.merge()

    def merge(self) -> dict[str, dict]:
        with folder_lock(self.output):
            found = self.rows()
            if found:
                write_tables(sorted(found.values(), key=self._sort), self.output)
        return found


def _milli(value: float | None, spec: str) -> str:
    """A figure in milli-units; a failed point's (null in the tables) as '-'."""
    return _figure(value, spec, scale=1e3)


def _thrust(row: dict) -> float | None:
    thrust = row.get("mean_thrust_n")
    return row.get("slender_body_mean_thrust_n") if thrust is None else thrust


def _figure(value: float | None, spec: str, scale: float = 1.0) -> str:
    """A figure (times ``scale``); a failed point's (null in the tables) as '-'. ``spec``
    "3s": three significant figures without an exponent (1000, 8.70, 0.0120)."""
    if value is None or not np.isfinite(value):
        return "-"
    value = scale * value
    if spec == "3s":
        if value == 0 or not 1e-4 <= abs(value) < 1e6:  # round-off, or far from a log's scale
            return "0" if value == 0 else format(value, ".3g")
        value = float(f"{value:.3g}")  # 9.996 -> 10.0, not 10.00
        return f"{value:.{max(2 - int(np.floor(np.log10(abs(value)))), 0)}f}"
    return format(value, spec)


def _tip_key(rows: list[dict], swimming: bool | None = None) -> tuple[str, str]:
    """The tail amplitude a sweep's table shows, and its header: a swimming sweep's at the
    swimming speed where its rows carry it (swimming.speed_coupling), else in still liquid."""
    if _swimming(rows, swimming):
        if any("tip_amplitude_at_speed_m" in r for r in rows):
            return "tip_amplitude_at_speed_m", "tip at speed [mm]"
        return "tip_amplitude_m", "tip, still liquid [mm]"
    return "tip_amplitude_m", "tip amplitude [mm]"


def _swimming(rows: list[dict], swimming: bool | None = None) -> bool:
    """A swimming case's sweep: its figure is the free fish's speed, not a held fish's
    thrust. ``swimming``: what the case says; else told by the rows (a failed point's row
    may lack the swimming columns)."""
    return swimming if swimming is not None else any(SWIMMING_KEYS[0] in r for r in rows)


def progress_line(
    row: dict, wall_s: float, finished: int, total: int, swimming: bool | None = None
) -> str:
    """One finished point, for logs: ``sweep: point 3/26 sine 5 Hz: ...``."""
    thrust = _thrust(row)
    status = row.get("status", "ok")
    tail = "" if status == "ok" else f"; {status}"
    figure = "" if thrust is None else f"thrust {_milli(thrust, '3s')} mN, "
    if _swimming([row], swimming):
        figure = f"speed {_figure(row.get('swimming_speed_m_s'), '3s')} m/s, "
    key, header = _tip_key([row], swimming)
    name = header.removesuffix(" [mm]")
    return (
        f"sweep: point {finished}/{total} {row['waveform']} {row['frequency_hz']:g} Hz: "
        f"{name} {_milli(row.get(key), '3s')} mm, {figure}{wall_s:.1f} s{tail}"
    )


def print_table(rows: list[dict], swimming: bool | None = None) -> None:
    swimming = _swimming(rows, swimming)
    figures = f"{'speed [m/s]':>12} {'body lengths/s':>14}" if swimming else f"{'thrust [mN]':>12}"
    tip, header = _tip_key(rows, swimming)
    print(f"{'waveform':>8} {'f [Hz]':>7} {header:>22} {figures}  status")
    for r in rows:
        if swimming:
            speed = _figure(r.get("swimming_speed_m_s"), ".3f")
            figures = f"{speed:>12} {_figure(r.get('body_lengths_per_s'), '.2f'):>14}"
        else:
            figures = f"{_milli(_thrust(r), '.2f'):>12}"
        print(
            f"{r['waveform']:>8} {r['frequency_hz']:7.2f} "
            f"{_milli(r.get(tip), '.2f'):>22} {figures}  {r.get('status', '')}"
        )


def _sweep(args: argparse.Namespace) -> int:
    comm = mpi_world()  # first: a mismatched launch stops before any work
    rank, size = (comm.Get_rank(), comm.Get_size()) if comm is not None else (0, 1)
    case = load(args)
    swims = case.analysis.kind is AnalysisKind.SWIMMING  # its table, even if every point failed
    if case.geometry.kind is GeometryKind.RECTANGLE:
        raise CaseError(
            'case.toml: geometry.kind = "rectangle" carries no actuators for fsi-sweep to drive; '
            'sweep a "fish" or "beam" case'
        )
    frequencies = parse_frequencies(args.frequencies)
    names = "sine,square" if args.waveforms.strip() == "both" else args.waveforms
    try:
        waveforms = [Waveform(w.strip()) for w in names.split(",")]
    except ValueError:
        raise CaseError(
            f"--waveforms {args.waveforms!r}: use sine, square, sine,square or both"
        ) from None
    if len(set(waveforms)) < len(waveforms):
        raise CaseError(f"--waveforms {args.waveforms!r}: a waveform is given twice")
    frequencies, waveforms = select_point(frequencies, waveforms, args.point)
    start_from = Path(args.start_from) if args.start_from else None
    if start_from is not None:
        check_start_from(case, start_from, args.method)
    if case.analysis.kind is AnalysisKind.SWIMMING and args.method == "transient":
        raise CaseError(
            'analysis.kind = "swimming": the swimming speed and turning come from the linear '
            "periodic response at speed; drop --method transient (the same fish's time march in "
            'still liquid: --set analysis.kind="dynamic")'
        )
    if case.time.start_from and args.method == "transient":
        raise CaseError(
            "time.start_from names one run, at one frequency; a sweep starts each point from "
            "the same point of an earlier sweep with --start-from SWEEP: remove the key"
        )
    output = output_folder(args.output, case.directory / "output" / "sweep")
    start = time.perf_counter()
    points = [point_name(w, f) for w in waveforms for f in frequencies]
    table = SweepTable(output, sweep_identity(case, args.method), waveforms)
    outcome: tuple[set[str] | None, str | None] = (None, None)
    if rank == 0:
        try:
            outcome = (table.prepare(points, args.resume, args.overwrite, args.point), None)
        except CaseError as err:
            if comm is None:
                raise
            outcome = (None, str(err))
    if comm is not None:  # every rank deals the same points, or stops with rank 0
        outcome = comm.bcast(outcome, root=0)
    done, refused = outcome
    if refused is not None:  # rank 0 says why, in one line
        if rank == 0:
            raise CaseError(refused)
        return EXIT_BAD_INPUT
    assert done is not None  # rank 0's (without MPI the only rank)

    def say(line: str, always: bool = False) -> None:
        if always or not args.quiet:
            print(line, file=sys.stderr, flush=True)

    if rank == 0:
        mpi = f", {size} MPI ranks" if size > 1 else ""
        resumed = f", {len(done)} done before (--resume)" if args.resume else ""
        plural = "s" if len(points) != 1 else ""
        say(f"sweep: {len(points)} point{plural} ({args.method}{mpi}) into {output}{resumed}")
        note = mpiexec_stop_note() if args.method == "transient" else None
        if note is not None:
            say(note)

    def on_row(name: str, row: dict, wall_s: float) -> None:
        finished = len(set(table.put(name, row)) & set(points))
        failed = row.get("status", "ok").startswith("failed")
        line = progress_line(row, wall_s, finished, len(points), swims)
        say(
            line
            + (
                f" (output kept in {output / name}; the whole error in {FAILURE_NOTE} there)"
                if failed and args.method == "transient"
                else ""
            ),
            always=failed,
        )

    if args.method == "linear":
        if rank != 0:  # seconds on one rank: the others have nothing to do
            return EXIT_OK
        case = without_cfd(case)
        undamped = case.fluid.damping_ratio == 0 and not case.fluid.edge_drag
        a = case.analysis
        if (case.fluid.model is FluidModel.NONE or undamped) and (
            case.material.loss_factor == 0 and a.rayleigh_alpha_per_s == a.rayleigh_beta_s == 0
        ):
            print(
                "note: no damping at all (material.loss_factor = 0, no fluid damping): at a "
                "resonance the linear amplitude is bounded only by the frequency step",
                file=sys.stderr,
            )
        elif case.fluid.model is not FluidModel.NONE and undamped:
            print(
                "note: no fluid damping: the linear sweep's amplitudes grow without bound near "
                "the wet resonances; --set fluid.edge_drag=true adds the separated-flow drag "
                "fitted to OpenFOAM (docs/validation.md)",
                file=sys.stderr,
            )
        linear_sweep(case, frequencies, waveforms, done, on_row)
    else:
        transient_sweep(
            case,
            frequencies,
            waveforms,
            output,
            comm=comm,
            done=done,
            resume=args.resume,
            on_row=on_row,
            start_from=start_from,
            finished=table.rows,
        )
        if rank != 0:  # rank 0 merges and prints, after the gather
            return EXIT_OK
    finished = table.merge()
    rows = [finished[n] for n in points if n in finished]
    if args.json:
        emit({"rows": rows, "wall_s": time.perf_counter() - start, "output": str(output)}, True)
    else:
        print_table(rows, swims)
        print(f"wrote {output / 'sweep.csv'} ({time.perf_counter() - start:.1f} s)")
    failed = [r for r in rows if r.get("status", "ok").startswith("failed")]
    if failed:
        say(f"sweep: {len(failed)} of {len(rows)} points failed (rerun them with --resume)", True)
    left = [n for n in points if n not in finished]  # another launch held them (RunningPoint)
    if left:
        say(
            f"sweep: {len(left)} point(s) left to another launch running them ({', '.join(left)}): "
            "no row yet; --resume once it has ended",
            True,
        )
    return EXIT_FAILED if failed or left else EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    parser = base_parser("fsi-sweep", "Tail amplitude and thrust versus driving frequency.")
    parser.add_argument(
        "--frequencies", default="1:25:2", help="start:stop:step or a,b,c Hz (default: 1:25:2)"
    )
    parser.add_argument(
        "--waveforms", default="sine,square", help="sine, square or both (default: both)"
    )
    parser.add_argument(
        "--method",
        choices=("linear", "transient"),
        default="linear",
        help="linear: modal superposition about the mean-voltage equilibrium, no CFD (an "
        "OpenFOAM case uses the potential model in its tank; seconds); transient: a run per "
        "frequency with the case's own fluid (MPI: each rank takes the next free frequency); "
        "default: linear",
    )
    parser.add_argument("--output", help="output folder (default: CASE/output/sweep)")
    parser.add_argument(
        "--point",
        type=int,
        help="run only the K-th point (0-based, waveforms then frequencies): one SLURM array "
        "task's share (scripts/slurm_array.sh); the rows merge in --output",
    )
    parser.add_argument(
        "--start-from",
        metavar="SWEEP",
        help="transient: start each point on the periodic orbit the same point of an earlier "
        "sweep ended on (its folder, e.g. the coarse level's; time.start_from): fewer periods "
        "to the periodic state. A point that sweep has no finished run for starts as usual",
    )
    earlier = parser.add_mutually_exclusive_group()
    earlier.add_argument(
        "--resume",
        action="store_true",
        help="skip the points whose rows are done in --output (same case) and run the rest; a "
        "killed transient point continues from its checkpoint",
    )
    earlier.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the sweep an existing --output holds (its sweep.csv, sweep.json and "
        "rows; with --point only that point's row); without it such a folder is refused",
    )
    parser.add_argument("--quiet", action="store_true", help="no line per finished point")
    return run_main(_sweep, parser, argv)


if __name__ == "__main__":
    raise SystemExit(main())
