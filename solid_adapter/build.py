"""Case -> shell model, participant, and the stand-alone analyses (static, modal)."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.schema import GeometryKind, StartMode

from .buckling import check_mean_voltage
from .feedback import PeriodicFeedback, mirror_asymmetry, mirror_signs
from .geometry import build_layout
from .harmonic import (
    ModalCorrection,
    ModalSweep,
    PeriodicResponse,
    harmonic_load,
    linearized_damping_response,
    mean_voltage_tangent,
    mean_volts,
    periodic_response,
)
from .mesh import build_mesh
from .participant import ShellParticipant, StaticLoads
from .piezo import DriveSignal
from .recorded_orbit import OrbitRecorder, RecordedStart
from .shell import NDOF, ShellModel
from .solvers import (
    CombinedDamping,
    NewtonSettings,
    RayleighDamping,
    TimeIntegrator,
    make_integrator,
    modal_analysis,
    mode_kind,
    solve_static,
)


def build_shell_model(case: Case) -> ShellModel:
    layout = build_layout(case)
    mesh = build_mesh(layout, case.mesh.level, case.mesh.elements_length, case.mesh.elements_width)
    return ShellModel(layout, mesh)


def has_actuators(case: Case) -> bool:
    return case.geometry.kind is not GeometryKind.RECTANGLE


def newton_settings(case: Case) -> NewtonSettings:
    a = case.analysis
    return NewtonSettings(a.newton_tolerance, a.max_newton_iterations, a.reuse_tangent)


def static_loads(case: Case, model: ShellModel) -> StaticLoads:
    edge = model.edge_load(model.layout.length_m, case.loads.tip_force_n, case.loads.tip_moment_nm)
    return StaticLoads(edge=edge, pressure_pa=case.loads.pressure_pa)


def static_load_function(model: ShellModel, loads: StaticLoads):
    """(lam, x, tangent) -> (force, its tangent or None): the static loads at load factor lam
    (the pressure follows the deformed plate)."""

    def load(lam: float, x: NDArray, tangent: bool):
        f = lam * loads.edge
        if loads.pressure_pa == 0:
            return f, None
        p = np.full(model.n_nodes, lam * loads.pressure_pa)
        fp, Kp = model.pressure_load(x, p, tangent)
        return f + fp, Kp

    return load


def rayleigh_coefficients(case: Case, model: ShellModel) -> tuple[float, float]:
    """(alpha, beta) of C = alpha M + beta K0: analysis.rayleigh_*, plus, with
    fluid.damping_ratio > 0, the pair giving that ratio at the first two bending modes of the
    (wet) model."""
    a, b = case.analysis.rayleigh_alpha_per_s, case.analysis.rayleigh_beta_s
    zeta = case.fluid.damping_ratio
    if zeta > 0:
        w1, w2 = 2 * np.pi * bending_frequencies(model, 2)
        a += 2 * zeta * w1 * w2 / (w1 + w2)
        b += 2 * zeta / (w1 + w2)
    return a, b


def rayleigh_damping(case: Case, model: ShellModel) -> RayleighDamping | None:
    a, b = rayleigh_coefficients(case, model)
    return RayleighDamping(a, b) if (a or b) else None


def structural_damping(case: Case, model: ShellModel) -> RayleighDamping | None:
    """material.loss_factor in a transient: eta K / omega, exact (zeta = eta / 2) at omega.
    omega is the drive's, or the first (wet) bending mode's when the drive is below it: there
    a square wave's harmonics ring that mode, and the quasi-static part hardly feels damping."""
    eta = case.material.loss_factor
    if not eta:
        return None
    omega = 2 * np.pi * case.actuation.frequency_hz
    first = 2 * np.pi * bending_frequencies(model, 1)[0]
    return RayleighDamping(0.0, eta / max(omega, first))


def build_damping(case: Case, model: ShellModel, feedback: PeriodicFeedback | None = None):
    """Rayleigh damping, the structure's loss factor, the fast fluid's damping the model
    carries and the periodic ``feedback``, or None."""
    parts = [
        d
        for d in (
            rayleigh_damping(case, model),
            structural_damping(case, model),
            model.fluid_damping,
            feedback,
        )
        if d is not None
    ]
    if not parts:
        return None
    return parts[0] if len(parts) == 1 else CombinedDamping(tuple(parts))


def bending_frequencies(model: ShellModel, count: int) -> NDArray:
    """The lowest ``count`` bending-mode frequencies (Hz) of the model with its inertia."""
    result = modal_analysis(model, 3 * count + 3)
    found = [
        f
        for f, s in zip(result.frequencies_hz, result.shapes, strict=True)
        if mode_kind(model, s) == "bending"
    ]
    return np.array(found[:count])


def periodic_feedback(case: Case, model: ShellModel) -> PeriodicFeedback | None:
    """time.periodic_feedback_per_s as the structure's delayed feedback (None: off), with the
    mirrored half-period term where time.periodic_feedback_mirror asks for it."""
    gain = case.time.periodic_feedback_per_s
    if not gain or not has_actuators(case):
        return None
    steps = case.time.steps_per_period
    ramp = round(case.actuation.ramp_periods * steps)
    mirror = None
    if case.time.periodic_feedback_mirror:
        check_mirror_symmetry(case, model)
        mirror = mirror_signs(model)
    return PeriodicFeedback(gain, steps, first_step=ramp, mirror=mirror)


# r(S x, swap V) against S r(x, V): round-off on a symmetric laminate is ~1e-15
MIRROR_TOLERANCE = 1e-8


def check_mirror_symmetry(case: Case, model: ShellModel) -> None:
    """time.periodic_feedback_mirror assumes the structure is its own mirror image with the
    actuators swapped (the drive's antisymmetry the loader checks); say so where it is not."""
    loads = static_loads(case, model)
    asymmetry = mirror_asymmetry(
        model, DriveSignal.from_case(case).volts(0.25 / case.actuation.frequency_hz)
    )
    lateral = (
        np.abs(mirror_signs(model) * loads.edge - loads.edge).max() > 0 or loads.pressure_pa != 0
    )
    if asymmetry > MIRROR_TOLERANCE or lateral:
        what = (
            "lateral loads (loads.*)"
            if lateral
            else f"a laminate or masses {asymmetry:.1e} off their mirror image"
        )
        raise CaseError(
            f"time.periodic_feedback_mirror: the structure is not symmetric about the plate's "
            f"plane ({what}), so its periodic motion is not its own mirror image half a period "
            f"later; set it to false"
        )


def build_integrator(
    case: Case, model: ShellModel, feedback: PeriodicFeedback | None = None
) -> TimeIntegrator:
    a = case.analysis
    return make_integrator(
        a.integrator.value,
        model,
        a.rho_infinity,
        build_damping(case, model, feedback),
        newton_settings(case),
    )


def build_shell_participant(
    case: Case, model: ShellModel | None = None, start: RecordedStart | None = None
) -> ShellParticipant:
    """The shell participant of a dynamic run: at rest, on the fast model's periodic orbit, or
    (``start``, time.start_from) on the orbit an earlier run recorded, from its end state."""
    model = model or build_shell_model(case)
    loads = static_loads(case, model)
    feedback = periodic_feedback(case, model)
    integrator = build_integrator(case, model, feedback)
    if not has_actuators(case):
        return ShellParticipant(model, integrator, lambda t: np.zeros(2), loads)
    drive = DriveSignal.from_case(case)
    check_mean_voltage(model, drive.mean)
    recorder = None
    if case.time.step_s is None:  # a whole number of windows per period
        recorder = OrbitRecorder(case.time.steps_per_period, 1 / case.actuation.frequency_hz)
    orbit: PeriodicResponse | None = None
    x0 = v0 = a0 = None
    if start is not None:
        orbit, x0, v0, a0 = start.orbit, start.x0, start.v0, start.a0
    elif case.time.start is StartMode.PERIODIC and case.actuation.ramp_periods == 0:
        orbit = periodic_orbit(case, model, drive, loads, integrator)
    return ShellParticipant(
        model,
        integrator,
        drive.volts,
        loads,
        x0=x0,
        v0=v0,
        a0=a0,
        orbit=orbit,
        feedback=feedback,
        recorder=recorder,
        exact_start=None if start is None else start.previous,
    )


# Fewest time steps per period of a harmonic that the periodic start holds. A square wave's
# odd harmonics reach the wet modes the time step does not resolve: undamped, the potential
# orbit at 3 Hz had 30 mm of its 15th harmonic (45 Hz, 2.7 steps per period) and a tail
# velocity of 7 m/s at t = 0, which generalized-alpha damps away in a few steps and which
# crashed the CFD lead-in (docs/coupling.md).
MIN_STEPS_PER_HARMONIC = 8


def resolved_harmonics(case: Case) -> int:
    """How many of the drive's harmonics (the odd ones of a square wave) the periodic start
    holds: those with at least MIN_STEPS_PER_HARMONIC steps per period (at least the
    fundamental)."""
    highest = max(1, case.time.steps_per_period // MIN_STEPS_PER_HARMONIC)
    return (highest + 1) // 2


def mean_voltage_equilibrium(
    case: Case, model: ShellModel, drive: DriveSignal, loads: StaticLoads
) -> NDArray:
    """The static state under the drive's mean voltages (and the static loads)."""
    mean = mean_volts(drive)
    check_mean_voltage(model, mean)
    return solve_static(
        model, static_load_function(model, loads), lambda lam: lam * mean, 4, newton_settings(case)
    )


def mean_voltage_modal_sweep(
    case: Case,
    model: ShellModel,
    drive: DriveSignal,
    x_static: NDArray,
    modes: int,
    with_rigid: bool = False,
) -> ModalSweep:
    """The (wet) plate's frequency response by modal superposition about the mean-voltage
    equilibrium x_static, with the case's Rayleigh damping (fsi-sweep --method linear);
    ``with_rigid``: a free plate's rigid modes in the superposition too."""
    return ModalSweep.build(
        model,
        harmonic_load(model, drive, x_static),
        modes,
        rayleigh_coefficients(case, model),
        stiffness=mean_voltage_tangent(model, x_static, drive),
        loss_factor=case.material.loss_factor,
        with_rigid=with_rigid,
    )


def periodic_orbit(
    case: Case,
    model: ShellModel,
    drive: DriveSignal,
    loads: StaticLoads,
    integrator: TimeIntegrator,
    correction: ModalCorrection | None = None,
) -> PeriodicResponse:
    """The linear periodic response about the mean-voltage equilibrium, with an optional
    fluid force the inertia does not hold (see ModalCorrection)."""
    x_static = mean_voltage_equilibrium(case, model, drive, loads)
    damping_model = integrator.damping
    eliminated: dict = {}  # each harmonic's operator, kept while only the drag changes

    def solve(damping):
        return periodic_response(
            model,
            drive,
            x_static,
            damping,
            resolved_harmonics(case),
            correction=correction,
            cache=eliminated,
        )

    if damping_model is None or not damping_model.amplitude_dependent:
        return solve(damping_model.linear(model) if damping_model is not None else None)
    # an amplitude-dependent damping (the fluid's edge drag), linearized about the orbit
    tip = model.mesh.nearest_node(*model.layout.tip_point) * NDOF + 2
    return linearized_damping_response(
        solve, lambda orbit: damping_model.linear(model, orbit), damping_model.linear(model), tip
    )


class CorrectableStart:
    """The structure's side of the start correction (fsi_orchestrator.start_orbit): the
    periodic orbit the shell started on, computed with the fast added mass in its inertia,
    and a restart on that orbit with the fluid's fitted extra inertia and damping."""

    def __init__(
        self, case: Case, model: ShellModel, solid: ShellParticipant, added_mass_z: NDArray
    ) -> None:
        self.case, self.model, self.solid = case, model, solid
        self._added_mass_z = added_mass_z
        # the orbit the shell starts on was computed with this inertia (a start from rest has
        # none: then the orbit it would have had)
        orbit = solid.orbit
        if orbit is None:
            with self._start_inertia():
                orbit = self._orbit(None)
        self._shape_z = self._in_phase_shape(orbit)

    @property
    def shape_z(self) -> NDArray:
        return self._shape_z

    @property
    def added_mass_z(self) -> NDArray:
        return self._added_mass_z

    def restart(self, fit, min_alignment: float) -> float:
        """Restart on the corrected orbit if its shape stays close to the one the fit was
        made along (|cos| >= min_alignment: the fit says nothing about motion off it);
        returns that |cos|."""

        def on_z(values: NDArray) -> NDArray:
            full = np.zeros(self.model.ndof)
            full[2::NDOF] = values
            return full

        correction = ModalCorrection(
            on_z(self._shape_z), on_z(fit.mass_z), on_z(fit.damping_z), fit.amplitude_m
        )
        with self._start_inertia():
            orbit = self._orbit(correction)
            alignment = abs(float(self._in_phase_shape(orbit) @ self._shape_z))
            if alignment >= min_alignment:
                self.solid.restart(orbit)
        return alignment

    def _in_phase_shape(self, orbit: PeriodicResponse) -> NDArray:
        """The in-phase part of the fundamental's z motion, relative to the tail (unit)."""
        fundamental = orbit.harmonics[0][1].reshape(-1, NDOF)[:, 2]
        tip = fundamental[self.solid.tip_node]
        shape = np.real(fundamental * np.conj(tip) / abs(tip))
        return shape / np.linalg.norm(shape)

    def _orbit(self, correction: ModalCorrection | None):
        return periodic_orbit(
            self.case,
            self.model,
            DriveSignal.from_case(self.case),
            static_loads(self.case, self.model),
            self.solid.integrator,
            correction,
        )

    @contextmanager
    def _start_inertia(self):
        """The model as the periodic start saw it: the fast added mass in the inertia."""
        integrator = self.solid.integrator
        saved = (self.model.added_mass, self.model.inertia, integrator.added_mass_as_force)
        self.model.set_added_mass(self._added_mass_z)
        integrator.added_mass_as_force = None
        try:
            yield
        finally:
            self.model.added_mass, self.model.inertia, integrator.added_mass_as_force = saved


@dataclass(frozen=True)
class StaticResult:
    x: NDArray
    tip_displacement_m: NDArray
    history: NDArray  # (steps, 4): lambda, ux, uy, uz at the tip


def run_static(case: Case, model: ShellModel | None = None) -> StaticResult:
    model = model or build_shell_model(case)
    loads = static_loads(case, model)
    static_volts = np.array(case.actuation.static_volts) if has_actuators(case) else np.zeros(2)
    tip = model.mesh.nearest_node(*model.layout.tip_point)
    history = []

    def record(k: int, lam: float, x: NDArray) -> None:
        history.append([lam, *x.reshape(-1, NDOF)[tip, :3]])

    x = solve_static(
        model,
        static_load_function(model, loads),
        lambda lam: lam * static_volts,
        case.analysis.load_steps,
        newton_settings(case),
        record,
    )
    return StaticResult(
        x=x, tip_displacement_m=x.reshape(-1, NDOF)[tip, :3].copy(), history=np.array(history)
    )
