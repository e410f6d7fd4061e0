"""Composition root: builds the solvers a case asks for. With the commands beside it in
fishfsi/cli/, the only part of the product that imports the adapters (lazily, so
that `--help` and case errors stay fast)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import FluidDomain, FluidModel
from fsi_orchestrator.participant import (
    AddedMassPreconditioning,
    HasAccelerationStencil,
    Participant,
)

if TYPE_CHECKING:
    from fsi_orchestrator.coupling import Coupling


def added_mass_for_preconditioning(case: Case, shell_model):
    """The fast model that preconditions the *-am schemes, on the case's fluid domain."""
    from fluid_adapter.potential import build_added_mass
    from fluid_adapter.strip import strip_added_mass
    from fsi_orchestrator.case.schema import AddedMassModel

    if case.coupling.added_mass_model is AddedMassModel.STRIP:
        return strip_added_mass(
            shell_model, case.fluid.density_kg_m3, case.fluid.added_mass_coefficient
        )
    fluid = dataclasses.replace(case.fluid, mesh_level=case.coupling.added_mass_mesh_level)
    if case.fluid.model is FluidModel.OPENFOAM:
        fluid = dataclasses.replace(fluid, domain=FluidDomain.TANK)
    return build_added_mass(dataclasses.replace(case, fluid=fluid), shell_model)


def coupling_settings(case: Case, flow=None):
    """The case's [coupling] keys on the typed settings of its scheme; ``flow``: the earlier
    run's flow the fluid starts with (decide_start_flow), if any."""
    from fsi_orchestrator.case.timing import case_schedule, windows_per_period
    from fsi_orchestrator.coupling_settings import CouplingSettings, scheme_settings

    c = case.coupling
    explicit = c.explicit_periods * windows_per_period(case)
    if c.explicit_until_periodic:  # every window, unless the periodic stop switches them
        explicit = case_schedule(case)[1]
    scheme = scheme_settings(
        c.scheme,
        relaxation=c.relaxation,
        max_iterations=c.max_iterations,
        reuse_windows=c.reuse_windows,
        added_mass_scale=c.added_mass_scale,
        explicit_windows=explicit,
    )
    return CouplingSettings(
        **lead_in(case, flow),
        scheme_settings=scheme,
        tolerance_rel=c.tolerance_rel,
        predictor=c.predictor.value,
        period_s=1 / case.actuation.frequency_hz,
    )


def lead_in(case: Case, flow=None) -> dict:
    """A fluid-only lead-in when a CFD fluid meets a structure that starts on its periodic
    orbit (Coupling.lead_in): one period; on a recorded orbit (time.start_from) two from rest,
    or one with the earlier run's ``flow`` (a FlowSource) mapped on."""
    from fsi_orchestrator.case.schema import StartMode
    from fsi_orchestrator.case.timing import windows_per_period

    if (
        case.fluid.model is not FluidModel.OPENFOAM
        or case.time.start is not StartMode.PERIODIC
        or case.actuation.ramp_periods > 0  # then the structure starts at rest
    ):
        return {}
    return {
        "lead_in_windows": windows_per_period(case),
        "lead_in_omega": 2 * math.pi * case.actuation.frequency_hz,
        "lead_in_periods": RECORDED_LEAD_IN_PERIODS if case.time.start_from else 1,
        "lead_in_displaced": flow is not None,
    }


OPENFOAM_FOLDER = "openfoam"  # a run's OpenFOAM case, in its output folder

# the lead-in before a start on a recorded orbit: after one period the flow still differs
# from its periodic state (prescribed motion from rest: 26 % in thrust, 11 % in lateral force;
# after two, under 1 %), and a coupled start rings from the difference
RECORDED_LEAD_IN_PERIODS = 2


def corrects_start(case: Case) -> bool:
    """Whether the lead-in corrects the structure's start orbit (a recorded orbit, from
    time.start_from, is the CFD's own: nothing to correct)."""
    return case.coupling.start_correction and not case.time.start_from


def lead_in_fluid_windows(case: Case, flow=None) -> int:
    """Fluid solves before window 0: the lead-in's periods, two with the start correction,
    one with an earlier run's ``flow``."""
    settings = lead_in(case, flow)
    n = settings.get("lead_in_windows", 0)
    if settings.get("lead_in_displaced"):
        return n
    return 2 * n if corrects_start(case) else n * settings.get("lead_in_periods", 1)


# fewest windows per period a start with an earlier run's flow takes: the predictor's seed
# bridges its first START_UP_WINDOWS windows from two windows on either side
MIN_WINDOWS_WITH_FLOW = 8


def decide_start_flow(case: Case, output: Path, resume: bool):
    """Whether this run's CFD starts with the flow of the run time.start_from names: its
    FlowSource, or why not (str), or None (no OpenFOAM run started from another). Decided
    once per run: a resumed run keeps what its start did (the case folder's record)."""
    from fluid_adapter.openfoam.flow_start import FlowSource, recorded_flow

    if not case.time.start_from or case.fluid.model is not FluidModel.OPENFOAM:
        return None
    workdir = output / OPENFOAM_FOLDER
    if resume:
        return recorded_flow(workdir)
    found = start_flow(case)
    if isinstance(found, FlowSource) and found.case.resolve() == workdir.resolve():
        return f"{found.case} is this run's own folder, which a fresh start replaces"
    return found


def start_flow(case: Case):
    """time.start_from's flow: the earlier run's OpenFOAM case at the time its checkpoint
    ended (fluid_adapter.openfoam.flow_start.FlowSource) where both are OpenFOAM runs in the
    same tank, else why not (str); None: no OpenFOAM run started from another."""
    from fluid_adapter.openfoam.fishmesh import tank_geometry
    from fluid_adapter.openfoam.flow_start import flow_source
    from fsi_orchestrator.case import CaseError
    from fsi_orchestrator.case.timing import windows_per_period

    if not case.time.start_from or case.fluid.model is not FluidModel.OPENFOAM:
        return None
    if windows_per_period(case) < MIN_WINDOWS_WITH_FLOW:
        return f"fewer than {MIN_WINDOWS_WITH_FLOW} windows per period"
    path = start_from_path(case)
    if not path.is_file():
        return None  # the structure's start refuses it, naming the key
    try:
        t = from_earlier_checkpoint(
            case,
            "time.start_from",
            case.time.start_from,
            lambda loop, _, __: float(loop["coupling"]["fluid"]["t"]),
            "OpenFOAM run's",
        )
    except CaseError as err:
        return str(err).removeprefix("time.start_from: ")
    return flow_source(path.parent / OPENFOAM_FOLDER, t, tank_geometry(case))


def checkpoint_named(case: Case, named: str):
    """The checkpoint a key names: an earlier run's output folder or the file (relative paths
    from the case folder)."""
    from fsi_orchestrator.results import CHECKPOINT_FILE

    path = case.directory / named
    return path / CHECKPOINT_FILE if path.is_dir() else path


def from_earlier_checkpoint(case: Case, key: str, named: str, pick, what: str):
    """``pick(loop state, participants' states, root attributes)`` of the checkpoint ``key``
    names, or one CaseError naming the key: no such file, or not a checkpoint holding
    ``what``."""
    from fsi_orchestrator.case import CaseError
    from fsi_orchestrator.results import CHECKPOINT_FILE, read_checkpoint

    path = checkpoint_named(case, named)
    where = f"{key}: {path}"
    if not path.is_file():
        raise CaseError(
            f"{where} does not exist (give an earlier run's output folder or its {CHECKPOINT_FILE})"
        )
    try:
        loop, participants, attrs = read_checkpoint(path)
        return pick(loop, participants, attrs)
    except (OSError, KeyError, ValueError, RuntimeError):  # ValueError: checksum, NaN
        raise CaseError(f"{where} holds no {what} checkpoint, or a damaged one") from None


def start_from_path(case: Case):
    """The checkpoint time.start_from names."""
    return checkpoint_named(case, case.time.start_from)


def recorded_start(case: Case, ndof: int):
    """time.start_from: the orbit and end state that run recorded (None without the key),
    checked against this case's frequency and a shell of ``ndof`` unknowns."""
    from fsi_orchestrator.case import CaseError
    from fsi_orchestrator.provenance import IDENTITY_ATTR, case_identity, identity_changes
    from solid_adapter.recorded_orbit import StartFromError
    from solid_adapter.recorded_orbit import recorded_start as start_on

    if not case.time.start_from:
        return None
    path = start_from_path(case)
    shell, stored = from_earlier_checkpoint(
        case,
        "time.start_from",
        case.time.start_from,
        lambda _, p, attrs: (p["shell"], attrs.get(IDENTITY_ATTR)),
        "shell's",
    )
    # a run held another way ended with the nodes this case holds displaced: they would stay
    # there, frozen (the state is carried over as it is)
    changed = identity_changes(stored, case_identity(case), 99) if stored else []
    held = [k for k in changed if k.startswith("boundary.")]
    if held:
        raise CaseError(
            f"time.start_from: {path} was run with its plate held otherwise "
            f"({', '.join(held)} changed): start from a run held as this case is"
        )
    try:
        return start_on(path, shell, case.actuation.frequency_hz, ndof)
    except StartFromError as exc:
        raise CaseError(str(exc)) from None


def is_coupled(case: Case) -> bool:
    return case.fluid.model is FluidModel.OPENFOAM or (
        case.coupling.partitioned and case.fluid.model is not FluidModel.NONE
    )


# a start from rest when the fast orbit outruns the CFD: periods of voltage ramp, then periods
# to settle, before the periods the case asks for (the lead-in it replaces has two)
RAMP_PERIODS = 1.0
SETTLE_PERIODS = 1.0


@dataclasses.dataclass(frozen=True)
class CoupledRun:
    """What a partitioned run is built from. ``case`` is the case as run: a start from rest
    (choose_start) changes its ramp and its number of periods; ``start_note`` says why."""

    case: Case
    solid: Participant
    coupling: Coupling
    start_note: str | None = None


def ramped_start(case: Case) -> Case:
    """From rest, the voltage amplitude ramped up over RAMP_PERIODS, SETTLE_PERIODS more to
    settle, then the periods asked for."""
    actuation = dataclasses.replace(case.actuation, ramp_periods=RAMP_PERIODS)
    periods = case.time.periods + RAMP_PERIODS + SETTLE_PERIODS
    return dataclasses.replace(
        case, actuation=actuation, time=dataclasses.replace(case.time, periods=periods)
    )


# the most the lead-in may turn the plate's midline (degrees): the shipped mesh motion fails
# checkMesh from 55 deg of fin rotation (benchmarks/mesh_rotation.py), and the free
# integrative robot's lead-in, turning it 55 deg, blew pimpleFoam up at t = 0.242 s
LEAD_IN_MAX_TURN_DEG = 50.0


def lead_in_turn_deg(motion, times: list[float], nodes) -> float:
    """The steepest the lead-in turns the plate's midline (the row of nodes nearest its mean
    y) over one period of ``motion``, in degrees, after the lead-in's amplitude cap."""
    from fsi_orchestrator.lead_in import LEAD_IN_MAX_AMPLITUDE_M

    path = [motion(t) for t in times]
    peak = max(float(np.max(np.abs(u))) for u in path)
    scale = min(1.0, LEAD_IN_MAX_AMPLITUDE_M / peak) if peak > 0 else 1.0
    y = nodes[:, 1]
    row = np.flatnonzero(np.isclose(y, y[np.argmin(np.abs(y - y.mean()))]))
    row = row[np.argsort(nodes[row, 0])]
    slopes = [
        np.abs(np.diff(scale * u[row, 2]) / np.diff(nodes[row, 0] + scale * u[row, 0]))
        for u in path
    ]
    return float(np.degrees(np.arctan(max(float(s.max()) for s in slopes))))


def choose_start(case: Case, solid) -> tuple[Case, str | None]:
    """The periodic start leads the CFD onto the fast model's orbit (Coupling.lead_in). That
    orbit has no fluid damping: near a wet resonance (20-28 Hz for the clamped fish) it moves
    the plate faster than the lead-in lets the CFD follow (lead_in.LEAD_IN_MAX_SPEED_M_S),
    and at 25 Hz the orbit corrected from the capped lead-in started the plate where its
    first coupled window never converged (docs/coupling.md); near the free integrative
    robot's first mode it turns the thin fin further than the mesh motion follows
    (LEAD_IN_MAX_TURN_DEG). Such a run starts from rest with a voltage ramp instead. Returns
    (the case as run, why it changed or None)."""
    from fsi_orchestrator.case.timing import windows_per_period
    from fsi_orchestrator.lead_in import LEAD_IN_MAX_SPEED_M_S, peak_speed

    motion = solid.orbit_motion() if lead_in(case) else None
    if motion is None:
        return case, None
    n, period = windows_per_period(case), 1.0 / case.actuation.frequency_hz
    times = [k * period / n for k in range(n + 1)]
    speed = peak_speed(motion, times)
    turn = lead_in_turn_deg(motion, times, solid.model.mesh.nodes)
    if speed <= LEAD_IN_MAX_SPEED_M_S and turn <= LEAD_IN_MAX_TURN_DEG:
        return case, None
    ramped = ramped_start(case)
    why = (
        f"moves the plate at {speed:.2g} m/s, faster than the CFD lead-in follows "
        f"({LEAD_IN_MAX_SPEED_M_S:g} m/s"
        if speed > LEAD_IN_MAX_SPEED_M_S
        else f"turns the plate by {turn:.0f} deg, further than the fluid mesh follows "
        f"({LEAD_IN_MAX_TURN_DEG:g} deg"
    )
    reason = (
        f"the fast model's periodic orbit {why}: near a wet resonance its amplitude is set by "
        "damping it does not know)"
    )
    return ramped, from_rest_note(case, ramped, reason)


def from_rest_note(case: Case, ramped: Case, reason: str) -> str:
    """The line that says a run starts from rest instead of on the fast orbit, and why."""
    return (
        f"start: {reason}; starting from rest instead, the voltage ramped up over "
        f"{RAMP_PERIODS:g} period(s), {ramped.time.periods:g} periods in all "
        f"({case.time.periods:g} asked for)"
    )


def coupled_setup(case: Case, fluid_factory=None):
    """(solid participant, Coupling) for a partitioned run (see build_coupled_run)."""
    run = build_coupled_run(case, fluid_factory)
    return run.solid, run.coupling


def build_coupled_run(
    case: Case, fluid_factory=None, *, resume: bool = False, flow=None
) -> CoupledRun:
    """A partitioned run. The structure starts on the periodic orbit estimated with the fast
    added mass (or from rest, choose_start); with an *-am scheme it keeps that mass. ``flow``:
    the earlier run's flow the fluid starts with (decide_start_flow; the factory's too)."""
    from fluid_adapter.fast import fast_added_mass
    from fluid_adapter.potential.participant import PotentialParticipant
    from fsi_orchestrator.acceleration import IQNIMVJAcceleration
    from fsi_orchestrator.coupling import Coupling
    from solid_adapter.build import CorrectableStart, build_shell_model, build_shell_participant

    model = build_shell_model(case)
    # read before the fluid is set up: a wrong file fails at once. A resumed run takes the
    # Jacobian and the state of its own checkpoint
    warm = case.coupling.jacobian_from and not resume
    learned = learned_jacobian(case, model.n_nodes) if warm else None
    recorded = None if resume else recorded_start(case, model.ndof)
    estimate = added_mass_for_preconditioning(case, model)
    model.set_added_mass(estimate.matrix)  # for the periodic start
    solid = build_shell_participant(case, model, recorded)
    start_note = None
    if not case.time.start_from:  # a recorded orbit is one the CFD has followed
        case, start_note = choose_start(case, solid)
    if start_note is not None:
        solid = build_shell_participant(case, model)
    settings = coupling_settings(case, flow)
    scale = settings.added_mass_scale  # None: a plain scheme
    if fluid_factory is not None:
        fluid = fluid_factory(case, solid)
    else:
        true_added_mass = fast_added_mass(case, build_shell_model(case))
        assert true_added_mass is not None  # no fluid factory: the fast fluid, coupled
        fluid = PotentialParticipant(true_added_mass, solid.interface())
    solid.take_added_mass(
        AddedMassPreconditioning(
            added_mass_z=scale * estimate.matrix,
            # M~ weighted with the fluid's own discrete acceleration
            stencil=(
                fluid.acceleration_stencil if isinstance(fluid, HasAccelerationStencil) else None
            ),
        )
        if scale is not None
        else None
    )
    start = None
    if corrects_start(case) and settings.lead_in_windows > 0:
        start = CorrectableStart(case, model, solid, estimate.matrix)
    coupling = Coupling(
        fluid,
        solid.interface().points,
        settings,
        estimate.matrix if settings.uses_added_mass else None,
        start_orbit=start,
    )
    if learned is not None:  # coupling.jacobian_from: iqn-ils-am only (the loader checks)
        assert isinstance(coupling.accelerator, IQNIMVJAcceleration)
        coupling.accelerator.warm_start(learned)
    return CoupledRun(case, solid, coupling, start_note)


def learned_jacobian_path(case: Case):
    """The checkpoint coupling.jacobian_from names (a run's output folder or the file)."""

    return checkpoint_named(case, case.coupling.jacobian_from)


def learned_jacobian(case: Case, n_nodes: int) -> dict:
    """coupling.jacobian_from: the quasi-Newton state saved in that checkpoint (a run's
    output folder or the file), checked against a shell of ``n_nodes`` interface nodes."""
    from fsi_orchestrator.case import CaseError

    where = f"coupling.jacobian_from: {learned_jacobian_path(case)}"
    state = from_earlier_checkpoint(
        case,
        "coupling.jacobian_from",
        case.coupling.jacobian_from,
        lambda loop, _, __: loop["coupling"]["accelerator"],
        "coupled run's",
    )
    if "imvj_jacobian" not in state:
        raise CaseError(
            f'{where} holds no quasi-Newton Jacobian (that run\'s scheme was not "iqn-ils-am")'
        )
    shape = np.shape(state["imvj_jacobian"])
    if shape != (3 * n_nodes, 3 * n_nodes):
        raise CaseError(
            f"{where} holds a Jacobian for {shape[0] // 3} shell nodes, this case's shell has "
            f"{n_nodes}: the meshes differ (geometry, mesh); start without it"
        )
    return state


def openfoam_fluid_factory(workdir, *, fresh: bool, flow=None):
    """Builds the OpenFOAM participant in ``workdir``: regenerated for a fresh run, reused (its
    time folders are the fluid's checkpoints) when resuming. ``flow``: an earlier run's flow
    to start with (decide_start_flow)."""
    import shutil

    from fluid_adapter.openfoam import build_openfoam_participant
    from fsi_orchestrator.case.timing import case_schedule

    def factory(case: Case, solid):
        if fresh and workdir.exists():
            shutil.rmtree(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        workdir.chmod(0o755)  # as root the persistent driver runs OpenFOAM as `nobody`
        _, n_windows = case_schedule(case)
        n_windows += lead_in_fluid_windows(case, flow)
        return build_openfoam_participant(
            case,
            workdir,
            n_windows=n_windows,
            mesh_scale=case.fluid.mesh_scale,
            flow_from=flow if fresh else None,
        )

    return factory
