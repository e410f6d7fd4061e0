"""Progress on stderr for every log: a live bar in a terminal, plain lines elsewhere (a SLURM
log, ``2>file``), set-up phases announced with their durations, and SIGTERM turned into a
checkpoint at the end of the running window."""

from __future__ import annotations

import contextlib
import math
import signal
import sys
import time
from collections.abc import Callable, Iterator
from typing import TextIO

# without a terminal, windows shorter than this are reported together (a fast model's
# thousand windows would otherwise flood the log)
LINE_EVERY_S = 5.0


def duration(seconds: float) -> str:
    """3.2 s, 4m05s, 2h03m."""
    if not math.isfinite(seconds):
        return "?"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, s = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{s:02d}s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m"


def window_line(done: int, total: int, row: dict, wall_per_window: float) -> str:
    """``window 12/80  t 0.1 s  fluid solves 3  residual 2.1e-05  3.4 s/window  ETA 3m58s``."""
    parts = [f"window {done}/{total}", f"t {row.get('time_s', float('nan')):.6g} s"]
    if "coupling/fluid_solves" in row:
        parts.append(f"fluid solves {int(row['coupling/fluid_solves'])}")
    if "coupling/residual" in row:
        parts.append(f"residual {row['coupling/residual']:.2e}")
    parts.append(f"{wall_per_window:.3g} s/window")
    parts.append(f"ETA {duration(wall_per_window * (total - done))}")
    return "  ".join(parts)


class RunProgress:
    """One run's progress. ``enabled=False`` (``--quiet``) prints nothing at all.

    ``hold=True`` keeps the set-up's lines until the run is under way (:meth:`release`, or
    the first window): a case refused at set-up (a buckling mean voltage, a checkpoint that
    does not fit) then says so in its one error line alone."""

    def __init__(self, enabled: bool, stream: TextIO | None = None, hold: bool = False) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.live = enabled and self.stream.isatty()
        self._held: list[str] | None = [] if hold else None
        self._last_line = -math.inf
        self._walls: list[float] = []

    def say(self, text: str) -> None:
        if not self.enabled:
            return
        if self._held is not None:
            self._held.append(text)
            return
        print(text, file=self.stream, flush=True)

    def release(self) -> None:
        """Print what was held, and from now on print at once."""
        held, self._held = self._held or [], None
        for text in held:
            self.say(text)

    @contextlib.contextmanager
    def phase(self, name: str) -> Iterator[None]:
        """``name: 12.3 s`` once done (set-up, meshing)."""
        start = time.perf_counter()
        yield
        self.say(f"{name}: {duration(time.perf_counter() - start)}")

    @contextlib.contextmanager
    def windows(self, total: int) -> Iterator[Callable[[int, int, dict], None]]:
        """The loop's progress callback: (windows done, total, the window's results row)."""
        if not self.enabled:
            yield lambda done, total, row: None
            return
        if self.live:
            self.release()
            with self._bar(total) as update:
                yield update
            return
        yield self._line

    def _line(self, done: int, total: int, row: dict) -> None:
        self.release()  # a resumed run is under way once its first window is done
        wall = float(row.get("wall_s", 0.0))
        self._walls.append(wall)
        now = time.perf_counter()
        if done < total and now - self._last_line < LINE_EVERY_S and wall < LINE_EVERY_S:
            return
        self._last_line = now
        # the ETA from the recent windows: the first holds the set-up's lead-in
        recent = self._walls[-10:] if len(self._walls) > 1 else self._walls
        per_window = sum(recent) / len(recent)
        self.say(window_line(done, total, row, per_window))

    @contextlib.contextmanager
    def _bar(self, total: int) -> Iterator[Callable[[int, int, dict], None]]:
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        with Progress(
            TextColumn("window"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TextColumn("{task.fields[detail]}"),
            TimeRemainingColumn(),
            console=Console(file=self.stream),
            transient=True,
        ) as bar:
            task = bar.add_task("run", total=total, detail="")

            def update(done: int, total: int, row: dict) -> None:
                detail = ""
                if "coupling/fluid_solves" in row:
                    detail = f"solves {int(row['coupling/fluid_solves'])}"
                bar.update(task, completed=done, detail=detail)

            yield update


class StopRequest:
    """Set by SIGTERM (SLURM's time limit, scancel) or a first Ctrl-C: the loop ends after the
    running window with a checkpoint, where a kill would lose the windows since the last one.
    A second Ctrl-C stops at once."""

    def __init__(self) -> None:
        self.signal: int | None = None

    def reason(self) -> str | None:
        """The signal's name once one asked the run to stop."""
        return None if self.signal is None else signal.Signals(self.signal).name

    @contextlib.contextmanager
    def on_sigterm(self) -> Iterator[StopRequest]:
        def request(signum, frame) -> None:
            if signum == signal.SIGINT and self.signal is not None:
                raise KeyboardInterrupt  # asked twice: stop now
            self.signal = signum

        installed = []
        try:
            for signum in (signal.SIGTERM, signal.SIGINT):
                installed.append((signum, signal.signal(signum, request)))
        except ValueError:  # not the main thread: nothing to install
            pass
        try:
            yield self
        finally:
            for signum, previous in installed:
                signal.signal(signum, previous)
