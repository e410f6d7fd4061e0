"""The last period of a run's motion, kept to start another run on it (``time.start_from``).

A run that has reached its periodic state knows its orbit better than any fast model: the
coarse CFD's 3 Hz orbit is within 0.4 % of the default level's in tail amplitude, where the
fast model's start is 10 % off and the coupled start-up then beats for periods. The shell keeps
its displacements at the last N window ends (N windows per period) and writes them to the
checkpoint. A run started from it takes the source's end state (exact) at t = 0, and the
trigonometric interpolant of that period as its orbit: what a CFD lead-in follows and what
the delayed feedback takes as the period before t = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .harmonic import PeriodicResponse, periodic_response_from_samples

STEPS, DISPLACEMENTS, PERIOD = "orbit_steps", "orbit_displacements", "orbit_period_s"


class OrbitRecorder:
    """Displacements at the last ``steps_per_period`` window ends, by step index."""

    def __init__(self, steps_per_period: int, period_s: float) -> None:
        self.steps_per_period, self.period_s = int(steps_per_period), float(period_s)
        self._x: dict[int, NDArray] = {}

    def record(self, t: float, x: NDArray) -> None:
        """The displacement x at a window end t (a re-solved window records it again)."""
        at = t * self.steps_per_period / self.period_s
        step = round(at)
        if abs(at - step) > 1e-6:  # not a window end (a sub-step)
            return
        self._x[step] = x.copy()
        for old in [k for k in self._x if k <= step - self.steps_per_period]:
            del self._x[old]

    def state(self) -> dict[str, NDArray | float]:
        steps = sorted(self._x)
        return {
            STEPS: np.array(steps, dtype=np.int64),
            DISPLACEMENTS: np.array([self._x[k] for k in steps]).reshape(len(steps), -1),
            PERIOD: self.period_s,
        }

    def restore(self, state) -> None:
        self._x.clear()
        steps = np.asarray(state.get(STEPS, np.zeros(0)), dtype=np.int64)
        for k, x in zip(steps, np.asarray(state.get(DISPLACEMENTS, [])), strict=True):
            self._x[int(k)] = np.array(x, dtype=float)


@dataclass(frozen=True)
class RecordedStart:
    """Where a run starts from another's last period: the orbit and the exact end state."""

    orbit: PeriodicResponse
    x0: NDArray
    v0: NDArray
    a0: NDArray
    source: Path


class StartFromError(ValueError):
    """The run named by time.start_from cannot start this one (one line, names the key)."""


def recorded_start(path: Path, shell_state, frequency_hz: float, ndof: int) -> RecordedStart:
    """The start a checkpoint's shell state gives a run driven at ``frequency_hz`` on a shell
    of ``ndof`` unknowns (StartFromError where it cannot)."""
    where = f"time.start_from: {path}"
    if STEPS not in shell_state:
        raise StartFromError(
            f"{where} holds no recorded period (a run of an older version, or one shorter "
            "than a period): rerun it, then start from it"
        )
    period = float(shell_state[PERIOD])
    if not np.isclose(period * frequency_hz, 1.0, rtol=1e-9, atol=0):
        raise StartFromError(
            f"{where} was driven at {1 / period:g} Hz, this case at {frequency_hz:g} Hz: start "
            "from a run at the same frequency"
        )
    x_end = np.asarray(shell_state["x"], dtype=float)
    if x_end.size != ndof:
        raise StartFromError(
            f"{where} has a shell of {x_end.size} unknowns, this case's has {ndof}: the shell "
            "meshes differ (mesh level, planform); start from a run on the same shell"
        )
    steps = np.asarray(shell_state[STEPS], dtype=np.int64)
    n = len(steps)
    t_end = float(shell_state["t"])
    dt = period / n if n else float("nan")
    end_step = round(t_end / dt) if n else -1
    whole = n >= 4 and np.array_equal(steps, np.arange(end_step - n + 1, end_step + 1))
    if not whole or end_step % n or not np.isclose(end_step * dt, t_end, rtol=1e-6):
        raise StartFromError(
            f"{where} ended at t = {t_end:g} s, not at the end of a whole recorded period: "
            "start from a run that ran whole periods"
        )
    displacements = np.asarray(shell_state[DISPLACEMENTS], dtype=float)
    samples = np.empty_like(displacements)
    samples[steps % n] = displacements  # sample j at phase j T / n
    orbit = periodic_response_from_samples(2 * np.pi * frequency_hz, samples)
    v0, a0 = (np.asarray(shell_state[k], dtype=float) for k in ("v", "a"))
    return RecordedStart(orbit, x_end.copy(), v0.copy(), a0.copy(), path)
