"""The shell as a coupling participant (implements fsi_orchestrator.participant.Participant).

Interface mesh = the mid-surface (all 9-node quad DOF locations). Reads nodal forces ("force",
dead within a window) and/or a net follower pressure ("pressure"); writes displacement and
velocity at the window end. Checkpoints are copies of the integrator state.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fsi_orchestrator.participant import (
    ACCELERATION,
    DISPLACEMENT,
    FORCE,
    PAST_DISPLACEMENT,
    PRESSURE,
    VELOCITY,
    AddedMassPreconditioning,
    InterfaceMesh,
    State,
)

from .feedback import PeriodicFeedback
from .harmonic import PeriodicResponse
from .recorded_orbit import OrbitRecorder, RecordedOrbit
from .shell import NDOF, ShellModel
from .solvers import AddedMassAsForce, DynamicState, TimeIntegrator


@dataclass(frozen=True)
class StaticLoads:
    """Case loads that do not come from the coupling."""

    edge: NDArray  # generalised load vector of the tip force / moment
    pressure_pa: float = 0.0  # uniform follower pressure


class ShellParticipant:
    name = "shell"

    def __init__(
        self,
        model: ShellModel,
        integrator: TimeIntegrator,
        volts,
        loads: StaticLoads,
        t0: float = 0.0,
        x0: NDArray | None = None,
        v0: NDArray | None = None,
        a0: NDArray | None = None,
        orbit: PeriodicResponse | None = None,
        feedback: PeriodicFeedback | None = None,
        recorder: OrbitRecorder | None = None,
        exact_start: tuple[NDArray, float] | None = None,
    ) -> None:
        """Starts at rest, from (x0, v0, a0), or on a periodic ``orbit`` at t0 (its state there
        unless (x0, v0, a0) is given too: a recorded orbit's exact end state). ``feedback``:
        the integrator's delayed feedback toward the periodic state, fed here. ``recorder``
        keeps the last period's states for the checkpoint (time.start_from);
        ``exact_start``: (x0, v0, a0) is a state the integrator reached (another run's end), taken
        as it is; the pair is that run's displacements one step before and the step's length."""
        self.model = model
        self.volts = volts
        self.loads = loads
        self.integrator = integrator
        self._force = np.zeros((model.n_nodes, 3))
        self._pressure = np.zeros(model.n_nodes)
        self.tip_node = model.mesh.nearest_node(*model.layout.tip_point)
        on_axis = np.flatnonzero(np.abs(model.mesh.nodes[:, 1]) < 1e-12 * model.layout.length_m)
        self.midline_nodes = on_axis[np.argsort(model.mesh.nodes[on_axis, 0])]
        self.orbit = orbit
        self.feedback = feedback
        self._seed_feedback(t0)
        self.recorder = recorder
        if orbit is not None and (x0 is None or v0 is None or a0 is None):
            if x0 is not None or v0 is not None or a0 is not None:
                raise ValueError("give the whole start state (x0, v0, a0) with an orbit, or none")
            x0, v0, a0 = orbit.at(t0)
        self.state = self.integrator.initial_state(
            t0,
            self.external_load,
            volts,
            x0,
            v0,
            a0,
            relax=exact_start is None,
            previous=exact_start,
        )
        self._checkpoint: tuple[DynamicState, NDArray, NDArray] | None = None
        # this window's last solution (a private copy): Newton's start when the window is solved
        # again after restore_checkpoint (2.5 Newton iterations instead of 4); without a restore
        # it equals the state, i.e. the usual start
        self._answer: NDArray | None = None

    def restart(self, orbit: PeriodicResponse) -> None:
        """Start again at the initial time on another periodic orbit (a corrected one)."""
        self.orbit = orbit
        self._seed_feedback(self.state.t)
        self.state = self.integrator.initial_state(
            self.state.t, self.external_load, self.volts, *orbit.at(self.state.t)
        )
        self._checkpoint, self._answer = None, None

    def _seed_feedback(self, t0: float) -> None:
        """The feedback's period before t0 from the start orbit (none from rest)."""
        feedback, orbit = self.feedback, self.orbit
        if feedback is None:
            return
        feedback.forget()
        if isinstance(orbit, RecordedOrbit) and len(orbit.step_velocities) == (
            feedback.steps_per_period
        ):  # the velocities the source run fed back on
            dt = 2 * np.pi / orbit.omega / feedback.steps_per_period
            feedback.seed(orbit.velocity_at_step, first=round(t0 / dt))
        elif orbit is not None:
            dt = 2 * np.pi / orbit.omega / feedback.steps_per_period
            feedback.seed(lambda k: orbit.at(k * dt)[1], first=round(t0 / dt))

    def take_added_mass(self, preconditioning: AddedMassPreconditioning | None) -> None:
        """Carry the *-am schemes' preconditioning added mass: in the inertia, and taken by the
        integrator as part of the exchanged force (solvers.AddedMassAsForce); None: neither."""
        if preconditioning is None:
            self.model.set_added_mass(None)
            self.integrator.added_mass_as_force = None
            return
        self.model.set_added_mass(preconditioning.added_mass_z)
        self.integrator.added_mass_as_force = AddedMassAsForce(preconditioning.stencil)

    def orbit_motion(self) -> Callable[[float], NDArray] | None:
        """t -> the nodes' translations (n, 3) on the periodic orbit the structure starts on
        now, at any time t (a fluid lead-in before t = 0 follows it); None without one. It
        keeps that orbit: a later restart on another one does not change it."""
        orbit, n = self.orbit, self.model.n_nodes
        if orbit is None:
            return None
        return lambda t: orbit.at(t)[0].reshape(n, NDOF)[:, :3].copy()

    def initialize_data(self, data: Mapping[str, NDArray]) -> None:
        """Values at the initial time, before the first window. ``force``: the coupled load,
        which becomes the state's external force (the first step's balance weights it with
        alpha_f). ``past_displacement``: the interface displacements the fluid was moved
        through before (a lead-in), the history a fluid-consistent added-mass stencil
        differentiates; ``acceleration``: the acceleration the fluid saw at t = 0."""
        s = self.state
        if FORCE in data or PRESSURE in data:
            self.read_data(data)
            s = replace(s, f_ext=self.external_load(s.t, s.x, False)[0])
        if PAST_DISPLACEMENT in data:
            s = replace(s, past=tuple(self._with_translations(u) for u in data[PAST_DISPLACEMENT]))
        if ACCELERATION in data:
            a = s.a.copy().reshape(self.model.n_nodes, NDOF)
            a[:, :3] = np.asarray(data[ACCELERATION], dtype=float)
            s = replace(s, a_fluid=a.ravel())
        self.state = s
        self._checkpoint, self._answer = None, None

    def _with_translations(self, u: NDArray) -> NDArray:
        """The state's DOF vector with the nodes' translations replaced by u (n, 3)."""
        x = self.state.x.copy().reshape(self.model.n_nodes, NDOF)
        x[:, :3] = np.asarray(u, dtype=float)
        return x.ravel()

    # --------------------------------------------------------------- loads
    def external_load(
        self, t: float, x: NDArray, tangent: bool
    ) -> tuple[NDArray, sp.spmatrix | None]:
        f = self.loads.edge + self.model.nodal_force_load(self._force)
        p = self._pressure + self.loads.pressure_pa
        if not np.any(p):
            return f, None
        fp, Kp = self.model.pressure_load(
            x, np.broadcast_to(p, (self.model.n_nodes,)).copy(), tangent
        )
        return f + fp, Kp

    # --------------------------------------------------------------- Participant protocol
    @property
    def time(self) -> float:
        return self.state.t

    def interface(self) -> InterfaceMesh:
        return InterfaceMesh(
            points=self.model.reference_points.copy(),
            cells=self.model.mesh.element_nodes.copy(),
            cell_type="quad9",
        )

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        if FORCE in data:
            self._force = np.asarray(data[FORCE], dtype=float).reshape(self.model.n_nodes, 3)
        if PRESSURE in data:
            self._pressure = np.asarray(data[PRESSURE], dtype=float).reshape(self.model.n_nodes)

    def solve(self, dt: float) -> None:
        if self.recorder is not None:
            self.recorder.record(self.state.t, self.state.x, self.state.v)
        if self.feedback is not None:
            self.feedback.prepare(round(self.state.t / dt), self.state.v)
        self.state = self.integrator.step(
            self.state, dt, self.external_load, self.volts, guess=self._answer
        )
        self._answer = self.state.x.copy()

    def write_data(self) -> dict[str, NDArray]:
        n = self.model.n_nodes
        return {
            DISPLACEMENT: self.state.x.reshape(n, NDOF)[:, :3].copy(),
            VELOCITY: self.state.v.reshape(n, NDOF)[:, :3].copy(),
            # as the fluid differentiates the displacement, where the added mass says so
            ACCELERATION: self.state.added_mass_acceleration.reshape(n, NDOF)[:, :3].copy(),
        }

    def monitor(self) -> dict[str, NDArray | float]:
        """Quantities recorded every window: tail-tip (free-edge mid-point) displacement, the
        midline's z displacement (nodes at y = 0, nose to tail) and the Newton count."""
        X = self.state.x.reshape(-1, NDOF)
        return {
            "tip_displacement_m": X[self.tip_node, :3].copy(),
            "midline_z_m": X[self.midline_nodes, 2].copy(),
            "newton_iterations": float(self.integrator.newton_iterations),
        }

    @property
    def midline_x_m(self) -> NDArray:
        return self.model.mesh.nodes[self.midline_nodes, 0].copy()

    def store_checkpoint(self) -> None:
        self._checkpoint = (self.state.copy(), self._force.copy(), self._pressure.copy())
        self._answer = None

    def restore_checkpoint(self) -> None:
        assert self._checkpoint is not None, "restore_checkpoint before store_checkpoint"
        state, force, pressure = self._checkpoint
        self.state, self._force, self._pressure = state.copy(), force.copy(), pressure.copy()

    def save_state(self) -> dict[str, NDArray | float | int]:
        self.integrator.kept_tangent.forget()  # the resumed run starts without it too
        s = self.state
        feedback: dict[str, NDArray] = {}
        if self.feedback is not None:
            steps, velocities = self.feedback.history()
            feedback = {
                "feedback_steps": steps,
                "feedback_velocities": velocities.reshape(len(steps), self.model.ndof),
            }
        recorded: dict[str, NDArray | float] = {}
        if self.recorder is not None:
            self.recorder.record(s.t, s.x, s.v)
            recorded = self.recorder.state()
        return {
            **feedback,
            **recorded,
            "t": s.t,
            "x": s.x.copy(),
            "v": s.v.copy(),
            "a": s.a.copy(),
            "f_int": s.f_int.copy(),
            "f_ext": s.f_ext.copy(),
            "f_damp": s.f_damp.copy(),
            "past": np.array(s.past).reshape(len(s.past), self.model.ndof),
            "a_fluid": s.added_mass_acceleration.copy(),
            "has_a_fluid": int(s.a_fluid is not None),
            "force": self._force.copy(),
            "pressure": self._pressure.copy(),
            "newton_iterations": self.integrator.newton_iterations,
        }

    def load_state(self, state: State) -> None:
        past = np.array(state.get("past", np.zeros((0, self.model.ndof))), dtype=float)
        x, v, a, f_int, f_ext, f_damp = (
            np.array(state[k], dtype=float) for k in ("x", "v", "a", "f_int", "f_ext", "f_damp")
        )
        self.state = DynamicState(
            float(state["t"]),
            x,
            v,
            a,
            f_int,
            f_ext,
            f_damp,
            past=tuple(past),
            a_fluid=np.array(state["a_fluid"], dtype=float)
            if int(state.get("has_a_fluid", 0))
            else None,
        )
        self._force = np.array(state["force"], dtype=float)
        self._pressure = np.array(state["pressure"], dtype=float)
        self.integrator.newton_iterations = int(state["newton_iterations"])
        self.integrator.kept_tangent.forget()
        self._answer = None
        if self.feedback is not None:
            steps = np.asarray(state.get("feedback_steps", np.zeros(0)), dtype=np.int64)
            velocities = np.asarray(state.get("feedback_velocities", np.zeros((0, 0))))
            self.feedback.restore(steps, velocities)  # none recorded: it records a period again
        if self.recorder is not None:
            self.recorder.restore(state)

    def finalize(self) -> None:
        pass
