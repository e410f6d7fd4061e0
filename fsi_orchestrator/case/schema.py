"""The case file schema: one frozen dataclass per ``case.toml`` section.

SI units everywhere; each key's unit is in its name. ``None`` means "take the value from the
geometry preset or the documented default". ``docs/case_format.md`` is generated from this file
(``python -m fsi_orchestrator.case.docgen``) and a test keeps the two in step.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from enum import StrEnum
from pathlib import Path

from .params import ParamSpec, param, spec_of

MFC_VOLTAGE_RANGE_V = (-500.0, 1500.0)  # Table 3.1 / Sec. 3.1.2: safe drive range of the M8528-P1


class GeometryKind(StrEnum):
    FISH = "fish"
    RECTANGLE = "rectangle"
    BEAM = "beam"


class Preset(StrEnum):
    ORIGINAL = "original"  # Tables 3.4, 4.1
    SERIAL = "serial"  # Table 5.2
    INTEGRATIVE = "integrative"  # Table 5.6


class ActuatorSides(StrEnum):
    BOTH = "both"  # bimorph: one MFC on each face (the fish)
    TOP = "top"  # unimorph: one MFC on the +z face (the beam model of Sec. 3.2)


class CfrpProperties(StrEnum):
    FSI = "fsi"  # Table 3.9: E 29.5 GPa, rho 1700
    ACOUSTIC = "acoustic"  # Table 3.5: E 20.5 GPa, rho 1643
    BEAM = "beam"  # Table 3.2: E 20.05 GPa, rho 1643


class HeadCondition(StrEnum):
    CLAMPED = "clamped"
    FREE = "free"
    ELASTIC = "elastic"  # held by springs over the clamp region
    PINNED = "pinned"  # a hinge about the vertical line x = pin_x_m (the thrust rig's stick)


class AnalysisKind(StrEnum):
    STATIC = "static"
    DYNAMIC = "dynamic"
    MODAL = "modal"
    SWIMMING = "swimming"  # self-propelled speed and turning rate (fluid_adapter/swimming.py)


class SkinFriction(StrEnum):
    ITTC_1957 = "ittc-1957"  # 0.075 / (log10 Re - 2)^2, fully turbulent
    BLASIUS = "blasius"  # 1.328 / sqrt(Re), laminar


class ThrustModel(StrEnum):
    LIGHTHILL = "lighthill"  # elongated-body thrust, edge suction included (eq. 5-12)
    PRESSURE = "pressure"  # its share carried by the pressure: no suction at sharp edges


class SectionAddedMass(StrEnum):
    MATCHED = "matched"  # rho pi b^2 scaled to the 3D flow's on the first wet bending mode
    STRIP = "strip"  # rho pi b^2 fluid.added_mass_coefficient: elongated-body theory as it is


class Integrator(StrEnum):
    GENERALIZED_ALPHA = "generalized-alpha"
    NEWMARK = "newmark"  # average acceleration (trapezoidal rule)
    ENERGY_CONSERVING = "energy-conserving"  # midpoint rule with a discrete energy gradient


class Waveform(StrEnum):
    SINE = "sine"
    SQUARE = "square"


class DriveModel(StrEnum):
    INDUCED_STRAIN = "induced-strain"  # MFC layers with a free (eigen)strain d E_V
    SEED_STRESS = "seed-stress"  # eq. 3-10's stress applied as dead loads (Sec. 3.5.2.1)


class StartMode(StrEnum):
    PERIODIC = "periodic"  # on the linear periodic orbit: the first periods are steady state
    REST = "rest"  # at rest in static equilibrium under the voltages of t = 0 (the seed)


class MeshLevel(StrEnum):
    COARSE = "coarse"
    DEFAULT = "default"
    FINE = "fine"


class FluidModel(StrEnum):
    NONE = "none"
    POTENTIAL = "potential"
    SLENDER_BODY = "slender_body"
    OPENFOAM = "openfoam"


class FluidDomain(StrEnum):
    SPHERE = "sphere"  # Sec. 3.4.2.1: sphere around the robot, p = 0 on its surface
    TANK = "tank"  # Sec. 3.5.2.2: 590 x 133 x 440 mm tank, walls, open top (p = 0)


class Turbulence(StrEnum):
    K_OMEGA_SST = "kOmegaSST"
    SMAGORINSKY = "Smagorinsky"
    WALE = "WALE"  # LES whose eddy viscosity vanishes in pure shear and at walls
    LAMINAR = "laminar"


class TimeScheme(StrEnum):
    EULER = "Euler"
    BACKWARD = "backward"


class FluidDriver(StrEnum):
    # pimpleFoam stays loaded between windows (one fluid step per window); a repeated window
    # restarts it from the checkpoint, started ahead on a free core
    PERSISTENT = "persistent"
    RELAUNCH = "relaunch"  # each solve restarts from the last converged time folder


class Extrapolation(StrEnum):
    CONSTANT = "constant"
    LINEAR = "linear"
    QUADRATIC = "quadratic"
    PERIODIC = "periodic"


class AddedMassModel(StrEnum):
    POTENTIAL = "potential"
    STRIP = "strip"


class CouplingScheme(StrEnum):
    """The partitioned coupling scheme: its name in case files and results, and what it does
    (the properties below)."""

    EXPLICIT = "explicit"
    CONSTANT = "constant"
    AITKEN = "aitken"
    IQN_ILS = "iqn-ils"
    IQN_ILS_AM = "iqn-ils-am"
    EXPLICIT_AM = "explicit-am"
    # IQN-IMVJ without the added-mass preconditioning: for participants without a fast fluid
    # model (the Turek & Hron flag), set in code; no case-file choice (case_choice)
    IQN_IMVJ = "iqn-imvj"

    @property
    def case_choice(self) -> bool:
        """Whether a case file (or ``--set``) may name this scheme."""
        return self is not CouplingScheme.IQN_IMVJ

    @property
    def iterates(self) -> bool:
        """Whether it solves a window again until it converges (implicit coupling)."""
        return self.accelerator is not None

    @property
    def uses_added_mass(self) -> bool:
        """Whether the fast model's added mass preconditions the exchange (the *-am schemes)."""
        return self in (CouplingScheme.IQN_ILS_AM, CouplingScheme.EXPLICIT_AM)

    @property
    def accelerator(self) -> str | None:
        """The acceleration that proposes each next iterate (fsi_orchestrator.acceleration's
        scheme name), None for one solve per window. The quasi-Newton *-am and imvj schemes
        keep all past windows in a multi-vector Jacobian (IMVJ)."""
        return _ACCELERATORS.get(self)


_ACCELERATORS = {
    CouplingScheme.CONSTANT: "constant",
    CouplingScheme.AITKEN: "aitken",
    CouplingScheme.IQN_ILS: "iqn-ils",
    CouplingScheme.IQN_ILS_AM: "iqn-imvj",
    CouplingScheme.IQN_IMVJ: "iqn-imvj",
}


@dataclass(frozen=True, kw_only=True)
class CaseInfo:
    title: str = param("", "Free text shown in logs and results.")


@dataclass(frozen=True, kw_only=True)
class Geometry:
    kind: GeometryKind = param(
        GeometryKind.FISH,
        "Plate outline: the fish planform, a plain "
        "isotropic rectangle (verification), or the seed's MFC-on-CFRP "
        "beam (Table 3.2).",
    )
    preset: Preset = param(
        Preset.ORIGINAL,
        "Fish robot of the seed whose dimensions are the defaults of every fish key below.",
    )
    length_m: float | None = param(
        None,
        "rectangle: plate length along x; beam: CFRP length (default 0.087, Table 3.2).",
        unit="m",
        gt=0,
        le=100,
    )
    width_m: float | None = param(
        None,
        "rectangle: plate width along y; beam: CFRP width (default 0.008).",
        unit="m",
        gt=0,
        le=100,
    )
    thickness_m: float | None = param(
        None,
        "rectangle: plate thickness; fish and beam: CFRP core "
        "thickness (default 0.2e-3, or the preset's).",
        unit="m",
        ge=1e-6,
        le=1,
    )
    body_length_m: float | None = param(
        None, "fish: nose to trailing edge.", unit="m", ge=1e-3, le=1
    )
    max_height_m: float | None = param(None, "fish: largest body height.", unit="m", ge=1e-3, le=1)
    peduncle_height_m: float | None = param(
        None, "fish: height at the caudal peduncle.", unit="m", ge=1e-4, le=1
    )
    caudal_fin_height_m: float | None = param(
        None,
        "fish: height of the (straight) trailing edge of the caudal fin.",
        unit="m",
        ge=1e-4,
        le=1,
    )
    head_length_m: float | None = param(
        None, "fish: nose to the point of maximum height (elliptic head).", unit="m", ge=1e-4, le=1
    )
    taper_start_x_m: float | None = param(
        None, "fish: x where the body starts to taper toward the peduncle.", unit="m", ge=1e-4, le=1
    )
    peduncle_x_m: float | None = param(
        None, "fish: x of the caudal peduncle (narrowest section).", unit="m", ge=1e-4, le=1
    )
    nose_height_fraction: float | None = param(
        None, "fish: height at the nose as a fraction of max_height_m (blunt nose).", gt=0, lt=1
    )
    mfc_thickness_m: float | None = param(
        None, "Thickness of each MFC layer (Table 3.1: 0.3e-3).", unit="m", ge=1e-6, le=0.01
    )
    actuator_length_m: float | None = param(
        None,
        "MFC package length along x (fish: 0.112, Table 3.4; beam: 0.085, Table 3.2).",
        unit="m",
        ge=1e-4,
        le=1,
    )
    actuator_width_m: float | None = param(
        None, "MFC package width (fish: 0.040; beam: 0.007).", unit="m", ge=1e-4, le=1
    )
    active_length_m: float | None = param(
        None,
        "fish: piezo-active length inside the package (Table 3.4: 0.085).",
        unit="m",
        ge=1e-4,
        le=1,
    )
    active_width_m: float | None = param(
        None, "fish: piezo-active width (Table 3.4: 0.028).", unit="m", ge=1e-4, le=1
    )
    actuator_start_x_m: float | None = param(
        None,
        "x of the package's front edge (beam: set back from the clamp, default 0.4e-3).",
        unit="m",
        ge=0,
        le=1,
    )
    actuator_sides: ActuatorSides | None = param(
        None, "MFC on both faces (fish default) or on the +z face only (beam default)."
    )
    head_weight_radius_m: float | None = param(
        None, "fish: radius of the steel head weight (disk).", unit="m", ge=1e-4, le=0.1
    )
    head_weight_thickness_m: float | None = param(
        None,
        "fish: thickness of the head weight (Tables 3.5/3.9: 2.5e-3).",
        unit="m",
        ge=0,
        le=0.05,
    )
    head_weight_x_m: float | None = param(
        None,
        "fish: x of the head weight's centre (default radius + 3 mm).",
        unit="m",
        ge=1e-4,
        le=1,
    )


@dataclass(frozen=True, kw_only=True)
class Material:
    youngs_modulus_pa: float | None = param(
        None,
        "rectangle: Young's modulus (required); fish/beam: overrides the CFRP core's.",
        unit="Pa",
        ge=1e3,
        le=1e13,
    )
    poisson_ratio: float | None = param(
        None,
        "rectangle: Poisson ratio (required); fish/beam: overrides the CFRP core's.",
        gt=-1,
        lt=0.5,
    )
    density_kg_m3: float | None = param(
        None,
        "rectangle: density (required); fish/beam: overrides the CFRP core's.",
        unit="kg/m^3",
        ge=1e-3,
        le=1e5,
    )
    cfrp: CfrpProperties | None = param(
        None, "CFRP property set for fish/beam (default: fsi for the fish, beam for the beam)."
    )
    loss_factor: float = param(
        0.0,
        "Structural (hysteretic) loss factor eta of the laminate, stiffness K (1 + i eta). The "
        "linear sweep uses it as such at every frequency; a transient as the stiffness-"
        "proportional (Kelvin-Voigt, strain-rate) damping eta / omega (exact at omega), omega the "
        "drive's angular frequency or, below it, the first bending mode's. The seed's cases take "
        "0.013, 1 / Q_m of "
        "the MFC's PZT-5A fibres (Q_m 75-80 on PZT-5A data sheets): the MFC layers carry most "
        "of the bending stiffness.",
        ge=0,
        le=0.5,
    )


@dataclass(frozen=True, kw_only=True)
class Actuation:
    frequency_hz: float = param(3.0, "Driving frequency.", unit="Hz", gt=0, ge=0.01, le=1000)
    waveform: Waveform = param(Waveform.SINE, "Voltage waveform of both actuators.")
    left_volts: tuple[float, ...] = param(
        (-500.0, 1500.0),
        "[min, max] voltage of the left (+z face) MFC, within the MFC's -500..1500 V (Table 3.1).",
        unit="V",
        length=2,
    )
    right_volts: tuple[float, ...] = param(
        (-500.0, 1500.0),
        "[min, max] voltage of the right "
        "(-z face) MFC, driven in anti-phase (opposite "
        "sense) to the left one; within -500..1500 V.",
        unit="V",
        length=2,
    )
    static_volts: tuple[float, ...] = param(
        (0.0, 0.0),
        '[left, right] constant voltages used by analysis.kind = "static".',
        unit="V",
        length=2,
    )
    electrode_spacing_m: float = param(
        0.5e-3,
        "W of eq. 3-11 (E = V/W). Not in the seed; about "
        "1800 ppm free strain over 2000 V with d33 = 460 pm/V "
        "implies W = 0.51 mm.",
        unit="m",
        ge=1e-6,
        le=0.01,
    )
    d33_m_per_v: float = param(
        460e-12,
        "Piezo constant along the fibres (Table 3.1, high field).",
        unit="m/V",
        ge=-1e-8,
        le=1e-8,
    )
    d31_m_per_v: float = param(
        -210e-12,
        "Piezo constant across the fibres (Table 3.1, high field).",
        unit="m/V",
        ge=-1e-8,
        le=1e-8,
    )
    drive_model: DriveModel = param(
        DriveModel.INDUCED_STRAIN,
        "How the MFC drives the laminate: induced-strain (each active layer has the free "
        "strain [d33, d31] V/W, eq. 3-9, and is held by the plate: a mean voltage prestresses "
        "it) or seed-stress (the seed's form, Sec. 3.1.3/3.5.2.1: eq. 3-10's stress applied to "
        "the MFC as dead loads: the same linear response, but the loads stretch the laminate "
        "where the induced strain of a free strip stresses nothing). docs/validation.md, "
        "'Drive model'.",
    )
    mean_strain_transfer: float = param(
        1.0,
        "Share of the mean voltage's induced strain (the +500 V of -500..+1500 V) that the "
        "laminate holds in the periodic state; the oscillating part is always transmitted. "
        "1: an elastic bond (the mean expansion, held back by the passive plate around the "
        "active area, prestresses it); 0: the epoxy bond and the MFC's matrix creep under the "
        "sustained mean stress and the laminate carries none of it. A 0.1 mm CFRP core "
        "buckles under the full mean (docs/validation.md, 'Drive model').",
        ge=0,
        le=1,
    )
    ramp_periods: float = param(
        0.0,
        "Periods over which the voltage amplitude ramps up from 0 "
        "(0: switched on at t = 0 like the seed).",
        ge=0,
        le=1000,
    )


@dataclass(frozen=True, kw_only=True)
class Loads:
    tip_force_n: float = param(
        0.0,
        "rectangle/beam: total dead force on the free edge along +z, "
        "spread uniformly over the edge.",
        unit="N",
        ge=-1e6,
        le=1e6,
    )
    tip_moment_nm: float = param(
        0.0,
        "rectangle/beam: total moment on the free edge about the "
        "width axis; positive bends toward +z (follows the edge's "
        "rotation).",
        unit="N m",
        ge=-1e6,
        le=1e6,
    )
    pressure_pa: float = param(
        0.0,
        "Uniform follower pressure on the plate, along the current +z-side normal.",
        unit="Pa",
        ge=-1e7,
        le=1e7,
    )


@dataclass(frozen=True, kw_only=True)
class Boundary:
    head: HeadCondition = param(
        HeadCondition.CLAMPED,
        'fish: head clamped ("fixed head"), '
        "free (free-free modes; a free body in dynamic runs, its static "
        "start held by a reaction-free support), elastic (the nodes a clamp would hold rest "
        "on springs of boundary.support_stiffness_n_per_m in all three directions) or pinned "
        "(the vertical line x = boundary.pin_x_m held in place and free to turn about "
        "itself, as the point contact of the thrust rig's stick holds the head, Sec. 4.3.1); "
        "rectangle/beam: x = 0 edge clamped or free, or pinned at boundary.pin_x_m.",
    )
    clamp_length_m: float | None = param(
        None,
        "fish: nodes with x <= this are clamped (default: "
        "the head weight's rear edge); rectangle/beam: 0.",
        unit="m",
        ge=0,
        le=100,
    )
    pin_x_m: float = param(
        0.0,
        'boundary.head = "pinned": where along the plate the hinge line stands (0: the nose, '
        "where the rig's stick touches the head; within 0.1 % of the length of an edge the "
        "shell mesh has anyway, such as the tail or an actuator's end, it stands on that edge). "
        "A static solve holds the free turn at a tenth of the length from it.",
        unit="m",
        ge=0,
        le=100,
    )
    support_stiffness_n_per_m: float = param(
        1000.0,
        'boundary.head = "elastic": total stiffness of the springs under the held region, '
        "spread by area over its nodes, the same along x, y and z (their spread over the "
        "region also resists rotation). The rig's stick and contact are not described in the "
        "seed (docs/validation.md).",
        unit="N/m",
        gt=0,
        le=1e9,
    )


@dataclass(frozen=True, kw_only=True)
class Analysis:
    kind: AnalysisKind = param(
        AnalysisKind.DYNAMIC,
        "static (load steps, Newton), dynamic "
        "(implicit time integration, Newton each step), modal (in "
        'vacuum, or wet with fluid.model = "potential") or swimming (self-propelled speed, '
        "swimming number and turning rate of the free fish from its linear periodic response; "
        'boundary.head = "free", or "elastic" for a restrained head, and a liquid, '
        'fluid.model not "none"; keys in [swimming], '
        "docs/swimming.md).",
    )
    load_steps: int = param(10, "static: number of load increments.", ge=1, le=10_000)
    num_modes: int = param(6, "modal: number of elastic modes reported.", ge=1, le=200)
    integrator: Integrator = param(
        Integrator.GENERALIZED_ALPHA,
        "dynamic: time integrator. "
        "generalized-alpha damps the stiff membrane modes (rho_infinity "
        "< 1); energy-conserving keeps 1/2 v.Mv + strain energy exact "
        "(the trapezoidal rule pumps energy into membrane modes at "
        "moderate rotations).",
    )
    rho_infinity: float = param(
        0.9,
        "generalized-alpha: spectral radius at infinite frequency (1: no numerical damping).",
        ge=0,
        le=1,
    )
    newton_tolerance: float = param(
        1e-8, "Relative tolerance on the Newton increment and energy norm.", ge=1e-14, lt=1
    )
    max_newton_iterations: int = param(
        30, "Newton iterations per step before giving up.", ge=1, le=1000
    )
    reuse_tangent: bool = param(
        True,
        "dynamic (generalized-alpha, newmark): Newton keeps its factored tangent (modified "
        "Newton, residuals only) once the increments are small, and a coupling re-solve starts "
        "with the last one; a new one is factored when an increment shrinks less than 4x. The "
        "same answer to the Newton tolerance; a coupled window's structure costs a third less.",
    )
    rayleigh_alpha_per_s: float = param(
        0.0, "Mass-proportional Rayleigh damping.", unit="1/s", ge=0, le=1e6
    )
    rayleigh_beta_s: float = param(
        0.0, "Stiffness-proportional Rayleigh damping.", unit="s", ge=0, le=1
    )


@dataclass(frozen=True, kw_only=True)
class Time:
    periods: float = param(3.0, "dynamic: simulated time in driving periods.", gt=0, le=10_000)
    steps_per_period: int = param(
        40, "dynamic: time steps (coupling windows) per period.", ge=4, le=100_000
    )
    step_s: float | None = param(
        None,
        "dynamic: time step, with time.end_time_s (overrides steps_per_period; a run "
        "without actuation has no period and needs both).",
        unit="s",
        ge=1e-9,
        le=10,
    )
    end_time_s: float | None = param(
        None,
        "dynamic: end time, with time.step_s (overrides periods).",
        unit="s",
        gt=0,
        le=1e4,
    )
    periodic_tolerance: float | None = param(
        None,
        "dynamic with actuation: end the run at the end of a period once the tail amplitude "
        "(and the mean thrust, where the fluid reports it) changed by less than this, "
        "relative, over each of the last two periods; time.periods is then the most it runs. "
        "For sweeps and design studies that want the periodic state, not a start-up "
        "(docs/coupling.md).",
        gt=0,
        lt=1,
    )
    periodic_feedback_per_s: float = param(
        0.0,
        "dynamic with actuation: rate g of a delayed feedback f = -g M (v(t) - v(t - T)) on "
        "the structure (Pyragas), zero on a periodic motion, so the periodic state is the same; "
        "it damps what does not repeat from period to period, such as the coupled start-up's "
        "slow beat. 0: off (docs/coupling.md).",
        unit="1/s",
        ge=0,
        le=1e4,
    )
    periodic_feedback_mirror: bool = param(
        False,
        "with time.periodic_feedback_per_s: also feed back the mirror image of the motion half "
        "a period earlier, f = -g M (v(t) - S v(t - T/2)), S the mirror through the plate's "
        "plane. A fish whose two actuators get the same voltages in opposite senses repeats "
        "its motion mirrored every half period, so this too is zero on the periodic state; it "
        "damps what the period's term cannot, such as a mode near twice the drive. Needs "
        "time.steps_per_period even and actuation.left_volts = right_volts (docs/coupling.md).",
    )
    start: StartMode = param(
        StartMode.PERIODIC,
        "dynamic with actuation: start on the linear periodic response (no start-up "
        "transient to wait for) or at rest like the seed.",
    )
    start_from: str = param(
        "",
        "dynamic with actuation: start on the periodic orbit an earlier run ended on (its "
        "output folder or checkpoint.h5; relative paths from the case folder), from its last "
        "state, instead of the fast model's orbit. An OpenFOAM run started from an OpenFOAM "
        "run (serial or decomposed, the same tank, 8 or more windows per period) starts with that "
        "run's flow mapped onto its mesh and follows the orbit for one period before window "
        "0; otherwise its lead-in follows it for two periods from rest. It needs the same "
        "shell mesh and frequency and a run of whole periods; the fluid's mesh level or model "
        "may differ: a default-level run from the coarse level's periodic state "
        "(docs/coupling.md).",
    )


@dataclass(frozen=True, kw_only=True)
class ShellMesh:
    level: MeshLevel = param(MeshLevel.DEFAULT, "Shell mesh level (see docs for element counts).")
    elements_length: int | None = param(
        None, "Quad9 elements along x (overrides level).", ge=1, le=400
    )
    elements_width: int | None = param(
        None, "Quad9 elements across y (overrides level).", ge=1, le=400
    )


@dataclass(frozen=True, kw_only=True)
class Fluid:
    model: FluidModel = param(FluidModel.NONE, "Fluid around the plate.")
    density_kg_m3: float = param(
        1820.0, "Fluorinert FC-3283 (Table 3.6).", unit="kg/m^3", ge=1e-3, le=1e7
    )
    kinematic_viscosity_m2_s: float = param(
        0.75e-6, "FC-3283 (Table 3.6).", unit="m^2/s", ge=1e-9, le=1
    )
    mesh_level: MeshLevel = param(MeshLevel.DEFAULT, "Fluid mesh level.")
    domain: FluidDomain = param(
        FluidDomain.SPHERE,
        "potential: fluid domain (the seed's modal sphere or the experiment's tank).",
    )
    domain_diameter_m: float = param(
        0.2, "potential, sphere: diameter (Sec. 3.4.2.1: 0.2).", unit="m", gt=0, le=2
    )
    tank_length_m: float = param(
        0.59, "Tank size along the body axis x (Sec. 3.5.2.2).", unit="m", ge=0.01, le=2
    )
    tank_depth_m: float = param(
        0.44, "Tank size along y (vertical; open top at +y).", unit="m", ge=0.01, le=2
    )
    tank_width_m: float = param(
        0.133, "Tank size along z (the swing direction).", unit="m", ge=0.01, le=2
    )
    tank_nose_x_m: float | None = param(
        None,
        "x of the fish's nose from the tank's front wall (default: fish centred in the tank).",
        unit="m",
        gt=0,
        le=2,
    )
    inflow_m_s: float = param(
        0.0,
        "openfoam: a flume: uniform inflow along +x (nose to tail) through the tank's front "
        "wall, an outlet at its back wall, the other walls and the top slip. 0: the closed "
        "tank. A swimming case with fluid.model = openfoam sets it to swimming.speed_m_s "
        "(docs/swimming.md).",
        unit="m/s",
        ge=0,
        le=5,
    )
    damping_ratio: float = param(
        0.0,
        "potential, transient: modal damping ratio at the first "
        "wet mode (the inviscid model has none).",
        ge=0,
        lt=1,
    )
    edge_drag: bool = param(
        False,
        "potential/slender_body: add the separated-flow drag of the plate's edges, "
        "C_D = 9.82 KC^-0.224 per unit area, fitted to OpenFOAM's lateral force on the same "
        "motion (fluid_adapter/drag.py, benchmarks/fast_fluid_damping.py): the fast model's "
        "fluid damping from a measured source, in transients and the periodic start.",
    )
    edge_drag_frequency_exponent: float = param(
        0.4,
        "edge_drag: r in C_D = C0 KC^-q (f / 3 Hz)^-r, how the drag coefficient changes with the "
        "drive frequency at a fixed KC. 0.4 is fitted to OpenFOAM's coupled 1-25 Hz tail "
        "amplitudes of the held fish (fitted apart: sine 0.37, square 0.36 with the edge inertia, "
        "0.41 and 0.39 without; median error 7 % at 0.4, against 20-29 % with 0, the 3 Hz law "
        "alone; docs/benchmarks.md, "
        "fast_fluid_accuracy.py --fit-exponent).",
        ge=0,
        le=2,
    )
    edge_inertia: bool = param(
        True,
        "edge_drag: add the extra inertia of the liquid the edges' vortices carry, m = gamma "
        "rho |a| per unit area (a the local amplitude of the periodic response), fitted to "
        "OpenFOAM's lateral force on the same motion (fluid_adapter/drag.py, "
        "benchmarks/fast_fluid_inertia.py). A linear sweep finds it with its response; a "
        "transient holds it at its periodic orbit's amplitude.",
    )
    edge_inertia_gamma: float = param(
        1.17,
        "edge_inertia: gamma, the carried layer's thickness per amplitude; 1.17 fits OpenFOAM's "
        "inertia at 1, 7.8 and 17.8 mm tail within 0.2 %.",
        ge=0,
        le=10,
    )
    added_mass_coefficient: float = param(
        1.0, "slender_body: gamma of A33 = rho pi b^2 gamma (eq. 5-3).", gt=0, le=10
    )
    thrust_shedding_kc: float = param(
        0.61,
        "KC0 of the fast thrust (mean_thrust_n of a fast fluid's run or linear sweep): each "
        "harmonic of the motion makes KC / (KC + KC0) of Lighthill's reactive thrust, KC = 2 pi a "
        "/ h at the trailing edge. Fitted to OpenFOAM's thrust on the held fish's own motion "
        "(1-25 Hz, 0.43-0.86 of Lighthill's; benchmarks/fast_thrust_shedding.py). 0: Lighthill's "
        "thrust as it is. slender_body_mean_thrust_n stays Lighthill's; swimming at speed too.",
        ge=0,
        le=100,
    )
    turbulence: Turbulence = param(
        Turbulence.K_OMEGA_SST,
        "openfoam: turbulence model: kOmegaSST (RANS), Smagorinsky or WALE (LES), laminar. "
        "WALE leaves resolved laminar shear alone, Smagorinsky damps it (docs/openfoam.md).",
    )
    time_scheme: TimeScheme = param(TimeScheme.BACKWARD, "openfoam: ddt scheme.")
    driver: FluidDriver = param(
        FluidDriver.RELAUNCH,
        "openfoam: how solves are driven: `relaunch` starts pimpleFoam for every solve (Courant "
        "sub-steps allowed); `persistent` keeps it loaded between windows (one fluid step per "
        "window; a repeated window goes on with a process started from its start, as root "
        "run as `nobody`).",
    )
    processes: int = param(
        1, "openfoam: MPI ranks for pimpleFoam (decomposePar, hierarchical).", ge=1, le=1024
    )
    mesh_scale: float = param(
        1.0,
        "openfoam: multiplies every cell size of fluid.mesh_level (1.5: about 1/3 the cells).",
        ge=0.5,
        le=10,
    )
    max_courant: float = param(
        2.0,
        "openfoam: largest Courant number of a fluid time step; each coupling window is split "
        "into as many fluid steps as this needs (the interface moves linearly within a window). "
        "Two-way coupled runs want one step per window (a large value): sub-stepped windows "
        "made converged coupled runs oscillate (docs/coupling.md).",
        ge=0.01,
        le=1e6,
    )
    outer_correctors: int = param(
        2,
        "openfoam: PIMPLE outer correctors per fluid step (nOuterCorrectors; 1 is PISO). "
        "2 lie within 0.55 % of 4 in the fish's forces; PISO 5.6 % off (docs/openfoam.md).",
        ge=1,
        le=20,
    )
    non_orthogonal_correctors: int = param(
        1,
        "openfoam: non-orthogonal correctors per pressure solve (nNonOrthogonalCorrectors). "
        "With 0 a step costs about 11 % less and the forces move by under 0.2 % at 3-18 Hz, but "
        "the main job's scene at 1 Hz (the largest motion) diverged (docs/openfoam.md).",
        ge=0,
        le=5,
    )


@dataclass(frozen=True, kw_only=True)
class Coupling:
    scheme: CouplingScheme = param(CouplingScheme.IQN_ILS_AM, "Partitioned coupling scheme.")
    relaxation: float | None = param(
        None,
        "constant: the relaxation factor; aitken/iqn-ils: the first iteration's (default 0.5); "
        "iqn-ils-am: its starting inverse Jacobian is this times the identity (default 1.0, "
        "the preconditioned map is contractive); explicit-am: unused.",
        gt=0,
        le=1,
    )
    tolerance_rel: float = param(
        1e-4, "Relative convergence tolerance of the exchanged data.", ge=1e-14, lt=1
    )
    max_iterations: int = param(
        50,
        "Coupling iterations per window; a window that has not converged by then is accepted, "
        "counted and reported (divergence - NaN or growth - stops the run).",
        ge=1,
        le=10_000,
    )
    predictor: Extrapolation = param(
        Extrapolation.PERIODIC,
        "First iterate of a window from the last windows' forces. periodic: the value one "
        "period back plus the change from period to period, or linear or quadratic "
        "extrapolation in time, whichever predicted the last window best (explicit schemes: "
        "the period rule or the last value; extrapolation destabilises them).",
    )
    reuse_windows: int = param(
        8, "iqn-ils: past windows whose secant information is reused.", ge=0, le=1000
    )
    partitioned: bool = param(
        False,
        "potential/slender_body: run the liquid as a separate participant through the "
        "coupling loop (stability studies of the schemes) instead of adding its mass to the "
        "structure (exact for the linear model, one solve per window).",
    )
    added_mass_model: AddedMassModel = param(
        AddedMassModel.POTENTIAL,
        "*-am schemes: the fast model whose interface added mass preconditions the coupling.",
    )
    added_mass_mesh_level: MeshLevel = param(
        MeshLevel.COARSE, "*-am schemes, potential: fluid mesh level of the preconditioner."
    )
    added_mass_scale: float = param(
        1.0,
        "*-am schemes: share of the fast added mass moved to the structure (any value keeps "
        "the converged result; the best one matches the fluid's response, docs/coupling.md).",
        gt=0,
        le=2,
    )
    explicit_periods: int = param(
        0,
        "iqn-ils-am: the first n periods after the lead-in take one fluid solve per window with "
        "the added-mass correction (as explicit-am), then the windows are iterated to "
        "coupling.tolerance_rel. A cheap start-up for long runs (default level, 4 periods: "
        "29 % less wall time; docs/coupling.md).",
        ge=0,
        le=10_000,
    )
    explicit_until_periodic: bool = param(
        False,
        "iqn-ils-am with time.periodic_tolerance: windows take one fluid solve (as "
        "explicit-am) until the periods agree to 5 % (or the tolerance, if larger), then they "
        "are iterated until the periods agree to the tolerance, so the figures a run ends "
        "with are iterated windows'. For drives where one solve per window stays off the "
        "iterated state or diverges: square waves (3 Hz coarse: +3 % in thrust), sines above "
        "15 Hz; with a sine up to that, explicit-am settles within 0.1-0.4 % of it "
        "(docs/coupling.md). A run that ends before it iterates (under 4 periods) says so.",
    )
    explicit_fallback_windows: tuple[int, ...] = param(
        (30, 20),
        "fsi-sweep with a one-solve scheme (explicit-am) and a sine: where a point's windows "
        "diverge, run it again with each of these time.steps_per_period below its own, "
        "longest windows first, before iterating its windows. Longer windows steady one "
        "solve per window: the default level's 15 Hz sine runs at 30 within 0.6 % (tail) "
        "and 2.3 % (thrust) of iterated windows at 40 in a seventh of their time; at 20 the "
        "coarse thrust is off by -6 to +4 % at 17-25 Hz. The row's status names the count; "
        "[] iterates at once (docs/validation.md).",
        ge=4,
        le=100_000,
    )
    jacobian_from: str = param(
        "",
        "iqn-ils-am: start the quasi-Newton Jacobian from the one an earlier run learned (its "
        "output folder or checkpoint.h5; relative paths from the case folder) instead of from "
        "scratch. It needs the same shell mesh; drive, frequency, thickness or head weight may "
        "differ. Fewer fluid solves in the first periods, same result (docs/coupling.md).",
    )
    start_correction: bool = param(
        True,
        "openfoam with time.start = periodic: fit the liquid's extra inertia and damping over "
        "the lead-in and start the structure on the corrected orbit (one more lead-in period; "
        "docs/coupling.md).",
    )


@dataclass(frozen=True, kw_only=True)
class Output:
    vtk: bool = param(
        True,
        "Write VTU/PVD series of the shell (vtk/shell.pvd) and, in partitioned runs, of the "
        "fluid's loads on the interface (vtk/fluid.pvd).",
    )
    vtk_every: int = param(1, "Write VTU every n windows.", ge=1, le=1_000_000)
    checkpoint_every: int = param(
        10,
        "Write a restart checkpoint every n windows. The structure factors a fresh tangent after "
        "each (analysis.reuse_tangent), so that --resume repeats the run exactly; runs with "
        "different n agree to the Newton tolerance.",
        ge=1,
        le=1_000_000,
    )
    flow_every: int = param(
        10,
        "OpenFOAM: write flow surfaces (p, U, vorticity) every n windows; 0: none. "
        "vtk/flow_midheight.pvd, a horizontal plane through the plate's centre height; "
        "vtk/flow_wake.pvd, across the tank 20 mm behind the tail; vtk/flow_body.pvd, the "
        "fish's faces; vtk/flow_vortices.pvd, the Q-criterion iso-surface (output.vortex_q_level). "
        "fsi-post draws them in 3D.",
        ge=0,
        le=1_000_000,
    )
    vortex_q_level: float = param(
        0.1,
        "OpenFOAM: the level of the wake's Q-criterion iso-surface (vtk/flow_vortices.pvd), in "
        "units of the drive's (2 pi f)^2 (0.1 at 10 Hz: 395 1/s^2, where the coarse LES wake "
        "peaks at 2440); 0: none. Q > 0 where rotation outweighs strain: vortex cores.",
        unit="(2 pi f)^2",
        ge=0,
        le=1e6,
    )


@dataclass(frozen=True, kw_only=True)
class Swimming:
    speed_m_s: float | None = param(
        None,
        "Forward speed at which thrust and drag are evaluated (a flume's inflow); unset: the "
        "self-propelled speed, where the mean thrust equals the drag.",
        unit="m/s",
        ge=0,
        le=20,
    )
    thrust_model: ThrustModel = param(
        ThrustModel.LIGHTHILL,
        "Mean thrust of the motion: lighthill (elongated-body theory, seed eqs. 5-1..5-12) or "
        "pressure (the sections' reactive force on the inclined plate alone, without the "
        "suction potential flow puts at the sharp edges; closer to the flume's CFD, "
        "docs/swimming.md). The speed only: turning keeps Lighthill's side force.",
    )
    skin_friction: SkinFriction = param(
        SkinFriction.ITTC_1957,
        "Flat-plate skin-friction line of the wetted plate (both faces) at Re = V L / nu: "
        "ittc-1957 (fully turbulent, ITTC 1957 correlation line) or blasius (laminar, "
        "Schlichting eq. 7.34).",
    )
    head_weight_drag_coefficient: float = param(
        0.63,
        "Form drag of the steel head weight, seen from the front as a short circular cylinder "
        "across the flow (diameter 2 r, length its thickness): C_D of a cylinder of "
        "length/diameter 1 (White, Fluid Mechanics, Table 7.3), on the area 2 r x thickness.",
        ge=0,
        le=10,
    )
    float_drag_coefficient: float = param(
        1.05,
        "Form drag of the float on the robot's top (seed Sec. 4.1: blowing agent, size not "
        "given), taken as a cube face-on (Hoerner, Fluid-Dynamic Drag, 1965, ch. 3).",
        ge=0,
        le=10,
    )
    float_density_kg_m3: float = param(
        30.0,
        "Density of the float's foam (low-density blowing agent; rigid PU foam 30-50).",
        unit="kg/m^3",
        ge=0,
        le=1000,
    )
    float_volume_m3: float | None = param(
        None,
        "Float volume; unset: what makes the robot neutrally buoyant (the model's mass less "
        "the liquid it displaces, over the liquid's density less the foam's).",
        unit="m^3",
        ge=0,
        le=1e-3,
    )
    speed_coupling: bool = param(
        True,
        "Feed the lateral load that forward speed adds (slender-body theory: -(d/dt + V d/dx) "
        "of the sections' momentum beyond the still liquid's added mass) back into the "
        "structure, so the motion is the one at the speed: its wake takes energy and damps "
        "the tail. false: the motion in still liquid at every speed (docs/swimming.md).",
    )
    section_added_mass: SectionAddedMass = param(
        SectionAddedMass.MATCHED,
        "Added mass per length A = rho pi b^2 gamma of the thrust, the turning and the load at "
        "speed: matched (gamma such that the strip theory carries the case's 3D potential "
        "added mass on the first wet bending mode: 0.25-0.42 for the seed's robots, whose "
        "bending waves are about as long as the plate is high) or strip (gamma = "
        "fluid.added_mass_coefficient, elongated-body theory as it is; docs/swimming.md).",
    )
    crossflow_drag_coefficient: float = param(
        1.2,
        "Turning: drag of the plate's sections moving sideways as the body rotates (a flat "
        "plate normal to the flow, breadth/height 1-5: White, Fluid Mechanics, Table 7.3).",
        ge=0,
        le=10,
    )


SECTIONS: dict[str, type] = {
    "case": CaseInfo,
    "geometry": Geometry,
    "material": Material,
    "actuation": Actuation,
    "loads": Loads,
    "boundary": Boundary,
    "analysis": Analysis,
    "time": Time,
    "mesh": ShellMesh,
    "fluid": Fluid,
    "coupling": Coupling,
    "output": Output,
    "swimming": Swimming,
}


@dataclass(frozen=True, kw_only=True)
class Case:
    """A validated case: every section typed and frozen."""

    directory: Path
    case: CaseInfo = field(default_factory=CaseInfo)
    geometry: Geometry = field(default_factory=Geometry)
    material: Material = field(default_factory=Material)
    actuation: Actuation = field(default_factory=Actuation)
    loads: Loads = field(default_factory=Loads)
    boundary: Boundary = field(default_factory=Boundary)
    analysis: Analysis = field(default_factory=Analysis)
    time: Time = field(default_factory=Time)
    mesh: ShellMesh = field(default_factory=ShellMesh)
    fluid: Fluid = field(default_factory=Fluid)
    coupling: Coupling = field(default_factory=Coupling)
    output: Output = field(default_factory=Output)
    swimming: Swimming = field(default_factory=Swimming)

    @property
    def name(self) -> str:
        return self.directory.name


def key_spec(key: str) -> ParamSpec:
    """The range and unit of a case key, ``section.key`` (e.g. the drive frequency's, which a
    sweep's frequencies and a sweep table's rows obey too)."""
    section, _, name = key.partition(".")
    return spec_of(next(f for f in fields(SECTIONS[section]) if f.name == name))
