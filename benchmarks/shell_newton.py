"""One dynamic Newton iteration on the fish: cost per mesh level and the discretisation error
of the tail displacement it buys (quasi-static bimorph bending at +1500/-500 V, reference 72 x 16
elements). Target: <= 0.1 s per iteration at <= 0.5 % error on the default mesh."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fsi_orchestrator.case.loader import case_from_dict  # noqa: E402
from solid_adapter.build import build_shell_model, run_static  # noqa: E402
from solid_adapter.solvers import solve_linear  # noqa: E402


def case_for(nx: int, ny: int):
    return case_from_dict(
        {
            "geometry": {"kind": "fish"},
            "analysis": {"kind": "static", "load_steps": 2},
            "actuation": {"static_volts": [1500.0, -500.0]},
            "mesh": {"elements_length": nx, "elements_width": ny},
        },
        Path("."),
    )


def iteration_cost(nx: int, ny: int, repeats: int = 5) -> tuple[float, float, int]:
    case = case_for(nx, ny)
    model = build_shell_model(case)
    x = run_static(case, model).x
    volts = np.array([1500.0, -500.0])
    dt = 1 / 120
    model.internal(x, volts)  # warm-up
    start = time.perf_counter()
    for _ in range(repeats):
        r, K, _ = model.internal(x, volts)
        solve_linear(4 / dt**2 * model.inertia + K, -r, model.free_dofs)
    elapsed = (time.perf_counter() - start) / repeats
    return elapsed, run_static(case, model).tip_displacement_m[2], model.ndof


def main() -> None:
    _, w_ref, n_ref = iteration_cost(72, 16, repeats=1)
    print(f"reference 72 x 16 ({n_ref} dofs): tail deflection {1e3 * w_ref:.4f} mm")
    print(f"{'mesh':>9} {'dofs':>6} {'s/iteration':>12} {'error %':>9}")
    for nx, ny in ((8, 2), (12, 4), (16, 4), (24, 6), (32, 8)):
        t, w, ndof = iteration_cost(nx, ny)
        print(f"{nx:>4} x {ny:<2} {ndof:6d} {t:12.4f} {100 * (w / w_ref - 1):9.4f}")


if __name__ == "__main__":
    main()
