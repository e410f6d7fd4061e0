"""The fast model of a case: the wet shell with a fast fluid's added mass (potential flow in
the tank for an OpenFOAM case, which the linear studies do not run), the edge drag and
inertia fitted to OpenFOAM, and its linear periodic response about the mean-voltage
equilibrium (modal superposition with static correction). fsi-modal, the linear sweep, the
swimming figures, the design studies and a coupled run's start orbit all build on it.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import (
    AnalysisKind,
    FluidDomain,
    FluidModel,
    SectionAddedMass,
    Waveform,
)

if TYPE_CHECKING:
    from fluid_adapter.swimming import SpeedLoads
    from solid_adapter.harmonic import ModalSweep, PeriodicResponse
    from solid_adapter.shell import ShellModel

MODES = 40  # wet modes in the superposition (with static correction), up to ~300 Hz


class SweepError(RuntimeError):
    """A sweep that cannot go on: a launch whose MPI world does not match its tasks, a linear
    step without a finite answer (one line, non-zero exit)."""


def without_cfd(case: Case) -> Case:
    """A study that needs no CFD (modes, the linear frequency sweep): an OpenFOAM case is
    analysed with the potential model in its tank."""
    if case.fluid.model is not FluidModel.OPENFOAM:
        return case
    fluid = dataclasses.replace(case.fluid, model=FluidModel.POTENTIAL, domain=FluidDomain.TANK)
    return dataclasses.replace(case, fluid=fluid)


def shell_with_fast_fluid(case: Case, edge_inertia: bool = False):
    """The shell model, with the fast fluid's added mass in its inertia when the case has one.
    ``edge_inertia``: add the edge inertia (fluid.edge_inertia) at the amplitude of the
    case's periodic orbit, as a transient carries it. Returns (model, added_mass or None)."""
    from fluid_adapter.fast import fast_added_mass
    from solid_adapter.build import build_shell_model

    model = build_shell_model(case)
    added = fast_added_mass(case, model)
    if added is not None:
        model.set_added_mass(added.matrix)
        if case.fluid.edge_drag:
            from fluid_adapter.drag import edge_drag

            model.fluid_damping = edge_drag(
                model,
                case.fluid.density_kg_m3,
                case.actuation.frequency_hz,
                frequency_exponent=case.fluid.edge_drag_frequency_exponent,
            )
            if edge_inertia and carries_edge_inertia(case):
                model.set_added_mass(added.matrix + np.diag(orbit_edge_inertia(case, model)))
    return model, added


def orbit_edge_inertia(case: Case, model) -> NDArray:
    """The edge inertia's nodal masses (kg, on z) at the amplitude of the linear sweep's
    periodic response to the case's drive: a transient holds them constant, as the linear
    sweep holds them at its orbit. Where the linear response has no answer, none (a note)."""
    from fluid_adapter.drag import NDOF

    waveform = case.actuation.waveform
    try:
        orbit = linear_model(case, model).response(case.actuation.frequency_hz, waveform)
    except SweepError as err:
        print(f"note: no edge inertia ({err})", file=sys.stderr)
        return np.zeros(model.n_nodes)
    law = case_edge_inertia(case, model)
    assert law is not None  # shell_with_fast_fluid asks only where it applies
    return law.linear(model, orbit).diagonal()[2::NDOF]


@dataclass(frozen=True)
class LinearModel:
    """What every frequency's response shares: the wet shell, its mean-voltage equilibrium and
    the modal basis about it."""

    case: Case
    model: ShellModel  # with the fast fluid's added mass
    x_static: NDArray
    sweep: ModalSweep
    tip: int  # the tail tip's node
    speed_loads: SpeedLoads | None = None  # the fluid's load at forward speed, on sweep's modes
    drive_load: NDArray | None = None  # the load of a unit oscillation of the drive (N)
    divergence_speed_m_s: float = float("inf")  # past it the motion at speed means nothing
    # gamma of the swimming model's A = rho pi b^2 gamma (swimming.section_added_mass)
    section_added_mass_coefficient: float = 1.0

    def drive_power(self, response: PeriodicResponse, waveform: Waveform) -> float:
        """The mean mechanical power (W) the actuators put into the plate over a period of
        ``response``: what the liquid and the laminate's loss take out of the periodic motion
        (for the seed's energy per distance, eq. 5-13)."""
        from solid_adapter.harmonic import harmonic_amplitudes
        from solid_adapter.piezo import DriveSignal

        if self.drive_load is None:
            return float("nan")
        drive = DriveSignal.from_case(with_drive(self.case, 1.0, waveform))
        amplitude = dict(harmonic_amplitudes(drive, len(response.harmonics)))
        return sum(
            0.5
            * float(np.real(np.vdot(1j * k * response.omega * X, amplitude[k] * self.drive_load)))
            for k, X in response.harmonics
        )

    def response(
        self, frequency_hz: float, waveform: Waveform, speed_m_s: float = 0.0
    ) -> PeriodicResponse:
        """The periodic response to the case's drive at ``frequency_hz`` and ``waveform``; the
        edge drag's damping at that frequency; at ``speed_m_s`` where speed_loads are set."""
        from fluid_adapter.drag import edge_drag
        from solid_adapter.harmonic import damped_sweep_response, sweep_response
        from solid_adapter.piezo import DriveSignal

        case, model = self.case, self.model
        drive = DriveSignal.from_case(with_drive(case, frequency_hz, waveform))
        extra_damping = extra_stiffness = None
        if self.speed_loads is not None and speed_m_s > 0:
            extra_damping = self.speed_loads.damping(speed_m_s)
            extra_stiffness = self.speed_loads.stiffness(speed_m_s)
        if case.fluid.edge_drag:
            drag = edge_drag(
                model,
                case.fluid.density_kg_m3,
                frequency_hz,
                frequency_exponent=case.fluid.edge_drag_frequency_exponent,
            )
            return damped_sweep_response(
                self.sweep,
                drive,
                self.x_static,
                drag,
                model,
                self.tip * 5 + 2,
                case_edge_inertia(case, model),
                extra_damping=extra_damping,
                extra_stiffness=extra_stiffness,
            )
        return sweep_response(
            self.sweep,
            drive,
            self.x_static,
            modal_damping=extra_damping,
            modal_stiffness=extra_stiffness,
        )


def carries_edge_inertia(case: Case) -> bool:
    """The edge inertia (fluid.edge_inertia) is fitted in still liquid; a swimming body's
    edge vortices are swept off by its speed, and the swimming model leaves it out, as it
    leaves out the thrust's shedding efficiency (docs/swimming.md)."""
    return (
        case.fluid.edge_drag
        and case.fluid.edge_inertia
        and case.analysis.kind is not AnalysisKind.SWIMMING
    )


def case_edge_inertia(case: Case, model):
    """The case's edge-inertia law on ``model``'s nodes, or None where it does not apply."""
    from fluid_adapter.drag import edge_inertia

    if not carries_edge_inertia(case):
        return None
    return edge_inertia(model, case.fluid.density_kg_m3, case.fluid.edge_inertia_gamma)


def linear_model(case: Case, model: ShellModel | None = None) -> LinearModel:
    """The shell with the fast fluid about the mean voltages' equilibrium; a step without a
    finite answer (a singular or indefinite tangent) raises SweepError naming the step.
    ``model``: the case's shell with its fast fluid, when already built."""
    from solid_adapter.build import (
        mean_voltage_equilibrium,
        mean_voltage_modal_sweep,
        static_loads,
    )
    from solid_adapter.harmonic import harmonic_load
    from solid_adapter.piezo import DriveSignal

    case = without_cfd(case)
    if model is None:
        model, _ = shell_with_fast_fluid(case)
    drive0 = DriveSignal.from_case(case)
    x_static = mean_voltage_equilibrium(case, model, drive0, static_loads(case, model))
    if not np.all(np.isfinite(x_static)):
        raise SweepError(
            "linear sweep, static step: the equilibrium under the mean voltages is not finite"
        )
    coupled = speed_coupled(case)
    with np.errstate(divide="ignore", invalid="ignore"):  # checked below, in one line
        sweep = mean_voltage_modal_sweep(case, model, drive0, x_static, MODES, with_rigid=coupled)
    check_modal_sweep(sweep)
    tip = model.mesh.nearest_node(*model.layout.tip_point)
    loads, diverges = None, float("inf")
    gamma = section_added_mass_coefficient(case, model, sweep)
    if coupled:  # at speed the fluid's load moves the free body's sway and yaw too
        from fluid_adapter.swimming import divergence_speed, speed_loads
        from solid_adapter.shell import NDOF

        midline = midline_nodes(model)
        xs = model.mesh.nodes[midline, 0]
        loads = speed_loads(
            xs,
            model.layout.height(xs) / 2,
            sweep.shapes[:, midline * NDOF + 2],
            density_kg_m3=case.fluid.density_kg_m3,
            added_mass_coefficient=gamma,
        )
        diverges = divergence_speed(loads, sweep.omegas, sweep.rigid)
    return LinearModel(
        case=case,
        model=model,
        x_static=x_static,
        sweep=sweep,
        tip=tip,
        speed_loads=loads,
        drive_load=harmonic_load(model, drive0, x_static),
        divergence_speed_m_s=diverges,
        section_added_mass_coefficient=gamma,
    )


def section_added_mass_coefficient(case: Case, model, sweep) -> float:
    """gamma of the swimming model's added mass per length A = rho pi b^2 gamma: the case's
    fluid.added_mass_coefficient, or (swimming.section_added_mass = "matched") the ratio of
    the fluid model's added mass to the strip theory's on the first wet bending mode. The
    strip theory holds where the bending wave is long against the plate's height; the
    robots' are about as long, and the 3D flow carries 0.25-0.42 of the strip's."""
    from fluid_adapter.strip import strip_added_mass
    from solid_adapter.shell import NDOF
    from solid_adapter.solvers import mode_kind

    gamma = case.fluid.added_mass_coefficient
    if (
        case.analysis.kind is not AnalysisKind.SWIMMING
        or case.swimming.section_added_mass is SectionAddedMass.STRIP
        or model.added_mass is None
    ):
        return gamma
    strip = strip_added_mass(model, case.fluid.density_kg_m3).matrix
    midline = midline_nodes(model)
    xs = model.mesh.nodes[midline, 0]
    for j in range(sweep.rigid, len(sweep.omegas)):
        shape = sweep.shapes[j]
        if mode_kind(model, shape) != "bending":
            continue
        w = shape[midline * NDOF + 2]
        straight = np.polyval(np.polyfit(xs, w, 1), xs)
        if np.linalg.norm(w - straight) < 0.2 * np.linalg.norm(w):
            continue  # a head on springs: sway and yaw of a body that hardly bends
        z = shape[2::NDOF]
        return float(shape @ (model.added_mass @ shape)) / float(z @ strip @ z)
    return gamma


def speed_coupled(case: Case) -> bool:
    """Whether a case's motion is the one at its swimming speed (swimming.speed_coupling)."""
    return case.analysis.kind is AnalysisKind.SWIMMING and case.swimming.speed_coupling


def midline_nodes(model) -> NDArray:
    """The nodes on the plate's axis y = 0, nose to tail."""
    nodes = model.mesh.nodes
    on_axis = np.flatnonzero(np.abs(nodes[:, 1]) < 1e-12 * model.layout.length_m)
    return on_axis[np.argsort(nodes[on_axis, 0])]


def with_drive(case: Case, frequency_hz: float, waveform: Waveform) -> Case:
    actuation = dataclasses.replace(case.actuation, frequency_hz=frequency_hz, waveform=waveform)
    return dataclasses.replace(case, actuation=actuation)


def check_modal_sweep(sweep) -> None:
    """The modal superposition needs every wet mode at a positive, finite frequency and a
    finite static correction: a singular or indefinite tangent (a mechanism, or a plate
    buckled by the mean voltages) has none. The rigid modes it holds are at 0 by design."""
    omegas = np.asarray(sweep.omegas)[sweep.rigid :]
    bad = np.flatnonzero(~(np.isfinite(omegas) & (omegas > 0)))
    if bad.size:
        j = int(bad[0])
        raise SweepError(
            f"linear sweep, modal step: the tangent about the mean-voltage equilibrium is "
            f"singular or indefinite (wet mode {j + 1} at {omegas[j] / (2 * np.pi):.3g} Hz: a "
            "mechanism, or a plate buckled by the mean voltages), so the linear response has "
            "no finite answer; check the case with fsi-modal, or use --method transient"
        )
    if not (np.all(np.isfinite(sweep.static)) and np.all(np.isfinite(sweep.zetas))):
        raise SweepError(
            "linear sweep, static-correction step: K^-1 F about the mean-voltage equilibrium "
            "is not finite (a singular tangent); check the case with fsi-modal"
        )
