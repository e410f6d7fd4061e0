"""``fsi-run CASE``: run a case (static, dynamic, modal; structure alone or coupled) and print a
summary (``--json`` for machines)."""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from collections.abc import Sequence
from itertools import pairwise
from pathlib import Path

import h5py
import numpy as np

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.schema import AnalysisKind, FluidModel, StartMode
from fsi_orchestrator.case.timing import case_schedule, windows_per_period
from fsi_orchestrator.loop import OutputSettings, Schedule, StopRule, WindowLoop
from fsi_orchestrator.periodic import summary_fields as periodic_fields
from fsi_orchestrator.provenance import case_identity, run_attributes
from fsi_orchestrator.results import CHECKPOINT_FILE, RESULTS_FILE, ResultsFile
from solid_adapter.solvers import NewtonNotConverged

from .common import (
    EXIT_OK,
    atomic_write,
    base_parser,
    emit,
    json_text,
    load,
    output_folder,
    run_main,
)
from .compose import (
    build_coupled_run,
    decide_start_flow,
    from_rest_note,
    is_coupled,
    learned_jacobian_path,
    openfoam_fluid_factory,
    ramped_start,
    recorded_start,
    start_from_path,
)
from .fast_model import shell_with_fast_fluid
from .linear import swimming_summary
from .modal import modal_summary
from .outputs import (
    check_finite,
    label_results,
    open_run_folder,
    prepare_output,
    refuse_unwritable,
)
from .progress import RunProgress, StopRequest


def schedule_of(case: Case) -> Schedule:
    dt, n_windows = case_schedule(case)
    return Schedule(dt=dt, n_windows=n_windows)


# a start-up still settling: the tail amplitude changed by more than this over the last period
# (the main job's two periods beat with the heavily damped wet first mode, docs/coupling.md)
SETTLED_CHANGE = 0.01


def complete_periods(values: np.ndarray, per_period: int) -> list[np.ndarray]:
    """The complete periods of a window series, counted back from its end, oldest first."""
    n = len(values) // per_period
    start = len(values) - n * per_period
    return [values[start + k * per_period : start + (k + 1) * per_period] for k in range(n)]


def period_amplitudes(values: np.ndarray, per_period: int) -> list[float]:
    """Half the peak-to-peak of each complete period, oldest first."""
    return [float(np.ptp(p) / 2) for p in complete_periods(values, per_period)]


def period_means(values: np.ndarray, per_period: int) -> list[float]:
    return [float(p.mean()) for p in complete_periods(values, per_period)]


# where coupling.explicit_until_periodic starts to iterate: the explicit windows' periods
# changing by less than this (or time.periodic_tolerance, if larger) twice in a row. One solve
# per window does not settle closer: continued from a coarse main job periodic to 0.1 %, it
# wandered by 0.3-2.3 % per period in tail amplitude and 0.1-4.6 % in thrust, where iterated
# windows from the same state stayed within 0.1 % (docs/coupling.md)
EXPLICIT_SWITCH_TOLERANCE = 0.05


def periodic_stop(case: Case, coupling=None, say=None) -> StopRule | None:
    """``time.periodic_tolerance``: the run ends at the end of a period once the tail
    amplitude, and the mean thrust where the fluid reports it, changed by less than the
    tolerance (relative) over each of the last two periods. Two, because the start-up beats
    with the damped wet first mode: one small change can be a crossing of the beat. Not
    before an explicit start-up (``coupling.explicit_periods``) is over: the figures a run
    ends with are those of iterated windows. With ``coupling.explicit_until_periodic`` the
    explicit windows' periodic state (EXPLICIT_SWITCH_TOLERANCE) switches ``coupling`` to
    iterated windows (``say`` tells), and the run ends after at least one iterated period."""
    tolerance, n = case.time.periodic_tolerance, windows_per_period(case)
    if tolerance is None:
        return None
    adaptive = coupling is not None and case.coupling.explicit_until_periodic
    fixed = (case.coupling.explicit_periods + 1) * n if is_coupled(case) else 0

    def per_period(results: ResultsFile) -> dict[str, list[float]]:
        tip = results.column("shell/tip_displacement_m")
        assert tip is not None  # every dynamic run records it
        series = {"tail amplitude": period_amplitudes(tip[:, 2], n)}
        thrust = results.column("fluid/thrust_n")
        if thrust is not None:
            series["mean thrust"] = period_means(thrust[:, 0], n)
        return series

    def changes_within(results: ResultsFile, limit: float) -> str | None:
        """What changed over the last two periods, if each change is within ``limit``."""
        changes = {}
        for name, values in per_period(results).items():
            if len(values) < 3:
                return None
            changes[name] = [abs(b - a) / abs(b) if b else np.inf for a, b in pairwise(values[-3:])]
            if max(changes[name]) > limit:
                return None
        return "; ".join(
            f"the {name} changed by {100 * a:.2g} % and {100 * b:.2g} %"
            for name, (a, b) in changes.items()
        )

    def rule(results: ResultsFile) -> str | None:
        rows = results.rows
        if rows == 0 or rows % n:
            return None
        if adaptive and coupling.iterate_from is None:
            said = changes_within(results, max(tolerance, EXPLICIT_SWITCH_TOLERANCE))
            if said is not None:
                coupling.iterate_from = rows  # the next window, 0-based
                if say is not None:
                    say(
                        f"periodic in its explicit windows after {rows // n} periods ({said}): "
                        f"iterating from window {rows + 1} (coupling.explicit_until_periodic)"
                    )
            return None
        first = coupling.iterate_from + n if adaptive else fixed
        if rows < first:
            return None
        said = changes_within(results, tolerance)
        if said is None:
            return None
        return (
            f"periodic after {rows // n} periods (time.periodic_tolerance = "
            f"{tolerance:g}): over the last two periods {said}"
        )

    return rule


# the tail's mean position per period flipping sign this many periods in a row while growing
# GROWTH_PERIOD_FACTOR times, in periods of one fluid solve per window, is the slow form of the
# explicit added-mass instability (explicit-am, coarse fish, 3 Hz square wave: -1.7, +4.3,
# -5.3 mm on a 13-15 mm swing). No sine or square run with iterated windows, and no explicit
# sine run at 1-15 Hz, does it (sweeps of the coarse fish).
FLIP_PERIODS = 3
GROWTH_PERIOD_FACTOR = 2.0


def explicit_growth_check(case: Case, coupling=None) -> StopRule | None:
    """In the periods whose windows take one fluid solve (explicit schemes, the explicit
    start-up periods), a CouplingDivergenceError when the tail's mean position per period
    flips sign FLIP_PERIODS times in a row, grows GROWTH_PERIOD_FACTOR times over them and
    ends above a tenth of the swing: the window-to-window check (coupling_failure) sees the
    fast form of the instability; this sees the form that grows from period to period."""
    from fsi_orchestrator.convergence import CouplingDivergenceError

    if not is_coupled(case):
        return None
    c, n = case.coupling, windows_per_period(case)
    if c.scheme.iterates and c.explicit_periods == 0 and not c.explicit_until_periodic:
        return None

    def explicit_rows() -> int | None:
        """The rows of one solve per window (None: all)."""
        if not c.scheme.iterates:
            return None
        if c.explicit_until_periodic:
            return None if coupling is None else coupling.iterate_from
        return c.explicit_periods * n

    def rule(results: ResultsFile) -> str | None:
        rows, explicit = results.rows, explicit_rows()
        if rows == 0 or rows % n or (explicit is not None and rows > explicit):
            return None
        tip = results.column("shell/tip_displacement_m")
        assert tip is not None
        periods = complete_periods(tip[:, 2], n)[-(FLIP_PERIODS + 1) :]
        if len(periods) <= FLIP_PERIODS:
            return None
        means = [float(p.mean()) for p in periods]
        swing = float(np.ptp(periods[-1]) / 2)
        flips = all(a * b < 0 for a, b in pairwise(means))
        grows = abs(means[-1]) >= GROWTH_PERIOD_FACTOR * abs(means[0])
        if flips and grows and abs(means[-1]) > 0.1 * swing:
            said = ", ".join(f"{1e3 * m:+.2f}" for m in means)
            raise CouplingDivergenceError(
                f"the tail's mean position flipped sign in each of the last {FLIP_PERIODS} "
                f"periods and grew ({said} mm on a {1e3 * swing:.1f} mm swing): one fluid "
                f'solve per window is unstable here (coupling.scheme = "{c.scheme}"); iterate '
                'the windows (coupling.scheme = "iqn-ils-am" with coupling.explicit_periods = 0 '
                "and coupling.explicit_until_periodic = false)",
                field="force",
                window=rows,
                iteration=1,
            )
        return None

    return rule


def stop_rules(*rules: StopRule | None) -> StopRule | None:
    """One rule asking each in turn; the first that says stop decides."""
    active = [r for r in rules if r is not None]
    if not active:
        return None

    def rule(results: ResultsFile) -> str | None:
        for r in active:
            said = r(results)
            if said is not None:
                return said
        return None

    return rule


def dynamic_summary(case: Case, results_path: Path) -> dict:
    with h5py.File(results_path, "r") as h5:
        t = h5["time_s"][:, 0]
        tip = h5["shell/tip_displacement_m"][:]
        newton = h5["shell/newton_iterations"][:, 0]
        wall = h5["wall_s"][:, 0]
    z, per_period = tip[:, 2], windows_per_period(case)
    last = z[-min(len(z), per_period) :]  # a run shorter than a period: all of it
    amplitudes = period_amplitudes(z, per_period)
    change = {}
    if len(amplitudes) >= 2 and amplitudes[-1] > 0:
        change = {
            "tip_amplitude_change_last_period": (amplitudes[-1] - amplitudes[-2]) / amplitudes[-1]
        }
    return {
        "tip_displacement_m": tip[-1].tolist(),
        "tip_amplitude_m": float(np.ptp(last) / 2),
        "tip_amplitude_per_period_m": amplitudes,
        **change,
        "tip_max_abs_m": float(np.abs(tip[:, 2]).max()),
        "end_time_s": float(t[-1]),
        "windows": int(len(t)),
        "mean_newton_iterations_per_window": float(newton[-1] / len(t)),
        "results": str(results_path),
        "wall_s": float(wall.sum()),
    }


def timed_factory(factory, progress: RunProgress):
    """The fluid's set-up (meshing, case files) announced with its duration."""

    def build(case: Case, solid):
        with progress.phase(f"set-up: {case.fluid.model.value} fluid (mesh, case files)"):
            return factory(case, solid)

    return build


# in a run's folder: its lead-in on the fast orbit diverged and it runs from rest (a --resume
# continues that run)
FROM_REST_MARK = "started_from_rest.txt"


def run_dynamic(
    case: Case,
    output: Path,
    resume: bool,
    show_progress: bool,
    overrides: Sequence[str] = (),
    replaces_run: bool = False,
) -> dict:
    """A transient run. Where the CFD blows up in the lead-in on the fast model's orbit
    (undamped, it can swing the plate twice as far as the coupled run: the hinged thrust rig
    at 3 Hz), the run starts again from rest with a voltage ramp, as choose_start starts one
    whose orbit moves too fast, and says so."""
    from fluid_adapter.openfoam.errors import LeadInDivergenceError

    mark = output / FROM_REST_MARK
    if not resume:
        mark.unlink(missing_ok=True)
    elif mark.is_file():
        summary = _run_dynamic(ramped_start(case), output, resume, show_progress, overrides)
        summary["start_from_rest"] = mark.read_text().strip()
        return summary
    try:
        return _run_dynamic(case, output, resume, show_progress, overrides, replaces_run)
    except LeadInDivergenceError as err:
        if resume or case.actuation.ramp_periods > 0:
            raise
        ramped = ramped_start(case)
        first = str(err).splitlines()[0]
        reason = first.split(": ", 1)[-1].split(";")[0]
        note = from_rest_note(
            case,
            ramped,
            f"the CFD diverged in the lead-in on the fast model's periodic orbit ({reason})",
        )
        print(note, file=sys.stderr)
        atomic_write(mark, note + "\n")
        summary = _run_dynamic(ramped, output, False, show_progress, overrides, True)
        summary["start_from_rest"] = note
        return summary


def _run_dynamic(
    case: Case,
    output: Path,
    resume: bool,
    show_progress: bool,
    overrides: Sequence[str] = (),
    replaces_run: bool = False,
) -> dict:
    set_up = time.perf_counter()
    provenance = run_attributes(case, overrides)  # the case as given, before a start's changes
    identity = case_identity(case)
    progress = RunProgress(show_progress, hold=True)
    start_note = None
    flow = decide_start_flow(case, output, resume)  # time.start_from's liquid, once
    if isinstance(flow, str):  # the orbit is carried over, the flow is not
        print(f"note: time.start_from: the flow starts from rest: {flow}", file=sys.stderr)
        flow = None
    if is_coupled(case):
        factory = None
        if case.fluid.model is FluidModel.OPENFOAM:
            factory = openfoam_fluid_factory(output / "openfoam", fresh=not resume, flow=flow)
            factory = timed_factory(factory, progress)
        with progress.phase("set-up: structure, start and coupling"):
            run = build_coupled_run(case, factory, resume=resume, flow=flow)
        case, solid, coupling, start_note = run.case, run.solid, run.coupling, run.start_note
        if start_note is not None:
            print(start_note, file=sys.stderr)
        added = None
    else:
        from solid_adapter.build import build_shell_participant

        fluid = (
            "" if case.fluid.model is FluidModel.NONE else f" and {case.fluid.model.value} fluid"
        )
        with progress.phase(f"set-up: structure{fluid}"):
            model, added = shell_with_fast_fluid(case, edge_inertia=True)
            recorded = None if resume else recorded_start(case, model.ndof)
            solid, coupling = build_shell_participant(case, model, recorded), None
    schedule = schedule_of(case)
    settings = OutputSettings(
        directory=output,
        vtk=case.output.vtk,
        vtk_every=case.output.vtk_every,
        checkpoint_every=case.output.checkpoint_every,
        flow_every=case.output.flow_every,
        attributes={**provenance, "dt_s": schedule.dt},
        case_identity=identity,
    )
    if replaces_run:  # --overwrite: a later --resume must not find the old checkpoint
        (output / CHECKPOINT_FILE).unlink(missing_ok=True)
        # nor the pictures find the old run's later windows (its .pvd is rewritten, its .vtu
        # files past this run's end would stay)
        shutil.rmtree(output / "vtk", ignore_errors=True)
    start = time.perf_counter()
    if coupling is not None and coupling.settings.lead_in_windows > 0 and not resume:
        progress.release()
        progress.say(
            f"lead-in: {coupling.start_up.fluid_windows} prescribed-motion fluid windows "
            "before window 1 (its time counts into window 1)"
        )
    try:
        with progress.windows(schedule.n_windows) as on_window, StopRequest().on_sigterm() as stop:
            loop = WindowLoop(
                solid,
                schedule,
                settings,
                on_window,
                coupling,
                stop_rules(
                    explicit_growth_check(case, coupling),
                    periodic_stop(case, coupling, progress.say),
                ),
                stop.reason,
            )
            path = loop.run(resume=resume)
        windows_end = time.perf_counter()
    except NewtonNotConverged as err:
        if case.time.start is not StartMode.PERIODIC:
            raise
        raise NewtonNotConverged(
            f"{err}; or start from rest (--set time.start=rest): this run started on the linear "
            "periodic orbit, which near a resonance can lie far from the large-deflection answer"
        ) from None
    finally:
        if coupling is not None:
            coupling.fluid.finalize()
    summary = dynamic_summary(case, path)
    if coupling is not None:
        if start_note is not None:
            summary["start_from_rest"] = start_note
        summary.update(coupling_summary(case, path, coupling))
        summary.update(fluid_force_summary(case, path))
    if added is not None or coupling is not None:
        # per period only where it is the run's thrust (OpenFOAM has its own per period)
        own = "mean_thrust_n" not in summary
        summary.update(thrust_estimate(case, solid, path, per_period=own))
    fast = summary.pop("fast_mean_thrust_n", None)  # the fast fluid's, with the shedding
    if "mean_thrust_n" in summary:
        summary["thrust_source"] = "openfoam"
    elif "slender_body_mean_thrust_n" in summary:
        summary["mean_thrust_n"] = summary["slender_body_mean_thrust_n"] if fast is None else fast
        summary["thrust_source"] = "slender_body"
    label_results(path, {"thrust_source": summary.get("thrust_source", "none")})
    # the recorded windows' time (every invocation's; window 1's holds the lead-in) and this
    # call's after them: a resume of a finished run keeps the run's figure, not its seconds
    summary["wall_s"] += time.perf_counter() - windows_end
    summary["setup_s"] = start - set_up
    if case.time.start_from:  # where the structure's orbit and start state came from
        summary["start_from"] = str(start_from_path(case))
        # ... and the liquid's (None: built up from rest)
        summary["start_from_flow"] = None if flow is None else str(flow.case / flow.time_name)
    if added is not None:  # the fast fluid's added mass is in the structure's equations
        summary.update(coupling_scheme="monolithic", mean_fluid_solves_per_window=1.0)
    if coupling is not None and coupling.resumed_from_scheme is not None:
        fresh = " (its accelerator started afresh)" if coupling.accelerator is not None else ""
        print(
            f'note: resumed a run saved with coupling.scheme = "{coupling.resumed_from_scheme}"'
            f' and went on with "{coupling.settings.scheme}"{fresh}',
            file=sys.stderr,
        )
    if loop.stopped is not None:
        summary["stopped_periodic"] = loop.stopped
        print(f"note: {loop.stopped}", file=sys.stderr)
    switched = None if coupling is None else coupling.iterate_from
    if case.coupling.explicit_until_periodic and (switched is None or switched >= loop.window):
        print(
            "note: coupling.explicit_until_periodic: every window took one fluid solve (the "
            "periods did not agree to 5 % before the run ended), so its figures may wander "
            "by 1-2 % from period to period; run more periods (--resume --set time.periods=N)",
            file=sys.stderr,
        )
    summary.update(periodic_summary(case, summary))
    for note in (settling_note(summary), partial_period_note(case, summary)):
        if note is not None:
            print(note, file=sys.stderr)
    return summary


def partial_period_note(case: Case, summary: dict) -> str | None:
    """A line for stderr when the run is shorter than one drive period: its mean thrust is
    then a part of a period's, not a period's mean."""
    span = summary.get("thrust_averaged_over_s")
    if span is None:
        return None
    return (
        f"note: the run is shorter than one period ({1 / case.actuation.frequency_hz:.4g} s): "
        f"its mean thrust is the mean over {span:.4g} s, not over a period; for a period's "
        "mean run at least one period (time.periods >= 1)"
    )


# a run's figures count as periodic when known to this (relative), unless
# time.periodic_tolerance says otherwise
PERIODIC_TOLERANCE = 0.01


def periodic_summary(case: Case, summary: dict) -> dict:
    """The periodic state estimated from the per-period figures (fsi_orchestrator.periodic),
    with uncertainties and whether it is known to the tolerance."""
    per_period = {"tip_amplitude": (summary["tip_amplitude_per_period_m"], "m")}
    if "mean_thrust_per_period_n" in summary:
        per_period["mean_thrust"] = (summary["mean_thrust_per_period_n"], "n")
    tolerance = case.time.periodic_tolerance or PERIODIC_TOLERANCE
    return {
        **periodic_fields(per_period, tolerance),
        "periodic_tolerance": tolerance,
        "windows_per_period": windows_per_period(case),
    }


def settling_note(summary: dict) -> str | None:
    """A line for stderr when the last period's tail amplitude is still changing: the figures
    are then a start-up's, not the periodic state's."""
    change = summary.get("tip_amplitude_change_last_period")
    if change is None or abs(change) <= SETTLED_CHANGE:
        return None
    a = summary["tip_amplitude_per_period_m"]
    thrust = summary.get("mean_thrust_per_period_n", [])
    thrust_part = (
        f", the mean thrust {thrust[-2]:.4g} -> {thrust[-1]:.4g} N" if len(thrust) >= 2 else ""
    )
    return (
        f"note: not periodic yet: over the last period the tail amplitude changed by "
        f"{100 * change:+.1f} % ({1e3 * a[-2]:.3f} -> {1e3 * a[-1]:.3f} mm){thrust_part}; "
        "for the periodic state run more periods (time.periods)"
    )


def coupling_summary(case: Case, results_path: Path, coupling) -> dict:
    with h5py.File(results_path, "r") as h5:
        solves = h5["coupling/fluid_solves"][:, 0]
        converged = h5["coupling/converged"][:, 0]
        wall = h5["wall_s"][:, 0]
        # (absent in a run resumed from an older version's results)
        fluid = h5["coupling/fluid_wall_s"][:, 0] if "coupling/fluid_wall_s" in h5 else None
        # whether a window was iterated (a resumed run may have changed its scheme)
        iterated = h5["coupling/iterated"][:, 0] > 0 if "coupling/iterated" in h5 else None
    last = slice(-min(len(solves), windows_per_period(case)), None)
    if iterated is None:
        iterated = np.array([coupling.iterates(w) for w in range(len(solves))])
    explicit = {}
    if coupling.settings.implicit and not iterated.all():  # an explicit start-up
        explicit = {
            "explicit_windows": int((~iterated).sum()),
            "iterated_fluid_solves_per_window": float(solves[iterated].mean())
            if iterated.any()
            else None,
        }
    learned = {}  # where the quasi-Newton's first Jacobian came from
    if case.coupling.jacobian_from:
        learned = {"jacobian_from": str(learned_jacobian_path(case))}

    timing = {}
    if fluid is not None and len(fluid) == len(wall):
        # the wall time outside the fluid's solves: the structure's and the coupling's
        timing = {
            "non_fluid_share": float(1 - fluid.sum() / wall.sum()),
            "last_period_non_fluid_share": float(1 - fluid[last].sum() / wall[last].sum()),
        }
    # window 0's wall time holds the fluid-only lead-in: not a coupled window's cost
    coupled_wall = wall.copy()
    coupled_wall[0] -= min(coupling.lead_in_wall_s, coupled_wall[0])
    timing["last_period_wall_s_per_window"] = float(coupled_wall[last].mean())
    prescribed = coupling.prescribed_wall_s_per_window
    if prescribed:  # the lead-in's windows are a prescribed-motion run of the same fluid
        timing["prescribed_wall_s_per_window"] = prescribed
        timing["last_period_wall_ratio_to_prescribed"] = float(
            coupled_wall[last].mean() / prescribed
        )
    start = {}
    if coupling.resumed_from_scheme is not None:
        start["resumed_from_scheme"] = coupling.resumed_from_scheme.value
    if coupling.start_fit is not None:
        start["start_correction"] = coupling.start_fit.summary(coupling.start_orbit.shape_z)
    resets = getattr(coupling.fluid, "mesh_resets", None)  # OpenFOAM's mesh put back on its path
    if resets is not None:
        # the fluid's clock runs through the lead-in, which ends at the run's t = 0
        lead_in = coupling.start_up.fluid_windows if coupling.settings.lead_in_windows else 0
        start["mesh_resets"] = [
            {"time_s": (window - lead_in) * schedule_of(case).dt, "drift_m": shift}
            for window, shift in resets
        ]
    return {
        **start,
        "coupling_scheme": coupling.settings.scheme.value,
        "mean_fluid_solves_per_window": float(solves.mean()),
        # the periodic state's cost, after the start-up windows
        "last_period_fluid_solves_per_window": float(solves[last].mean()),
        "max_fluid_solves_per_window": int(solves.max()),
        "unconverged_windows": int((converged[iterated] == 0).sum()),
        **timing,
        **explicit,
        **learned,
    }


def fluid_force_summary(case: Case, results_path: Path) -> dict:
    """Mean thrust (-F_x, eq. 3-25) and force amplitudes over the last period, where the fluid
    reports its integrated force (OpenFOAM)."""
    with h5py.File(results_path, "r") as h5:
        if "fluid/thrust_n" not in h5:
            return {}
        thrust = h5["fluid/thrust_n"][:, 0]
        force = h5["fluid/force_n"][:]
        moment = h5["fluid/moment_nm"][:] if "fluid/moment_nm" in h5 else None
    per_period = windows_per_period(case)
    last = slice(-min(len(thrust), per_period), None)
    partial = {}
    if len(thrust) < per_period:  # a run shorter than a period: the mean of what it has
        partial = {
            "thrust_averaged_over_s": len(thrust) / (per_period * case.actuation.frequency_hz)
        }
    turning = {}
    if moment is not None:  # unequal voltages on the two MFCs turn the fish (seed Sec. 4.5)
        turning = {
            "mean_lateral_force_n": float(force[last, 2].mean()),
            # about the vertical (y) axis through the nose, right-handed
            "mean_yaw_moment_nm": float(moment[last, 1].mean()),
        }
    return {
        "mean_thrust_n": float(thrust[last].mean()),
        "mean_thrust_per_period_n": period_means(thrust, windows_per_period(case)),
        "lateral_force_amplitude_n": float(np.ptp(force[last, 2]) / 2),
        **turning,
        **partial,
    }


def thrust_estimate(case: Case, solid, results_path: Path, per_period: bool = False) -> dict:
    """Slender-body (Lighthill, eq. 5-12, fixed head) mean thrust over the last period; with
    ``per_period`` (a fast fluid's run, whose thrust it is) also the fast thrust with the
    shedding efficiency (``fast_mean_thrust_n``) and it over each complete period
    (``mean_thrust_per_period_n``, aligned with the tail amplitude's per-period figures)."""
    from fluid_adapter.slender_body import mean_thrust_from_shell

    if case.time.step_s is not None:
        return {}
    with h5py.File(results_path, "r") as h5:
        t = h5["time_s"][:, 0]
        midline = h5["shell/midline_z_m"][:]
    period = 1.0 / case.actuation.frequency_hz
    partial = len(t) < windows_per_period(case)  # a run shorter than a period: its mean
    if partial:
        if len(t) < 4:  # the thrust needs time derivatives: at least 4 samples
            return {}
        period = len(t) * float(t[1] - t[0])
    xs = solid.midline_x_m

    def thrust_until(end: int, kc0: float = 0.0) -> float:  # the period ending at ``end``
        return mean_thrust_from_shell(
            xs,
            solid.model.layout.height(xs) / 2,
            t[:end],
            midline[:end],
            density_kg_m3=case.fluid.density_kg_m3,
            period_s=period,
            added_mass_coefficient=case.fluid.added_mass_coefficient,
            shedding_kc=kc0,
        )

    # the run's own thrust (a fast fluid's): with the shedding efficiency, as the linear sweep
    kc0 = case.fluid.thrust_shedding_kc
    if partial:
        return {
            "slender_body_mean_thrust_n": thrust_until(len(t)),
            "fast_mean_thrust_n": thrust_until(len(t), kc0),
            "thrust_averaged_over_s": period,
        }
    if not per_period:
        return {"slender_body_mean_thrust_n": thrust_until(len(t))}
    n = windows_per_period(case)
    ends = range(len(t) - (len(t) // n - 1) * n, len(t) + 1, n)  # complete periods, as the tail's
    thrusts = [thrust_until(end, kc0) for end in ends]
    return {
        "slender_body_mean_thrust_n": thrust_until(len(t)),
        "fast_mean_thrust_n": thrusts[-1],
        "mean_thrust_per_period_n": thrusts,
    }


def static_summary(case: Case) -> dict:
    from solid_adapter.build import run_static

    res = run_static(case)
    return {
        "tip_displacement_m": res.tip_displacement_m.tolist(),
        "load_steps": case.analysis.load_steps,
    }


def execute(
    case: Case,
    output: Path,
    resume: bool,
    overwrite: bool,
    show_progress: bool,
    overrides: Sequence[str] = (),
) -> dict:
    """Run a case of any analysis kind; its summary (fsi-run, fsi_orchestrator.run)."""
    kind = case.analysis.kind
    if kind is AnalysisKind.MODAL:
        return modal_summary(case, RunProgress(enabled=show_progress))
    if kind is AnalysisKind.STATIC:
        return static_summary(case)
    if kind is AnalysisKind.SWIMMING and case.fluid.model is FluidModel.OPENFOAM:
        from .flume import flume_summary

        def say(line: str) -> None:
            if show_progress:
                print(line, file=sys.stderr, flush=True)

        return flume_summary(case, output, say)
    if kind is AnalysisKind.SWIMMING:
        return swimming_summary(case)
    replaces = prepare_output(output, resume, overwrite)
    summary = run_dynamic(
        case, output, resume, show_progress, overrides=overrides, replaces_run=replaces
    )
    check_finite(Path(summary["results"]), summary)
    return summary


RUN_SUMMARY_FILE = "summary.json"


def _body(args: argparse.Namespace) -> int:
    case = load(args)
    output = output_folder(args.output, case.directory / "output")
    # a dynamic run keeps its summary beside results.h5; another kind only where --output
    # asks for a folder (a modal or static case's answer is the summary alone)
    keep = args.output is not None or case.analysis.kind is AnalysisKind.DYNAMIC
    replaced: list[str] = []
    if keep and case.analysis.kind is not AnalysisKind.DYNAMIC:
        replaced = _refuse_an_earlier_run(output, case.analysis.kind, args)
    earlier = _stamp(output / CHECKPOINT_FILE)  # an earlier run's checkpoint, if any
    try:
        summary = execute(case, output, args.resume, args.overwrite, not args.quiet, args.overrides)
    except KeyboardInterrupt as err:
        from fsi_orchestrator.participant import ParticipantStopped

        dynamic = case.analysis.kind is AnalysisKind.DYNAMIC
        if dynamic and str(err) and not isinstance(err, ParticipantStopped):
            raise  # the window loop's own word: what it checkpointed
        kept = _what_an_interrupt_keeps(case, output, resumed=args.resume, earlier=earlier)
        raise KeyboardInterrupt(f"{err}; {kept}" if str(err) else kept) from None
    emit(summary, args.json)
    for name in replaced:  # a dynamic run's files, which this summary does not describe
        path = output / name
        shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
    if keep:
        path = output / RUN_SUMMARY_FILE
        try:
            atomic_write(path, json_text(summary, indent=1))
        except OSError as err:  # the summary is printed; the results are on disk
            kept = "it is printed above" + (
                f" and the results are in {summary['results']}" if "results" in summary else ""
            )
            raise RuntimeError(
                f"{path}: cannot write the summary ({err.strerror or err}); {kept}"
            ) from None
    return EXIT_OK


def _refuse_an_earlier_run(output: Path, kind: AnalysisKind, args: argparse.Namespace) -> list[str]:
    """A modal, static or swimming run's --output, before the work, as a dynamic run's is: a
    folder it cannot write, or one holding an earlier run without --overwrite, is refused in
    one line. Such a run has no checkpoint to --resume. Returns the earlier dynamic run's
    files that --overwrite replaces (removed once the new summary is computed)."""
    from .flume import FLUME_FILE

    if args.resume:
        raise CaseError(
            f"--resume: a {kind.value} run keeps no checkpoint to continue; run it again "
            "(with --overwrite to replace its --output)"
        )
    held = open_run_folder(
        output, (RUN_SUMMARY_FILE, RESULTS_FILE, CHECKPOINT_FILE, FLUME_FILE, "vtk")
    )
    if held and not args.overwrite:
        raise CaseError(
            f"--output {output}: holds an earlier run ({', '.join(held)}); write elsewhere "
            "with --output, or replace it with --overwrite"
        )
    refuse_unwritable(output, (RUN_SUMMARY_FILE,))
    return [n for n in (RESULTS_FILE, CHECKPOINT_FILE, "vtk") if n in held]


def _stamp(path: Path) -> int | None:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return None


def _what_an_interrupt_keeps(
    case: Case, output: Path, *, resumed: bool, earlier: int | None
) -> str:
    """What a Ctrl-C outside the windows leaves. A modal, static or swimming run writes nothing
    until its answer (a flume, its OpenFOAM case); a dynamic run keeps its last checkpoint if
    this run wrote one or continued one (an --overwrite stopped in its set-up leaves the
    earlier run as it was)."""
    if case.analysis.kind is not AnalysisKind.DYNAMIC:
        if (output / "fluid").is_dir() and case.fluid.model is FluidModel.OPENFOAM:
            return (
                f"no forces were written ({output / 'fluid'} holds the flume so far); run it again"
            )
        return "nothing was written; run it again"
    now = _stamp(output / CHECKPOINT_FILE)
    if now is not None and (resumed or now != earlier):  # continued, or written by this run
        return "the results up to the last checkpoint are kept; continue with --resume"
    if now is not None:
        return (
            "stopped before this run's first checkpoint; the earlier run in the folder is as "
            "it was: run it again with --overwrite to replace it"
        )
    return "stopped before the first checkpoint: nothing to resume; run it again"


# a Ctrl-C outside the windows (or a second one); SIGTERM or a first Ctrl-C in the windows
# ends the window with a checkpoint and says so
INTERRUPTED = (
    "the results up to the last checkpoint are kept; continue with --resume (a run stopped "
    "before its first checkpoint has none: run it again)"
)


def main(argv: Sequence[str] | None = None) -> int:
    parser = base_parser("fsi-run", "Run a case: structure alone or coupled with a fluid.")
    parser.add_argument("--output", help="output folder (default: CASE/output)")
    earlier = parser.add_mutually_exclusive_group()
    earlier.add_argument(
        "--resume", action="store_true", help="continue a killed run from its last checkpoint"
    )
    earlier.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the run an existing --output holds (without it, such a folder is refused)",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="no progress (set-up phases, window lines, bar)"
    )
    return run_main(_body, parser, argv, interrupted=INTERRUPTED)


if __name__ == "__main__":
    raise SystemExit(main())
