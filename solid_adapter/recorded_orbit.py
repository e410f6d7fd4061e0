"""The last period of a run's motion, kept to start another run on it (``time.start_from``).

A run that has reached its periodic state knows its orbit better than any fast model: the
coarse CFD's 3 Hz orbit is within 1 % of the default level's answer in tail amplitude, where a
coupled run from the fast model's start swings by 3-8 % for periods (docs/coupling.md). The
shell keeps its displacements and velocities at the last N + 1 window ends (N windows per
period) and writes them to the checkpoint. A run started from it takes the source's end state
(exact) at t = 0 and the trigonometric interpolant of that period as its orbit, which a CFD
lead-in follows; the delayed feedback's period before t = 0 is the recorded velocities.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .harmonic import PeriodicResponse, periodic_response_from_samples

STEPS, PERIOD = "orbit_steps", "orbit_period_s"
DISPLACEMENTS, VELOCITIES = "orbit_displacements", "orbit_velocities"


class OrbitRecorder:
    """Displacements and velocities at the last ``steps_per_period`` + 1 window ends (a whole
    period, both its ends), by step."""

    def __init__(self, steps_per_period: int, period_s: float) -> None:
        self.steps_per_period, self.period_s = int(steps_per_period), float(period_s)
        self._states: dict[int, tuple[NDArray, NDArray]] = {}

    def record(self, t: float, x: NDArray, v: NDArray) -> None:
        """The state at a window end t (a re-solved window records it again)."""
        at = t * self.steps_per_period / self.period_s
        step = round(at)
        if abs(at - step) > 1e-6:  # not a window end (a sub-step)
            return
        self._states[step] = (x.copy(), v.copy())
        for old in [k for k in self._states if k < step - self.steps_per_period]:
            del self._states[old]

    def state(self) -> dict[str, NDArray | float]:
        steps = sorted(self._states)
        if not steps:
            return {}
        return {
            STEPS: np.array(steps, dtype=np.int64),
            DISPLACEMENTS: np.array([self._states[k][0] for k in steps]),
            VELOCITIES: np.array([self._states[k][1] for k in steps]),
            PERIOD: self.period_s,
        }

    def restore(self, state) -> None:
        self._states.clear()
        if STEPS not in state or VELOCITIES not in state:  # none kept: record a period again
            return
        steps = np.asarray(state[STEPS], dtype=np.int64)
        pairs = zip(np.asarray(state[DISPLACEMENTS]), np.asarray(state[VELOCITIES]), strict=True)
        for k, (x, v) in zip(steps, pairs, strict=True):
            self._states[int(k)] = (np.array(x, dtype=float), np.array(v, dtype=float))


@dataclass(frozen=True)
class RecordedOrbit(PeriodicResponse):
    """The interpolant of a recorded period, with the velocities the integrator had at the
    N window starts before t = 0 (row j: step j - N): the delayed feedback's period before
    t = 0 is then the one the source run fed back on, not the interpolant's derivative."""

    step_velocities: NDArray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    def velocity_at_step(self, k: int) -> NDArray:
        """The recorded velocity at the start of step k, -N <= k < 0."""
        if not -len(self.step_velocities) <= k < 0:
            raise IndexError(f"step {k} is not in the recorded period before t = 0")
        return self.step_velocities[k + len(self.step_velocities)]


@dataclass(frozen=True)
class RecordedStart:
    """Where a run starts from another's last period: the orbit and the exact end state."""

    orbit: RecordedOrbit
    x0: NDArray
    v0: NDArray
    a0: NDArray
    source: Path
    previous: tuple[NDArray, float]  # the displacements one window before the end, dt


class StartFromError(ValueError):
    """The run named by time.start_from cannot start this one (one line, names the key)."""


def recorded_start(path: Path, shell_state, frequency_hz: float, ndof: int) -> RecordedStart:
    """The start a checkpoint's shell state gives a run driven at ``frequency_hz`` on a shell
    of ``ndof`` unknowns (StartFromError where it cannot)."""
    where = f"time.start_from: {path}"
    if STEPS not in shell_state or VELOCITIES not in shell_state:
        raise StartFromError(
            f"{where} holds no recorded period: a run of an older version, one shorter than a "
            "period, one without actuators or one given by time.step_s; start from a "
            "driven run of whole periods"
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
    n = len(steps) - 1  # windows per period: the period's both ends are recorded
    t_end = float(shell_state["t"])
    dt = period / n if n > 0 else float("nan")
    end_step = round(t_end / dt) if n > 0 else -1
    whole = n >= 4 and np.array_equal(steps, np.arange(end_step - n, end_step + 1))
    if not whole or end_step % n or not np.isclose(end_step * dt, t_end, rtol=1e-6):
        raise StartFromError(
            f"{where} ended at t = {t_end:g} s, not at the end of a whole recorded period: "
            "start from a run that ran whole periods"
        )
    # steps end - n .. end: the interpolant through the last n (sample j at phase j T / n,
    # the end state at phase 0); the velocities at the n window starts before the end
    displacements = np.asarray(shell_state[DISPLACEMENTS], dtype=float)
    samples = np.empty_like(displacements[1:])
    samples[steps[1:] % n] = displacements[1:]
    velocities = np.asarray(shell_state[VELOCITIES], dtype=float)[:-1]
    interpolant = periodic_response_from_samples(2 * np.pi * frequency_hz, samples)
    orbit = RecordedOrbit(
        interpolant.omega, interpolant.x_static, interpolant.harmonics, velocities
    )
    v0, a0 = (np.asarray(shell_state[k], dtype=float) for k in ("v", "a"))
    previous = (displacements[-2].copy(), dt)
    return RecordedStart(orbit, x_end.copy(), v0.copy(), a0.copy(), path, previous)
