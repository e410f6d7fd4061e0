"""``fsi-modal CASE``: mode frequencies in vacuum (dry) and, with a fluid model, in the liquid
(potential flow; an OpenFOAM case is analysed with the potential model in its tank)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence

from .common import EXIT_OK, base_parser, emit, load, run_main
from .fast_model import shell_with_fast_fluid, without_cfd
from .progress import RunProgress


def modal_summary(
    case,
    progress: RunProgress | None = None,
    at_mean_voltage: bool = True,
    refuse_a_buckling_mean: bool = False,
) -> dict:
    """fsi-modal's summary. ``at_mean_voltage``: with the wet modes about the static state
    under the drive's mean voltages (a static solve more), which a design study skips unless
    it asks for them; ``refuse_a_buckling_mean``: a mean that buckles the plate is then
    CaseError (a design's infeasibility) instead of a null."""
    from solid_adapter.buckling import check_mean_voltage, mean_voltage_buckling_factor
    from solid_adapter.build import has_actuators
    from solid_adapter.piezo import DriveSignal
    from solid_adapter.solvers import modal_analysis, mode_kind

    progress = progress or RunProgress(enabled=False)
    start = time.perf_counter()
    case = without_cfd(case)
    wet_part = (
        "" if case.fluid.model.value == "none" else f" and {case.fluid.model.value} added mass"
    )
    with progress.phase(f"set-up: structure{wet_part}"):
        model, added = shell_with_fast_fluid(case)
    n = case.analysis.num_modes

    def modes(result) -> tuple[list[float], list[str]]:
        return (result.frequencies_hz.tolist(), [mode_kind(model, s) for s in result.shapes])

    wet = driven = None
    drive = DriveSignal.from_case(case) if has_actuators(case) else None
    factor = float("inf")
    if drive is not None:
        # the load factor at which the drive's mean voltage buckles the flat plate (> 1: held)
        with progress.phase("mean-voltage buckling factor"):
            factor = mean_voltage_buckling_factor(model, drive.mean)
    driving = at_mean_voltage and drive is not None and added is not None
    if drive is not None and driving and factor < 1.0 and refuse_a_buckling_mean:
        check_mean_voltage(model, drive.mean)  # its one line
    if added is not None:
        with progress.phase(f"wet modes ({n})"):
            wet = modal_analysis(model, n)
        if driving and factor >= 1.0:
            with progress.phase("wet modes about the mean voltages' equilibrium"):
                driven = wet_modes_about_mean_voltage(case, model, drive, n, wet)
    model.set_added_mass(None)
    summary: dict = {}
    with progress.phase(f"dry modes ({n})"):
        summary["dry_hz"], summary["dry_kinds"] = modes(modal_analysis(model, n))
    if wet is not None:
        summary["wet_hz"], summary["wet_kinds"] = modes(wet)
        # a driven robot's modes (what a camera sees while it swims): the mean voltages'
        # prestress lowers them where it nears buckling (null: the mean buckles the plate)
        if drive is None:
            driven = wet
        if drive is None or at_mean_voltage:
            hz, kinds = modes(driven) if driven is not None else (None, None)
            summary["wet_hz_at_mean_voltage"], summary["wet_kinds_at_mean_voltage"] = hz, kinds
        summary["added_mass_kg"] = added.total()
        summary["plate_mass_kg"] = model.total_mass_kg()
        summary["fluid_nodes"] = added.n_fluid_nodes
    if drive is not None:
        # (null: the mean prestress does not buckle it at any factor)
        summary["mean_voltage_buckling_factor"] = factor if factor < float("inf") else None
    summary["wall_s"] = time.perf_counter() - start
    return summary


def wet_modes_about_mean_voltage(case, model, drive, n: int, flat=None):
    """The wet modes about the static state under the drive's mean voltages and the case's
    static loads, with their prestress; the flat plate's (``flat``, if already solved) where
    both are zero."""
    import numpy as np

    from solid_adapter.build import mean_voltage_equilibrium, static_loads
    from solid_adapter.harmonic import mean_voltage_tangent
    from solid_adapter.solvers import modal_analysis

    loads = static_loads(case, model)
    if not np.any(drive.mean) and not np.any(loads.edge) and loads.pressure_pa == 0:
        return flat if flat is not None else modal_analysis(model, n)
    x_static = mean_voltage_equilibrium(case, model, drive, loads)
    return modal_analysis(model, n, stiffness=mean_voltage_tangent(model, x_static, drive))


def _body(args: argparse.Namespace) -> int:
    emit(modal_summary(load(args, static=False), RunProgress(enabled=not args.quiet)), args.json)
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    parser = base_parser("fsi-modal", "Mode frequencies of the plate (dry; wet with a fluid).")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    return run_main(_body, parser, argv, interrupted="nothing was written; run it again")


if __name__ == "__main__":
    raise SystemExit(main())
