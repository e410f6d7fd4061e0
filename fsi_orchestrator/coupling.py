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

Here: the iteration of a window and the hand-over of the exchanged variable; the start-up (a
fluid-only lead-in and its modal fit) is fsi_orchestrator.lead_in, the failure handling (retries,
divergence) fsi_orchestrator.coupling_failure.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .acceleration import Acceleration
from .case.schema import CouplingScheme
from .convergence import ConvergenceCriteria, ScaledRelativeMeasure, WindowStatus
from .coupling_failure import FailureHandling
from .coupling_settings import CouplingSettings as CouplingSettings  # re-exported
from .lead_in import (
    FluidClock,
    LeadIn,
    Motion,
    bridge_start_up,
    motion_acceleration,
)
from .mapping import InterfaceMapping
from .participant import (
    ACCELERATION,
    FORCE,
    PAST_DISPLACEMENT,
    HasAccelerationStencil,
    InitializesData,
    Participant,
    StartsDisplaced,
)
from .predictors import EXPLICIT_RULES, PERIODIC_RULES, Predictor
from .start_orbit import ModalFit, StartOrbit

FIELD = "force"
Iterate = NDArray[np.float64]
SCALE_MEMORY = 20  # windows over which the fluid force's size is remembered
PAST_WINDOWS = 4  # lead-in displacements handed on (a BDF2-of-BDF2 stencil needs 3)


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
        self.failures = FailureHandling(settings.scheme, FIELD)
        # the tolerance refers to the fluid force's size over the last windows: its norm passes
        # through zero twice a period, where a purely instantaneous reference would be harsh
        self.force_scales: list[float] = []  # the fluid force's norm at past window ends
        self._force_norm = 0.0  # ... and at the last iteration
        self.clock = FluidClock()  # inside the fluid's solve / follow in the current window
        self.start_up = LeadIn(
            fluid,
            self.mapping,
            self.clock,
            settings.lead_in_windows,
            settings.lead_in_omega,
            start_orbit,
            periods=settings.lead_in_periods,
            displaced=settings.lead_in_displaced,
        )
        self.resumed_from_scheme: CouplingScheme | None = None  # a resumed run's former scheme
        # the window from which every window is iterated, set during the run (a run whose
        # explicit windows became periodic, coupling.explicit_until_periodic); None: the
        # scheme's rule alone
        self.iterate_from: int | None = None

    @property
    def fluid_wall_s(self) -> float:
        return self.clock.wall_s

    @property
    def start_orbit(self) -> StartOrbit | None:
        return self.start_up.start_orbit

    @property
    def start_fit(self) -> ModalFit | None:
        return self.start_up.start_fit

    @property
    def prescribed_wall_s_per_window(self) -> float | None:
        return self.start_up.prescribed_wall_s_per_window

    @property
    def lead_in_wall_s(self) -> float:
        return self.start_up.wall_s

    # ------------------------------------------------------------------ start-up
    def lead_in(self, solid: Participant, dt: float) -> None:
        """Fluid-only lead-in before window 0 (fsi_orchestrator.lead_in); the motion it ends
        on hands the initial data over."""
        self.start_up.run(solid, dt, lambda motion: self._initialize_data(solid, motion, dt))

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
        self._seed_predictor(self._start_from_fluid_force(solid), motion, dt)

    def _start_from_fluid_force(self, solid: Participant) -> NDArray[np.float64]:
        """The fluid's last force in this scheme's exchanged variable (f, or g = f + M~ a with
        the structure's present acceleration for an *-am scheme) becomes the structure's load
        and the predictor's only value; returned."""
        x = self.mapping.conservative(self.fluid.write_data()[FORCE])
        if self.added_mass_z is not None:
            x[:, 2] += self.added_mass_z @ solid.write_data()[ACCELERATION][:, 2]
        if isinstance(solid, InitializesData):
            solid.initialize_data({FORCE: x})
        self.predictor.restart(solid.time, {FIELD: x})
        return x

    def _seed_predictor(self, x0: NDArray[np.float64], motion: Motion, dt: float) -> None:
        """A lead-in that ended on whole periods of the structure's orbit (a recorded start)
        gives the predictor the period before t = 0 in the exchanged variable (x0 at t = 0),
        so that window 0 already predicts one period back instead of holding the last force:
        an explicit scheme's forcing then does not change its rule a period into the run,
        which rang the coupled first mode (6 % in tail amplitude, coarse 3 Hz)."""
        ends = self.start_up.last_period[:-1]  # the last one is t = 0's: x0
        if not ends:
            return
        stencil = (
            self.fluid.acceleration_stencil
            if isinstance(self.fluid, HasAccelerationStencil)
            else None
        )

        def exchanged(t: float, force: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
            x = force.copy()
            if self.added_mass_z is None:
                return {FIELD: x}
            if stencil is None:  # the structure's own acceleration: the motion's
                a = motion_acceleration(motion, t, dt)
            else:  # as the fluid differentiates u (the structure's a_fluid at t = 0)
                levels = [motion(t - k * dt) for k in range(len(stencil))]
                a = np.sum([c * u for c, u in zip(stencil, levels, strict=True)], axis=0) / dt**2
            x[:, 2] += self.added_mass_z @ a[:, 2]
            return {FIELD: x}

        seed = [(t, exchanged(t, force)) for t, force in ends]
        if isinstance(self.fluid, StartsDisplaced) and self.start_up.displaced:
            # its start-up, and accelerations across t = -T
            reach = len(stencil) - 1 if stencil is not None else 1
            seed = bridge_start_up(seed, max(self.fluid.start_up_windows, reach))
        self.predictor.restart(*seed[0])
        for t, values in seed[1:]:
            self.predictor.record(t, values)
        self.predictor.record(0.0, {FIELD: x0})

    # ------------------------------------------------------------------ one window
    def solve_window(self, solid: Participant, dt: float, window: int) -> dict[str, float]:
        self.clock.wall_s = 0.0
        if window == 0:
            self.lead_in(solid, dt)
        t_end = solid.time + dt
        iterate = self.iterates(window)
        self.predictor.use_rules(PERIODIC_RULES if iterate else EXPLICIT_RULES)
        x = self._first_iterate(t_end)
        self.criteria.new_window(window, max_iterations=None if iterate else 1)
        solid.store_checkpoint()
        self.fluid.store_checkpoint()
        status, x, x_tilde, misses = self._iterate(solid, x, dt, window)
        if self.accelerator is not None and iterate:
            self.accelerator.iterations_converged({FIELD: x}, {FIELD: x_tilde})
        self.predictor.record(t_end, {FIELD: x_tilde})
        self.failures.check_growth(x_tilde, window, self.criteria.iteration, iterated=iterate)
        self.force_scales = (self.force_scales + [self._force_norm])[-SCALE_MEMORY:]
        return self._report(status, iterate, misses)

    def iterates(self, window: int) -> bool:
        """Whether window ``window`` (0-based) is iterated: the scheme's rule, or from
        ``iterate_from`` on (set once a run's explicit windows are periodic)."""
        switched = self.iterate_from is not None and window >= self.iterate_from
        return switched or self.settings.iterates(window)

    def _iterate(
        self, solid: Participant, x: Iterate, dt: float, window: int
    ) -> tuple[WindowStatus, Iterate, Iterate, tuple[float, float]]:
        """The window's Gauss-Seidel passes until the criteria hold, the accelerator proposing
        each next iterate: (status, x, x~, how far the predictor and the accelerator's first
        update missed)."""
        self.failures.retries = 0
        x_good = None  # the last iterate the solvers accepted
        while True:
            x, x_tilde = self.failures.guarded(
                lambda x: self._gauss_seidel(solid, x, dt),
                x,
                x_good,
                lambda: self._restore(solid),
                (window, self.criteria.iteration + 1),
            )
            x_good = x
            status = self.criteria.check({FIELD: x}, {FIELD: x_tilde})
            if self.criteria.iteration == 1:
                predictor_miss, updated_miss = self.measure.value, np.nan
            elif self.criteria.iteration == 2:  # how much the accelerator's first step gained
                updated_miss = self.measure.value
            if status.done:
                return status, x, x_tilde, (predictor_miss, updated_miss)
            assert self.accelerator is not None  # a second iteration: an iterating scheme
            x = self.accelerator.perform({FIELD: x}, {FIELD: x_tilde})[FIELD]
            self._restore(solid)

    def _restore(self, solid: Participant) -> None:
        solid.restore_checkpoint()
        self.fluid.restore_checkpoint()

    def _report(
        self, status: WindowStatus, iterate: bool, misses: tuple[float, float]
    ) -> dict[str, float]:
        return {
            "coupling/fluid_solves": float(self.criteria.iteration + self.failures.retries),
            "coupling/converged": float(status is WindowStatus.CONVERGED),
            "coupling/iterated": float(iterate),
            "coupling/residual": float(self.criteria.residuals.get(FIELD, 0.0)),
            # first residual over the tolerance's reference: how far the predictor missed
            "coupling/predictor_miss": float(misses[0]),
            # the same after the accelerator's first update (nan: one solve)
            "coupling/updated_miss": float(misses[1]),
            "coupling/fluid_wall_s": self.clock.wall_s,
        }

    def _first_iterate(self, t_end: float) -> Iterate:
        if not self.predictor.has_history:
            return np.zeros((self.n_solid, 3))
        return self.predictor.predict(t_end)[FIELD]

    def _gauss_seidel(self, solid: Participant, x: Iterate, dt: float) -> Iterate:
        solid.read_data({FORCE: x})
        solid.solve(dt)
        motion = solid.write_data()
        self.fluid.read_data({k: self.mapping.consistent(v) for k, v in motion.items()})
        self.clock.run(self.fluid.solve, dt)
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
            "iterate_from": -1 if self.iterate_from is None else self.iterate_from,
            "force_scales": np.array(self.force_scales),
            "norms": np.array(self.failures.norms),
            "turns": np.array(self.failures.turns),
            "last_force": (
                np.array(self.failures.last) if self.failures.last is not None else np.zeros(0)
            ),
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
        # a switch to iterated windows holds where the scheme can iterate (a resume under
        # explicit-am goes on with one solve per window); older runs: none
        switched = int(state.get("iterate_from", -1))
        self.iterate_from = switched if switched >= 0 and self.settings.implicit else None
        self.force_scales = [float(v) for v in np.atleast_1d(state["force_scales"])]
        self.failures.norms = [float(v) for v in np.atleast_1d(state["norms"])]
        self.failures.turns = [float(v) for v in np.atleast_1d(state.get("turns", []))]
        last = np.array(state.get("last_force", np.zeros(0)), dtype=float)  # older runs: none
        self.failures.last = last if last.size else None
        prescribed = float(state.get("prescribed_wall_s_per_window", np.nan))  # older runs: none
        self.start_up.prescribed_wall_s_per_window = None if np.isnan(prescribed) else prescribed
        self.start_up.wall_s = float(state.get("lead_in_wall_s", 0.0))
        self.predictor.load_state(state["predictor"])
        self.fluid.load_state(state["fluid"])
        if self.resumed_from_scheme is None:
            if self.accelerator is not None:
                self.accelerator.load_state(state["accelerator"])
        elif saved.uses_added_mass != self.settings.uses_added_mass:
            self._start_from_fluid_force(solid)  # the history holds the other variable
