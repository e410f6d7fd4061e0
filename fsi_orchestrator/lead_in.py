"""The coupling's start-up: a fluid-only lead-in before window 0, and its modal fit.

The structure starts on its (fast-model) periodic orbit with displacement u0 and velocity v0
while a CFD's plate is flat and its liquid at rest: jumping to u0 in one window would move the
plate at metres per second. Instead the fluid follows u(t) = r(t) u_orbit(t) over one period
(the orbit with all the harmonics it holds, a square wave's too), r a smooth ramp from 0 to 1
over its first half, so at t = 0 it arrives with the structure's position and velocity and a
developed flow. With a ``start_orbit`` the fluid's force over the second half corrects the
structure's orbit (fsi_orchestrator.start_orbit), and a second period blends the motion from
the old orbit into the new one. Prescribed motion: the structure is not advanced and its time
is untouched.

A fluid that starts displaced (StartsDisplaced, on a recorded orbit: time.start_from) is put
where the run that recorded the orbit ended, with that run's flow, and follows the orbit
unramped for one period: the predictor's period before t = 0.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from itertools import pairwise
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from .mapping import InterfaceMapping
from .participant import (
    ACCELERATION,
    DISPLACEMENT,
    FORCE,
    VELOCITY,
    FollowsMotion,
    OnPeriodicOrbit,
    Participant,
    StartsDisplaced,
)
from .predictors import lagrange_weights
from .start_orbit import (
    MIN_SHAPE_ALIGNMENT,
    LeadInSamples,
    ModalFit,
    StartOrbit,
    fit_modal_force,
)

T = TypeVar("T")
Motion = Callable[[float], NDArray[np.float64]]  # t -> the interface nodes' displacements
LEAD_IN_MAX_AMPLITUDE_M = 0.04  # largest interface motion of the fitting lead-in period
# ... and its largest speed: near the wet torsion modes (22-25 Hz for the clamped fish) the
# undamped fast orbit moved the fin at 3.5 m/s and blew the coarse CFD up within the first
# period; 2.5 m/s (18 Hz, square) ran (docs/coupling.md)
LEAD_IN_MAX_SPEED_M_S = 2.0
# a displaced lead-in's period is seeded with the two window ends before it, by periodicity
ENDS_BEFORE = 2


class FluidClock:
    """The fluid's share of a window's wall time (results.h5 coupling/fluid_wall_s: the rest of
    a window is the coupling's and the structure's)."""

    def __init__(self) -> None:
        self.wall_s = 0.0

    def run(self, call: Callable[..., T], *args: Any) -> T:
        """``call(*args)``, its wall time counted as the fluid's."""
        start = time.perf_counter()
        try:
            return call(*args)
        finally:
            self.wall_s += time.perf_counter() - start


class LeadIn:
    """The fluid alone through ``windows`` windows per period of the structure's orbit
    (angular frequency ``omega``) before window 0; see the module's docstring."""

    def __init__(
        self,
        fluid: Participant,
        mapping: InterfaceMapping,
        clock: FluidClock,
        windows: int,
        omega: float,
        start_orbit: StartOrbit | None = None,
        periods: int = 1,
        displaced: bool = False,
    ) -> None:
        """``periods``: how many periods the fluid follows the orbit without a start orbit to
        correct (the first ramped up; a start orbit takes two: fit and blend). ``displaced``:
        the fluid starts on the orbit instead (the module's docstring)."""
        self.fluid, self.mapping, self.clock = fluid, mapping, clock
        self.windows, self.omega, self.periods = windows, omega, periods
        self.start_orbit = start_orbit if windows > 0 else None
        if displaced and (self.start_orbit is not None or not isinstance(fluid, StartsDisplaced)):
            raise ValueError("a displaced lead-in needs a StartsDisplaced fluid, no start orbit")
        self.displaced = displaced
        self.start_fit: ModalFit | None = None
        # the prescribed-motion windows (one fluid step each): the fluid's wall time per
        # window, the denominator of the coupled / prescribed-motion cost ratio
        self.prescribed_wall_s_per_window: float | None = None
        self.wall_s = 0.0  # all of it, fit included (window 0's wall time holds it)
        # the last period and two windows of fluid forces (window end, structure's nodal
        # force), where the lead-in ends on whole periods of the orbit: the predictor's
        # history before t = 0 (its period rule looks a period back from the last two ends)
        self.last_period: list[tuple[float, NDArray[np.float64]]] = []

    @property
    def fluid_windows(self) -> int:
        """The lead-in's fluid windows: ``periods`` periods, two with a start orbit (the
        blend); displaced, one."""
        if self.displaced:
            return self.windows
        return self.periods * self.windows if self.start_orbit is None else 2 * self.windows

    def run(self, solid: Participant, dt: float, arrive: Callable[[Motion], None]) -> None:
        """The lead-in (none without windows or frequency); ``arrive(motion)`` hands on the
        motion the fluid was moved through, ending at t = 0 (the initial data)."""
        n = self.windows
        if n <= 0 or self.omega <= 0:
            return
        start = time.perf_counter()
        motion = self._periods(solid, dt)
        arrive(motion)
        self.wall_s = time.perf_counter() - start
        self.prescribed_wall_s_per_window = self.clock.wall_s / self.fluid_windows

    def _periods(self, solid: Participant, dt: float) -> Motion:
        """The lead-in's periods of prescribed motion; returns the last one's motion."""
        n = self.windows
        old = periodic_motion(solid, self.omega)
        if self.displaced:  # one period from t = -T, where the fluid starts on the orbit
            times = [(k - n) * dt for k in range(1, n + 1)]
            assert isinstance(self.fluid, StartsDisplaced)  # __init__ checks
            self.fluid.start_displaced(self.mapping.consistent(old(-n * dt)))
            self.follow(old, times, dt)
            return old
        periods = self.periods if self.start_orbit is None else 1
        # ``periods`` periods ending at t = 0, ramped up over the first half period
        times = [(k - periods * n) * dt for k in range(1, periods * n + 1)]
        half = n * dt / 2

        def ramped(t: float) -> NDArray[np.float64]:
            return smoothstep((t - times[0] + dt) / half) * old(t)

        if self.start_orbit is None:
            self.follow(ramped, times, dt)
            return ramped
        cap = self._fit(self.start_orbit, old, ramped, times, dt)
        new = periodic_motion(solid, self.omega)

        def blended(t: float) -> NDArray[np.float64]:
            r = smoothstep((t - times[0] + dt) / (n * dt))
            return (1 - r) * cap * old(t) + r * new(t)

        self.follow(blended, times, dt)
        return blended

    def _fit(
        self, orbit: StartOrbit, old: Motion, ramped: Motion, times: list[float], dt: float
    ) -> float:
        """The fitting period: the fluid's force over the ramped orbit's second half corrects
        the structure's orbit (start_fit). Near the fast model's (undamped) wet resonance its
        orbit is unbounded; the fit needs only some motion along it, so the period is capped
        at the amplitude the mesh motion is checked for (issue 4: +-40 mm at the tail) and at
        a speed the CFD resolves. Returns that cap."""
        samples = [times[0] - dt, *times]
        peak = max(float(np.max(np.abs(old(t)))) for t in samples)
        speed = peak_speed(old, samples)
        cap = min(
            1.0,
            LEAD_IN_MAX_AMPLITUDE_M / peak if peak > 0 else 1.0,
            LEAD_IN_MAX_SPEED_M_S / speed if speed > 0 else 1.0,
        )

        def probe(t: float) -> NDArray[np.float64]:
            return cap * ramped(t)

        half = self.windows * dt / 2
        recorded = self.follow(probe, times, dt, record_from=times[0] - dt + half)
        assert recorded is not None  # a record_from records
        fit = fit_modal_force(recorded, orbit.shape_z, orbit.added_mass_z)
        alignment = orbit.restart(fit, MIN_SHAPE_ALIGNMENT)
        self.start_fit = dataclasses.replace(
            fit, alignment=alignment, applied=alignment >= MIN_SHAPE_ALIGNMENT
        )
        return cap

    def follow(
        self, motion: Motion, times: list[float], dt: float, record_from: float | None = None
    ) -> LeadInSamples | None:
        """The fluid alone through a prescribed interface motion u(t) (solid nodes), window by
        window, or all at once by a fluid that can (optional ``follow(displacements, dt)``:
        OpenFOAM runs them in one launch). Samples from ``record_from`` on."""
        if isinstance(self.fluid, FollowsMotion):
            moved = [self.mapping.consistent(motion(t)) for t in times]
            forces = self.clock.run(self.fluid.follow, moved, dt)
        else:
            forces = [self._prescribed_window(motion, t, dt) for t in times]
        self.last_period = []
        if (self.periods >= 2 or self.displaced) and self.start_orbit is None:  # on the orbit
            ends = list(zip(times, forces, strict=True))[-self.windows - 2 :]
            if self.displaced:  # one period: the ends before it by periodicity
                before = ends[-ENDS_BEFORE:]
                ends = [(t - self.windows * dt, f) for t, f in before] + ends
            self.last_period = [(t, self.mapping.conservative(f)) for t, f in ends]
        if record_from is None:
            return None
        rows = [
            (t, motion(t)[:, 2], _velocity(motion, t, dt)[:, 2])
            + (motion_acceleration(motion, t, dt)[:, 2], self.mapping.conservative(f)[:, 2])
            for t, f in zip(times, forces, strict=True)
            if t >= record_from - 1e-9 * dt
        ]
        t, u, v, a, f = (np.array(c) for c in zip(*rows, strict=True))
        return LeadInSamples(t, u, v, a, f)

    def _prescribed_window(self, motion: Motion, t: float, dt: float) -> NDArray[np.float64]:
        """One fluid window ending at t on the motion (velocity and acceleration: central
        differences of u); the fluid's nodal force."""
        self.fluid.read_data(
            {
                DISPLACEMENT: self.mapping.consistent(motion(t)),
                VELOCITY: self.mapping.consistent(_velocity(motion, t, dt)),
                ACCELERATION: self.mapping.consistent(motion_acceleration(motion, t, dt)),
            }
        )
        self.clock.run(self.fluid.solve, dt)
        return self.fluid.write_data()[FORCE]


def peak_speed(motion: Motion, times: list[float]) -> float:
    """The largest speed of any interface node along u(t) between consecutive sample times."""
    path = [motion(t) for t in times]
    return max(
        float(np.max(np.abs(b - a))) / (tb - ta)
        for (ta, a), (tb, b) in pairwise(zip(times, path, strict=True))
    )


def bridge_start_up(
    ends: list[tuple[float, dict[str, NDArray[np.float64]]]], count: int
) -> list[tuple[float, dict[str, NDArray[np.float64]]]]:
    """A displaced lead-in's period (LeadIn.last_period, the two ends before it first) with its
    first ``count`` windows replaced by cubic interpolation in time from the two ends on either
    side. A CFD started from a mapped flow zig-zags about its force in its first windows
    (StartsDisplaced.start_up_windows), and an acceleration differentiated across t = -T
    differentiates the recorded orbit's closure (its last period does not repeat exactly); the
    predictor's period rule would hand either on to the coupled windows a period later."""
    first, last = ENDS_BEFORE, ENDS_BEFORE + count
    if len(ends) < last + 2:
        raise ValueError(f"a period of {len(ends)} window ends cannot bridge {count} windows")
    known = [*ends[:first], *ends[last : last + 2]]
    times = [t for t, _ in known]
    bridged = []
    for t, _ in ends[first:last]:
        weights = lagrange_weights(times, t)
        values = {
            name: sum(w * v[name] for w, (_, v) in zip(weights, known, strict=True))
            for name in known[0][1]
        }
        bridged.append((t, values))
    return [*ends[:first], *bridged, *ends[last:]]


def smoothstep(s: float) -> float:
    """C2 ramp from 0 (s <= 0) to 1 (s >= 1)."""
    s = min(1.0, max(0.0, s))
    return s * s * s * (10 - 15 * s + 6 * s * s)


def periodic_motion(solid: Participant, omega: float) -> Motion:
    """u(t): the interface motion on the periodic orbit the structure starts on now, with all
    its harmonics (``orbit_motion``, optional in the protocol); else the harmonic
    u0 cos wt + v0/w sin wt through its state at t = 0."""
    on_orbit = solid.orbit_motion() if isinstance(solid, OnPeriodicOrbit) else None
    if on_orbit is not None:
        return on_orbit
    state = solid.write_data()
    u0, v0 = state[DISPLACEMENT], state[VELOCITY]

    def harmonic(t: float) -> NDArray[np.float64]:
        u: NDArray[np.float64] = u0 * np.cos(omega * t) + v0 / omega * np.sin(omega * t)
        return u

    return harmonic


def _velocity(motion: Motion, t: float, dt: float) -> NDArray[np.float64]:
    h = 1e-4 * dt
    rate: NDArray[np.float64] = (motion(t + h) - motion(t - h)) / (2 * h)
    return rate


def motion_acceleration(motion: Motion, t: float, dt: float) -> NDArray[np.float64]:
    h = 1e-4 * dt
    rate: NDArray[np.float64] = (motion(t + h) - 2 * motion(t) + motion(t - h)) / h**2
    return rate
