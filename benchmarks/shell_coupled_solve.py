"""Cost of the structure's side of a coupling iteration (issue 5: non-fluid share <= 10 %).

With an *-am scheme the shell carries the dense fluid added mass on its normal DOFs, so every
Newton iteration factors a tangent with a dense 450 x 450 block. Measured here, in one run:
1. one factorisation of that tangent: SuperLU's default (COLAMD, partial pivoting) against
   solid_adapter.solvers.factorize (minimum degree on A^T + A, diagonal pivots);
2. a partitioned fixed_head_3Hz run with the potential fluid (iqn-ils-am): Newton iterations and
   wall time per structural solve, the first solve of a window (cold start) against the
   re-solves that start from the previous coupling iteration's answer.

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

from fsi_orchestrator.case.loader import load_case  # noqa: E402
from fsi_orchestrator.cli.compose import coupled_setup  # noqa: E402
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

    # 2. structural solves inside a coupled run
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
    for w in range(args.windows):
        state["first"] = True
        coupling.solve_window(solid, dt, w)
    for first, label in ((True, "first solve of a window"), (False, "re-solves (warm start)")):
        rows = [r for r in records if r[0] is first]
        if rows:
            print(
                f"  {label:24s} {len(rows):3d} solves, {np.mean([r[1] for r in rows]):.2f} Newton "
                f"iterations, {np.mean([r[2] for r in rows]):.3f} s each"
            )


if __name__ == "__main__":
    main()
