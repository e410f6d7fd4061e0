"""Shell mesh levels: error against a much finer mesh versus wall time.

(a) strip under a large tip force (PL^2/EI = 4; reference: the elastica by shooting),
(b) the original fish's first free-free vacuum mode (reference: 96 x 24 elements).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fsi_orchestrator.case.loader import case_from_dict  # noqa: E402
from solid_adapter.build import build_shell_model, run_static  # noqa: E402
from solid_adapter.solvers import modal_analysis  # noqa: E402
from tests.test_shell_statics import elastica_tip  # noqa: E402


def strip(nx: int) -> tuple[float, float]:
    case = case_from_dict(
        {
            "geometry": {"kind": "rectangle", "length_m": 10.0, "width_m": 1.0, "thickness_m": 0.1},
            "material": {"youngs_modulus_pa": 1.2e6, "poisson_ratio": 0.0, "density_kg_m3": 1.0},
            "loads": {"tip_force_n": 4.0},
            "analysis": {"kind": "static", "load_steps": 10},
            "mesh": {"elements_length": nx, "elements_width": 1},
        },
        Path("."),
    )
    start = time.perf_counter()
    w = run_static(case).tip_displacement_m[2]
    return w, time.perf_counter() - start


def fish(nx: int, ny: int) -> tuple[float, float, int]:
    case = case_from_dict(
        {
            "geometry": {"kind": "fish"},
            "material": {"cfrp": "acoustic"},
            "boundary": {"head": "free"},
            "analysis": {"kind": "modal"},
            "mesh": {"elements_length": nx, "elements_width": ny},
        },
        Path("."),
    )
    start = time.perf_counter()
    model = build_shell_model(case)
    f1 = modal_analysis(model, 1).frequencies_hz[0]
    return f1, time.perf_counter() - start, model.ndof


def main() -> None:
    w_ref = elastica_tip(4.0 / 100.0, 10.0)[1]
    print("(a) strip, PL^2/EI = 4, tip deflection vs elastica", f"{w_ref:.5f}")
    print(f"{'elements':>9} {'error %':>9} {'time s':>8}")
    for nx in (2, 4, 6, 10, 20, 40):
        w, t = strip(nx)
        print(f"{nx:>9} {100 * (w / w_ref - 1):9.4f} {t:8.3f}")
    f_ref, _, n_ref = fish(96, 24)
    print(f"(b) fish free-free f1 vs 96 x 24 ({n_ref} dofs): {f_ref:.4f} Hz")
    print(f"{'mesh':>9} {'dofs':>6} {'f1 Hz':>8} {'error %':>9} {'time s':>8}")
    for nx, ny in ((8, 2), (12, 4), (16, 4), (24, 6), (32, 8), (48, 12)):
        f1, t, ndof = fish(nx, ny)
        print(f"{nx:>4} x {ny:<2} {ndof:6d} {f1:8.4f} {100 * (f1 / f_ref - 1):9.4f} {t:8.3f}")


if __name__ == "__main__":
    main()
