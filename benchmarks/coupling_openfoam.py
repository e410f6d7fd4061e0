"""Coupling schemes side by side on the fixed-head fish with the real OpenFOAM (issue 5's
benchmark): fluid solves per window, wall time, the coupled / prescribed-motion wall-time
ratio, the non-fluid share of the wall time, and the tail amplitude / force difference to a
tightly converged reference run.

All runs share one generated mesh (copied), the same fluid-only lead-in onto the periodic orbit
(timed separately: it *is* a prescribed-motion run of the same windows, one fluid solve each),
then ``--windows`` coupled windows at 3 Hz: the start-up, where the flow is still developing.

``--from-run DIR`` starts every scheme instead from the checkpoint of a finished ``fsi-run``
of this case (its output folder, run at the same ``--level`` and ``--mesh-scale``), e.g. one
run on to its periodic state; each scheme goes on from a copy of its OpenFOAM case. The
prescribed-motion cost is then the reference's windows replayed through the fluid alone in this
run, and a scheme other than the run's starts
its accelerator afresh (``fsi-run --resume`` with another ``coupling.scheme`` does the same).

    .venv/bin/python benchmarks/coupling_openfoam.py [--level coarse] [--mesh-scale 1.5]
        [--windows 10] [--schemes iqn-ils-am,explicit-am,...] [--from-run DIR] [--json]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.compose import coupled_setup, openfoam_fluid_factory  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from fsi_orchestrator.case.timing import case_schedule  # noqa: E402
from fsi_orchestrator.convergence import CouplingDivergenceError  # noqa: E402
from fsi_orchestrator.loop import load_checkpoint  # noqa: E402
from fsi_orchestrator.results import CHECKPOINT_FILE, read_checkpoint  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# scheme -> extra case overrides; "reference" is the tightly converged run
RUNS = {
    "reference": [
        "coupling.scheme=iqn-ils-am",
        "coupling.tolerance_rel=1e-7",
        "coupling.max_iterations=40",
    ],
    "constant": [
        "coupling.scheme=constant",
        "coupling.relaxation=0.02",
        "coupling.max_iterations=40",
    ],
    "aitken": ["coupling.scheme=aitken", "coupling.relaxation=0.02", "coupling.max_iterations=40"],
    "iqn-ils": [
        "coupling.scheme=iqn-ils",
        "coupling.relaxation=0.02",
        "coupling.max_iterations=40",
    ],
    "iqn-ils-am": ["coupling.scheme=iqn-ils-am"],
    # the accuracy a looser tolerance buys back (difference to the reference below)
    "iqn-ils-am-1e-3": ["coupling.scheme=iqn-ils-am", "coupling.tolerance_rel=1e-3"],
    "explicit-am": ["coupling.scheme=explicit-am"],
    # the structure factoring a fresh tangent every Newton iteration (no kept tangent)
    "iqn-ils-am-fresh-tangent": ["coupling.scheme=iqn-ils-am", "analysis.reuse_tangent=false"],
    "explicit-am-fresh-tangent": ["coupling.scheme=explicit-am", "analysis.reuse_tangent=false"],
    # the case's driver keeps pimpleFoam loaded (persistent); with one launch per solve instead
    "iqn-ils-am-relaunch": ["coupling.scheme=iqn-ils-am", "fluid.driver=relaunch"],
    "explicit-am-relaunch": ["coupling.scheme=explicit-am", "fluid.driver=relaunch"],
}


def set_up(name: str, overrides: list[str], folder: Path, start: Path | None, windows: int):
    """(case, structure, coupling, first window) after the lead-in or from ``start``, for
    ``windows`` more windows."""
    overrides = overrides + RUNS[name]
    if start is not None:  # the fluid plans its windows: the checkpoint's and these
        done = int(read_checkpoint(start)[0]["window"])
        steps = load_case(ROOT / "cases" / "fixed_head_3Hz", overrides).time.steps_per_period
        overrides = [*overrides, f"time.periods={(done + windows) / steps + 1:g}"]
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", overrides)
    solid, coupling = coupled_setup(case, openfoam_fluid_factory(folder, fresh=False))
    if start is None:  # prescribed motion: the fluid's cost per window alone
        coupling.lead_in(solid, window_s(case))
        return case, solid, coupling, 1  # window 0 would hold the lead-in, done here apart
    return case, solid, coupling, load_checkpoint(start, solid, coupling)


def window_s(case) -> float:
    return case_schedule(case)[0]


def copy_case(template: Path, folder: Path) -> None:
    """A scheme's own OpenFOAM case (a killed run may have left the persistent driver's named
    pipes behind: not copied)."""
    shutil.copytree(template, folder, symlinks=True, ignore=shutil.ignore_patterns("*.fifo*"))


def one_run(
    name: str, overrides: list[str], windows: int, folder: Path, start: Path | None = None
) -> dict:
    """``windows`` coupled windows after the lead-in, or after the checkpoint ``start``."""
    case, solid, coupling, first = set_up(name, overrides, folder, start, windows)
    fluid, dt = coupling.fluid, window_s(case)
    prescribed_s = coupling.prescribed_wall_s_per_window
    fluid_time = 0.0
    solves, tips, forces, thrusts, motions = [], [], [], [], []
    t0 = time.perf_counter()
    status = "ok"
    try:
        for w in range(windows):
            stats = coupling.solve_window(solid, dt, first + w)
            solves.append(stats["coupling/fluid_solves"])
            fluid_time += stats["coupling/fluid_wall_s"]
            tips.append(solid.monitor()["tip_displacement_m"][2])
            forces.append(fluid.monitor()["force_n"][2])
            thrusts.append(fluid.monitor()["thrust_n"])
            # the converged interface motion, for a prescribed-motion replay of these windows
            motion = solid.write_data()
            motions.append({k: coupling.mapping.consistent(v) for k, v in motion.items()})
    except CouplingDivergenceError as err:
        status = f"diverged at window {err.window}: {err}"
    finally:
        fluid.finalize()
    wall = time.perf_counter() - t0
    n = max(1, len(solves))
    return {
        "scheme": name,
        "status": status,
        "mean_solves": float(np.mean(solves)) if solves else float("nan"),
        "wall_s_per_window": wall / n,
        "prescribed_s_per_window": prescribed_s,
        "ratio_to_prescribed": wall / n / prescribed_s,
        "non_fluid_share": 1 - fluid_time / wall if wall else float("nan"),
        "tip_m": tips,
        "thrust_n": thrusts,
        "motions": motions,
        "force_z_n": forces,
    }


def prescribed_run(overrides: list[str], folder: Path, start: Path, motions: list[dict]) -> float:
    """Seconds per window of the fluid alone moved through ``motions`` from ``start``: the
    prescribed-motion CFD run of the same windows (one fluid step each)."""
    case, _, coupling, _ = set_up("explicit-am", overrides, folder, start, len(motions))
    fluid, dt = coupling.fluid, window_s(case)
    t0 = time.perf_counter()
    try:
        for motion in motions:
            fluid.read_data(motion)
            fluid.solve(dt)
    finally:
        fluid.finalize()
    return (time.perf_counter() - t0) / len(motions)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", default="coarse")
    ap.add_argument("--mesh-scale", type=float, default=1.5)
    ap.add_argument("--windows", type=int, default=10)
    ap.add_argument("--schemes", default=",".join(RUNS))
    ap.add_argument("--from-run", type=Path, help="start from this fsi-run output's checkpoint")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    overrides = [f"fluid.mesh_level={args.level}", f"fluid.mesh_scale={args.mesh_scale}"]
    base = Path(tempfile.mkdtemp(prefix="fishfsi-bench-"))
    base.chmod(0o755)
    start = None
    if args.from_run is not None:
        template, start = args.from_run / "openfoam", args.from_run / CHECKPOINT_FILE
    else:  # generate the mesh once (a throw-away build), then copy it per run
        template = base / "template"
        case = load_case(ROOT / "cases" / "fixed_head_3Hz", overrides)
        openfoam_fluid_factory(template, fresh=True)(case, None).finalize()
    rows = []
    for name in args.schemes.split(","):
        folder = base / name
        copy_case(template, folder)
        try:
            rows.append(one_run(name, overrides, args.windows, folder, start))
        except RuntimeError as err:  # e.g. a checkpoint that does not fit: the others go on
            print(f"{name:20s} failed: {err}", flush=True)
            continue
        r = rows[-1]
        print(
            f"{name:20s} {r['status']:24s} solves/window {r['mean_solves']:5.2f}  "
            f"{r['wall_s_per_window']:6.2f} s/window  x{r['ratio_to_prescribed']:5.2f} of "
            f"prescribed  non-fluid {100 * r['non_fluid_share']:4.1f} %",
            flush=True,
        )
    ref = next((r for r in rows if r["scheme"] == "reference"), None)
    if start is not None and ref is not None and ref["motions"]:
        # the checkpoint's lead-in cost was measured in another run; replay the reference's
        # windows as prescribed motion here, in this run
        folder = base / "prescribed"
        copy_case(template, folder)
        prescribed = prescribed_run(overrides, folder, start, ref["motions"])
        print(f"prescribed motion (the reference's windows replayed): {prescribed:.2f} s/window")
        for r in rows:
            r["prescribed_s_per_window"] = prescribed
            r["ratio_to_prescribed"] = r["wall_s_per_window"] / prescribed
            print(f"{r['scheme']:20s} x{r['ratio_to_prescribed']:5.2f} of prescribed (replayed)")
    if ref is not None and ref["tip_m"]:
        for r in rows:
            k = min(len(r["tip_m"]), len(ref["tip_m"]))
            if k:
                tip = np.abs(np.subtract(r["tip_m"][:k], ref["tip_m"][:k])).max()
                force = np.abs(np.subtract(r["force_z_n"][:k], ref["force_z_n"][:k])).max()
                r["tip_error_m"] = float(tip)
                r["force_error_rel"] = float(force / np.abs(ref["force_z_n"][:k]).max())
                ref_thrust = np.mean(ref["thrust_n"][:k])
                r["thrust_error_rel"] = float(abs(np.mean(r["thrust_n"][:k]) - ref_thrust))
                r["thrust_error_rel"] /= abs(ref_thrust)
                print(
                    f"{r['scheme']:20s} tip diff {tip * 1e3:.4f} mm  "
                    f"Fz diff {100 * r['force_error_rel']:.3f} % of max  "
                    f"mean thrust diff {100 * r['thrust_error_rel']:.3f} %"
                )
    if args.json:
        print(json.dumps([{k: v for k, v in r.items() if k != "motions"} for r in rows]))
    shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
