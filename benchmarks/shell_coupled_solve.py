"""Cost of the structure's side of a coupling iteration (issue 5: non-fluid share <= 10 %).

With an *-am scheme the shell carries the dense fluid added mass on its normal DOFs, so every
Newton iteration factors a tangent with a dense 450 x 450 block. Measured here, in one run:
1. one factorisation of that tangent: SuperLU's default (COLAMD, partial pivoting) against
   solid_adapter.solvers.factorize (minimum degree on A^T + A, diagonal pivots);
2. a partitioned fixed_head_3Hz run with the potential fluid (iqn-ils-am): Newton iterations and
   wall time per structural solve, the first solve of a window (cold start) against the
   re-solves that start from the previous coupling iteration's answer; with a fresh tangent
   every Newton iteration (analysis.reuse_tangent = false) and with modified Newton on the
   kept tangent (true), and the difference of the two runs' tail-tip histories.

    .venv/bin/python benchmarks/shell_coupled_solve.py [--windows 12]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.compose import coupled_setup  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from solid_adapter.solvers import factorize  # noqa: E402

CASE = Path(__file__).resolve().parents[1] / "cases" / "fixed_head_3Hz"


def best_of(fn, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=12)
    args = parser.parse_args()
    case = load_case(CASE, ["fluid.model=potential", "coupling.partitioned=true"])
    solid, coupling = coupled_setup(case)
    model, dt = solid.model, 1.0 / (case.actuation.frequency_hz * case.time.steps_per_period)

    # 1. one factorisation of a dynamic tangent (inertia with the added mass + K at rest)
    K = model.internal(model.zero_state(), np.zeros(2))[1]
    tangent = (1 / (0.25 * dt * dt)) * model.inertia + K
    free = model.free_dofs
    A = sp.csc_matrix(tangent[free][:, free])
    default = best_of(lambda: spla.splu(A))
    fast = best_of(lambda: factorize(A))
    print(f"tangent {A.shape[0]} DOFs, {A.nnz} entries (dense added-mass block)")
    print(f"  factorise: SuperLU default {default * 1e3:.1f} ms, factorize {fast * 1e3:.1f} ms")

    # 2. structural solves inside a coupled run, with and without the kept tangent
    tips = {reuse: coupled_solves(args.windows, reuse) for reuse in (False, True)}
    difference = np.max(np.abs(tips[True] - tips[False])) / np.max(np.abs(tips[False]))
    print(f"  tail-tip history with / without the kept tangent: max difference {difference:.1e}")


def coupled_solves(windows: int, reuse: bool) -> np.ndarray:
    """Newton iterations and seconds per structural solve; returns the tail-tip z history."""
    case = load_case(
        CASE,
        [
            "fluid.model=potential",
            "coupling.partitioned=true",
            f"analysis.reuse_tangent={'true' if reuse else 'false'}",
        ],
    )
    solid, coupling = coupled_setup(case)
    dt = 1.0 / (case.actuation.frequency_hz * case.time.steps_per_period)
    records = []  # (first solve of the window?, Newton iterations, seconds)
    solve = solid.solve
    state = {"first": True}

    def timed(step):
        before = solid.integrator.newton_iterations
        start = time.perf_counter()
        solve(step)
        records.append(
            (
                state["first"],
                solid.integrator.newton_iterations - before,
                time.perf_counter() - start,
            )
        )
        state["first"] = False

    solid.solve = timed
    tip = []
    for w in range(windows):
        state["first"] = True
        coupling.solve_window(solid, dt, w)
        tip.append(solid.monitor()["tip_displacement_m"][2])
    print(f"  analysis.reuse_tangent = {str(reuse).lower()}:")
    for first, label in ((True, "first solve of a window"), (False, "re-solves (warm start)")):
        rows = [r for r in records if r[0] is first]
        if rows:
            print(
                f"    {label:24s} {len(rows):3d} solves, {np.mean([r[1] for r in rows]):.2f} "
                f"Newton iterations, {np.mean([r[2] for r in rows]):.3f} s each"
            )
    return np.array(tip)


if __name__ == "__main__":
    main()
