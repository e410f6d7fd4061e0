"""Implicit partitioned coupling of one time window (the ANSYS MFX stand-in).

Gauss-Seidel per iteration (the seed's order, Sec. 2.2.3: structure first, then fluid):

    solid.read(force x) -> solid.solve -> map (d, v, a) -> fluid.solve -> map force back -> x~

and the accelerator proposes the next x until the convergence criteria hold, each new iteration
starting from the checkpoint of the window's start. The iterated variable is the force on the
structure's interface nodes.

Added-mass preconditioning (schemes ``iqn-ils-am`` and ``explicit-am``). The liquid is far
denser than the plate: its force is dominated by -M_a a, the added mass times the plate's
acceleration, so the plain fixed-point map has a gain of about M_a/M_s (~40 here) and naive
iteration diverges. A fast model's interface added mass M~_a (potential flow) moves that part to
the structure's side: the structure integrates with M_s + M~_a, and the exchanged variable
becomes g = f_fluid + M~_a a. With the exact model g no longer depends on the motion (one
iteration); with a real fluid it depends only on the model error (M_a - M~_a) a and the viscous
rest, so the map is strongly contractive. This is the interface-quasi-Newton method with the
initial Jacobian taken from M~_a, written as a change of variables; the least-squares
quasi-Newton update then learns the rest and keeps it from window to window in a multi-vector
Jacobian (IQN-IMVJ, acceleration/iqn_imvj.py), since the preconditioned map changes little.
With one solve per window (``explicit-am``) the correction alone keeps a persistent,
non-restartable fluid solver stable. ``iqn-ils-am`` may start that way for its first periods
(``explicit_windows``): the start-up transient then costs what prescribed motion costs, and
the windows after it are iterated to the tolerance (docs/coupling.md).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping
from itertools import pairwise
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from .acceleration import Acceleration
from .case.schema import CouplingScheme
from .convergence import (
    ConvergenceCriteria,
    CouplingDivergenceError,
    ScaledRelativeMeasure,
    WindowStatus,
)
from .coupling_settings import CouplingSettings as CouplingSettings  # re-exported
from .mapping import InterfaceMapping
from .participant import (
    ACCELERATION,
    DISPLACEMENT,
    FORCE,
    PAST_DISPLACEMENT,
    VELOCITY,
    FollowsMotion,
    HasAccelerationStencil,
    InitializesData,
    OnPeriodicOrbit,
    Participant,
    ParticipantSetupError,
)
from .predictors import EXPLICIT_RULES, PERIODIC_RULES, Predictor
from .start_orbit import (
    MIN_SHAPE_ALIGNMENT,
    LeadInSamples,
    ModalFit,
    StartOrbit,
    fit_modal_force,
)

FIELD = "force"
T = TypeVar("T")
Motion = Callable[[float], NDArray[np.float64]]  # t -> the interface nodes' displacements
MAX_RETRIES = 3  # halvings of an iterate a solver failed on
SCALE_MEMORY = 20  # windows over which the fluid force's size is remembered
PAST_WINDOWS = 4  # lead-in displacements handed on (a BDF2-of-BDF2 stencil needs 3)
LEAD_IN_MAX_AMPLITUDE_M = 0.04  # largest interface motion of the fitting lead-in period
# ... and its largest speed: near the wet torsion modes (22-25 Hz for the clamped fish) the
# undamped fast orbit moved the fin at 3.5 m/s and blew the coarse CFD up within the first
# period; 2.5 m/s (18 Hz, square) ran (docs/coupling.md)
LEAD_IN_MAX_SPEED_M_S = 2.0


class Coupling:
    """Couples a fluid participant to the structure over one window at a time."""

    def __init__(
        self,
        fluid: Participant,
        solid_points: NDArray[np.float64],
        settings: CouplingSettings,
        added_mass_z: NDArray[np.float64] | None = None,
        start_orbit: StartOrbit | None = None,
    ) -> None:
        self.fluid, self.settings = fluid, settings
        self.start_orbit = start_orbit if settings.lead_in_windows > 0 else None
        self.start_fit: ModalFit | None = None
        fluid_points = fluid.interface().points
        self.mapping = InterfaceMapping.from_points(solid_points[:, :2], fluid_points[:, :2])
        scale = settings.added_mass_scale
        self.added_mass_z = (
            scale * added_mass_z if scale is not None and added_mass_z is not None else None
        )
        self.n_solid = len(solid_points)
        self.accelerator: Acceleration | None = settings.scheme_settings.make_accelerator()
        if self.accelerator is not None:
            self.accelerator.initialize({FIELD: np.zeros((self.n_solid, 3))})
        self.predictor = Predictor(settings.predictor, period=settings.period_s)
        self.measure = ScaledRelativeMeasure(tolerance=settings.tolerance_rel)
        self.criteria = ConvergenceCriteria(
            {FIELD: [self.measure]},
            max_iterations=settings.max_iterations,
        )
        self.norms: list[float] = []
        # the tolerance refers to the fluid force's size over the last windows: its norm passes
        # through zero twice a period, where a purely instantaneous reference would be harsh
        self.force_scales: list[float] = []  # the fluid force's norm at past window ends
        self._force_norm = 0.0  # ... and at the last iteration
        self.fluid_wall_s = 0.0  # inside the fluid's solve / follow in the current window
        # the lead-in's prescribed-motion windows (one fluid step each): the fluid's wall time
        # per window, the denominator of the coupled / prescribed-motion cost ratio
        self.prescribed_wall_s_per_window: float | None = None
        self.lead_in_wall_s = 0.0  # all of it, fit included (window 0's wall time holds it)
        self.resumed_from_scheme: CouplingScheme | None = None  # a resumed run's former scheme

    def _in_fluid(self, call: Callable[..., T], *args: Any) -> T:
        """``call(*args)``, its wall time counted as the fluid's (results.h5
        coupling/fluid_wall_s: the rest of a window is the coupling's and the structure's)."""
        start = time.perf_counter()
        try:
            return call(*args)
        finally:
            self.fluid_wall_s += time.perf_counter() - start

    # ------------------------------------------------------------------ lead-in
    def lead_in(self, solid: Participant, dt: float) -> None:
        """Fluid-only lead-in before window 0. The structure starts on its (fast-model)
        periodic orbit with displacement u0 and velocity v0 while the CFD's plate is flat and
        its liquid at rest: jumping to u0 in one window would move the plate at metres per
        second. Instead the fluid follows u(t) = r(t) u_orbit(t) over one period (the orbit
        with all the harmonics it holds, a square wave's too), r a smooth ramp from 0 to 1
        over its first half, so at t = 0 it arrives with the structure's position and
        velocity and a developed flow. With a ``start_orbit``
        the fluid's force over the second half corrects the structure's orbit
        (fsi_orchestrator.start_orbit), and a second period blends the motion from the old
        orbit into the new one. Prescribed motion: the structure is not advanced and its
        time is untouched."""
        n, omega = self.settings.lead_in_windows, self.settings.lead_in_omega
        if n <= 0 or omega <= 0:
            return
        start = time.perf_counter()
        periods = self._lead_in(solid, dt, n, omega)
        self.lead_in_wall_s = time.perf_counter() - start
        self.prescribed_wall_s_per_window = self.fluid_wall_s / (periods * n)

    def _lead_in(self, solid: Participant, dt: float, n: int, omega: float) -> int:
        """The lead-in's periods of prescribed motion; returns how many it took."""
        old = _periodic_motion(solid, omega)
        times = [(k - n) * dt for k in range(1, n + 1)]  # one period, ending at t = 0
        half = n * dt / 2

        def ramped(t: float) -> NDArray[np.float64]:
            return _smoothstep((t - times[0] + dt) / half) * old(t)

        if self.start_orbit is None:
            self._follow(ramped, times, dt)
            self._initialize_data(solid, ramped, dt)
            return 1
        # near the fast model's (undamped) wet resonance its orbit is unbounded; the fit needs
        # only some motion along it, so the first period is capped at the amplitude the mesh
        # motion is checked for (issue 4: +-40 mm at the tail) and at a speed the CFD resolves
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

        recorded = self._follow(probe, times, dt, record_from=times[0] - dt + half)
        assert recorded is not None  # a record_from records
        fit = fit_modal_force(recorded, self.start_orbit.shape_z, self.start_orbit.added_mass_z)
        alignment = self.start_orbit.restart(fit, MIN_SHAPE_ALIGNMENT)
        self.start_fit = dataclasses.replace(
            fit, alignment=alignment, applied=alignment >= MIN_SHAPE_ALIGNMENT
        )
        new = _periodic_motion(solid, omega)

        def blended(t: float) -> NDArray[np.float64]:
            r = _smoothstep((t - times[0] + dt) / (n * dt))
            return (1 - r) * cap * old(t) + r * new(t)

        self._follow(blended, times, dt)
        self._initialize_data(solid, blended, dt)
        return 2

    def _initialize_data(self, solid: Participant, motion: Motion, dt: float) -> None:
        """The lead-in's last fluid solve ends at t = 0 with the structure's motion there: its
        force is the exchanged variable at t = 0 (preCICE's initial data). The structure takes
        it as its load at t = 0, which window 0's generalized-alpha balance weights with
        alpha_f; left at zero, a plain scheme (x = f ~ -M_a a) started with an impulse of
        alpha_f M_a a(0) that an *-am scheme (x = g = f + M~ a, small) hardly felt, and the two
        converged to different runs (0.17 mm, 19 % of the force apart). The predictor takes
        it as its first value. With it go the displacements the fluid was moved through,
        which a fluid-consistent added-mass acceleration differentiates."""
        stencil = (
            self.fluid.acceleration_stencil
            if isinstance(self.fluid, HasAccelerationStencil)
            else None
        )
        if isinstance(solid, InitializesData):
            past = np.array([motion(-k * dt) for k in range(1, PAST_WINDOWS + 1)])
            history = {PAST_DISPLACEMENT: past}
            if stencil is not None and self.added_mass_z is not None:
                # the acceleration the fluid saw at t = 0: the initial g then holds the same
                # acceleration as every later window's (the start-up ring of explicit-am,
                # docs/coupling.md, is the lagged load catching up, not this)
                levels = [motion(0.0), *past]
                history[ACCELERATION] = (
                    sum(c * u for c, u in zip(stencil, levels, strict=False)) / dt**2
                )
            solid.initialize_data(history)
        self._start_from_fluid_force(solid)

    def _start_from_fluid_force(self, solid: Participant) -> None:
        """The fluid's last force in this scheme's exchanged variable (f, or g = f + M~ a with
        the structure's present acceleration for an *-am scheme) becomes the structure's load
        and the predictor's only value."""
        x = self.mapping.conservative(self.fluid.write_data()[FORCE])
        if self.added_mass_z is not None:
            x[:, 2] += self.added_mass_z @ solid.write_data()[ACCELERATION][:, 2]
        if isinstance(solid, InitializesData):
            solid.initialize_data({FORCE: x})
        self.predictor.restart(solid.time, {FIELD: x})

    def _follow(
        self, motion: Motion, times: list[float], dt: float, record_from: float | None = None
    ) -> LeadInSamples | None:
        """The fluid alone through a prescribed interface motion u(t) (solid nodes), window by
        window, or all at once by a fluid that can (optional ``follow(displacements, dt)``:
        OpenFOAM runs them in one launch). Samples from ``record_from`` on."""
        if isinstance(self.fluid, FollowsMotion):
            moved = [self.mapping.consistent(motion(t)) for t in times]
            forces = self._in_fluid(self.fluid.follow, moved, dt)
        else:
            forces = [self._prescribed_window(motion, t, dt) for t in times]
        if record_from is None:
            return None
        rows = [
            (t, motion(t)[:, 2], _velocity(motion, t, dt)[:, 2])
            + (_acceleration(motion, t, dt)[:, 2], self.mapping.conservative(f)[:, 2])
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
                ACCELERATION: self.mapping.consistent(_acceleration(motion, t, dt)),
            }
        )
        self._in_fluid(self.fluid.solve, dt)
        return self.fluid.write_data()[FORCE]

    # ------------------------------------------------------------------ one window
    def solve_window(self, solid: Participant, dt: float, window: int) -> dict[str, float]:
        self.fluid_wall_s = 0.0
        if window == 0:
            self.lead_in(solid, dt)
        t_end = solid.time + dt
        iterate = self.settings.iterates(window)
        self.predictor.use_rules(PERIODIC_RULES if iterate else EXPLICIT_RULES)
        x = self._first_iterate(t_end)
        self.criteria.new_window(window, max_iterations=None if iterate else 1)
        solid.store_checkpoint()
        self.fluid.store_checkpoint()
        self.retries = 0
        x_good = None  # the last iterate the solvers accepted
        while True:
            x, x_tilde = self._guarded_iteration(solid, x, x_good, dt, window)
            x_good = x
            status = self.criteria.check({FIELD: x}, {FIELD: x_tilde})
            if self.criteria.iteration == 1:
                predictor_miss, updated_miss = self.measure.value, np.nan
            elif self.criteria.iteration == 2:  # how much the accelerator's first step gained
                updated_miss = self.measure.value
            if status.done:
                break
            assert self.accelerator is not None  # a second iteration: an iterating scheme
            x = self.accelerator.perform({FIELD: x}, {FIELD: x_tilde})[FIELD]
            solid.restore_checkpoint()
            self.fluid.restore_checkpoint()
        if self.accelerator is not None and iterate:
            self.accelerator.iterations_converged({FIELD: x}, {FIELD: x_tilde})
        self.predictor.record(t_end, {FIELD: x_tilde})
        self._check_growth(float(np.linalg.norm(x_tilde)), window)
        self.force_scales = (self.force_scales + [self._force_norm])[-SCALE_MEMORY:]
        return {
            "coupling/fluid_solves": float(self.criteria.iteration + self.retries),
            "coupling/converged": float(status is WindowStatus.CONVERGED),
            "coupling/iterated": float(iterate),
            "coupling/residual": float(self.criteria.residuals.get(FIELD, 0.0)),
            # first residual over the tolerance's reference: how far the predictor missed
            "coupling/predictor_miss": float(predictor_miss),
            # the same after the accelerator's first update (nan: one solve)
            "coupling/updated_miss": float(updated_miss),
            "coupling/fluid_wall_s": self.fluid_wall_s,
        }

    def _guarded_iteration(
        self,
        solid: Participant,
        x: NDArray[np.float64],
        x_good: NDArray[np.float64] | None,
        dt: float,
        window: int,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """One Gauss-Seidel pass, returning (the iterate used, x~). A quasi-Newton step can
        overshoot so far that a solver fails on it (a CFD step at Courant 8): the iterate is then
        pulled halfway back toward the last accepted one, up to MAX_RETRIES times, from the
        window's checkpoints. A solver that still fails is reported as what it almost always
        is here, a diverging coupling."""
        for attempt in range(MAX_RETRIES + 1):
            try:
                return x, self._gauss_seidel(solid, x, dt)
            except (RuntimeError, FloatingPointError) as err:
                if isinstance(err, CouplingDivergenceError | ParticipantSetupError):
                    raise
                if x_good is None or attempt == MAX_RETRIES:
                    raise CouplingDivergenceError(
                        f"a solver failed ({err}) {self._hint()}",
                        field=FIELD,
                        window=window,
                        iteration=self.criteria.iteration + 1,
                    ) from err
                self.retries += 1
                x = x_good + 0.5 * (x - x_good)
                solid.restore_checkpoint()
                self.fluid.restore_checkpoint()
        raise AssertionError("unreachable")

    def _check_growth(self, norm: float, window: int) -> None:
        """Window-to-window divergence (explicit schemes have no iterations to watch): the
        force grew tenfold in each of three consecutive windows."""
        self.norms = (self.norms + [norm])[-4:]
        n = self.norms
        if len(n) == 4 and n[0] > 0 and all(b > 10 * a for a, b in zip(n, n[1:], strict=False)):
            raise CouplingDivergenceError(
                f"the interface force grew from {n[0]:.3g} to {n[-1]:.3g} N over three windows "
                f"{self._hint()}",
                field=FIELD,
                window=window,
                iteration=self.criteria.iteration,
            )

    def _hint(self) -> str:
        return f'(coupling.scheme = "{self.settings.scheme}"). The liquid is far denser than ' + (
            "the plate: a smaller coupling.relaxation or a shorter time step may help."
            if self.settings.uses_added_mass
            else 'the plate: use "iqn-ils-am" or "explicit-am", or a smaller coupling.relaxation.'
        )

    def _first_iterate(self, t_end: float) -> NDArray[np.float64]:
        if not self.predictor.has_history:
            return np.zeros((self.n_solid, 3))
        return self.predictor.predict(t_end)[FIELD]

    def _gauss_seidel(
        self, solid: Participant, x: NDArray[np.float64], dt: float
    ) -> NDArray[np.float64]:
        solid.read_data({FORCE: x})
        solid.solve(dt)
        motion = solid.write_data()
        self.fluid.read_data({k: self.mapping.consistent(v) for k, v in motion.items()})
        self._in_fluid(self.fluid.solve, dt)
        force = self.mapping.conservative(self.fluid.write_data()[FORCE])
        self._force_norm = float(np.linalg.norm(force))
        self.measure.scale = max([self._force_norm, *self.force_scales])
        if self.added_mass_z is not None:
            force[:, 2] += self.added_mass_z @ motion[ACCELERATION][:, 2]
        return force

    # ------------------------------------------------------------------ restart
    def save_state(self) -> dict[str, Any]:
        return {
            "scheme": np.bytes_(str(self.settings.scheme)),
            "force_scales": np.array(self.force_scales),
            "norms": np.array(self.norms),
            "prescribed_wall_s_per_window": self.prescribed_wall_s_per_window or np.nan,
            "lead_in_wall_s": self.lead_in_wall_s,
            "predictor": self.predictor.save_state(),
            "accelerator": (self.accelerator.save_state() if self.accelerator is not None else {}),
            "fluid": self.fluid.save_state(),
        }

    def load_state(self, state: Mapping[str, Any], solid: Participant) -> None:
        """Continue from :meth:`save_state` (``solid`` already restored). A run saved with
        another coupling.scheme goes on with this one: its accelerator starts afresh, and
        between a plain and an *-am scheme (f against g = f + M~ a exchanged) the predictor and
        the structure's load restart from the last window's value in this scheme's variable."""
        saved = state.get("scheme", str(self.settings.scheme).encode())  # older runs: none
        saved = CouplingScheme(saved.decode() if isinstance(saved, bytes) else str(saved))
        self.resumed_from_scheme = None if saved is self.settings.scheme else saved
        self.force_scales = [float(v) for v in np.atleast_1d(state["force_scales"])]
        self.norms = [float(v) for v in np.atleast_1d(state["norms"])]
        prescribed = float(state.get("prescribed_wall_s_per_window", np.nan))  # older runs: none
        self.prescribed_wall_s_per_window = None if np.isnan(prescribed) else prescribed
        self.lead_in_wall_s = float(state.get("lead_in_wall_s", 0.0))
        self.predictor.load_state(state["predictor"])
        self.fluid.load_state(state["fluid"])
        if self.resumed_from_scheme is None:
            if self.accelerator is not None:
                self.accelerator.load_state(state["accelerator"])
        elif saved.uses_added_mass != self.settings.uses_added_mass:
            self._start_from_fluid_force(solid)  # the history holds the other variable


def peak_speed(motion: Motion, times: list[float]) -> float:
    """The largest speed of any interface node along u(t) between consecutive sample times."""
    path = [motion(t) for t in times]
    return max(
        float(np.max(np.abs(b - a))) / (tb - ta)
        for (ta, a), (tb, b) in pairwise(zip(times, path, strict=True))
    )


def _smoothstep(s: float) -> float:
    """C2 ramp from 0 (s <= 0) to 1 (s >= 1)."""
    s = min(1.0, max(0.0, s))
    return s * s * s * (10 - 15 * s + 6 * s * s)


def _periodic_motion(solid: Participant, omega: float) -> Motion:
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


def _acceleration(motion: Motion, t: float, dt: float) -> NDArray[np.float64]:
    h = 1e-4 * dt
    rate: NDArray[np.float64] = (motion(t + h) - 2 * motion(t) + motion(t - h)) / h**2
    return rate
