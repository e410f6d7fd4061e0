"""Cost of building and applying the interface mapping at the fish's sizes.

Structure: the shell's 9-node mid-surface nodes of the original fish (coarse/default/fine mesh).
Fluid: a stand-in for an OpenFOAM plate patch, points on both faces (z = +-0.4 mm) inside the
outline plus the outline itself, about 2500 to 20000 points. Also prints the max error of a
quadratic field (a bending-like shape) and the dense global-RBF apply time for comparison.

    .venv/bin/python benchmarks/mapping_cost.py
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from fsi_orchestrator.case.loader import load_case
from fsi_orchestrator.case.schema import MeshLevel
from fsi_orchestrator.mapping import InterfaceMapping
from solid_adapter.geometry import build_layout
from solid_adapter.mesh import build_mesh

CASE = Path(__file__).resolve().parents[1] / "cases" / "fixed_head_3Hz"


def fluid_points(layout, n_target: int, seed: int = 0) -> np.ndarray:
    """(n, 2) plate-plane points of both faces (each face's points repeated) and the outline."""
    rng = np.random.default_rng(seed)
    n_face = int(0.45 * n_target)
    x = rng.uniform(0.0, layout.length_m, n_face)
    y = rng.uniform(-0.5, 0.5, n_face) * layout.height(x)
    xe = np.linspace(0.0, layout.length_m, (n_target - 2 * n_face) // 2)
    he = layout.height(xe) / 2
    face = np.column_stack([x, y])
    edge = np.column_stack([np.r_[xe, xe], np.r_[he, -he]])
    return np.vstack([face, face, edge])


def best_time(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        times.append((time.perf_counter() - t0) / repeat)
    return min(times)


def bending(xy: np.ndarray, length: float) -> np.ndarray:
    return (xy[:, 0] / length) ** 2 + 0.3 * (xy[:, 0] / length) * (xy[:, 1] / length)


def row(level: MeshLevel, layout, src: np.ndarray, n_target: int) -> str:
    tgt = fluid_points(layout, n_target)
    t0 = time.perf_counter()
    mapping = InterfaceMapping.from_points(src, tgt)
    build_ms = (time.perf_counter() - t0) * 1e3
    u = np.ones((len(src), 3))
    f = np.ones((len(tgt), 3))
    cons_us = best_time(lambda: mapping.consistent(u), 200) * 1e6
    csv_us = best_time(lambda: mapping.conservative(f), 200) * 1e6
    dense_us = float("nan")
    if n_target <= 5000:  # the dense matrix of 20000 points would take 200 MB
        dense = mapping.matrix.toarray()
        dense_us = best_time(lambda: dense @ u, 20) * 1e6
    err = np.abs(mapping.consistent(bending(src, layout.length_m)) - bending(tgt, layout.length_m))
    nnz_row = mapping.matrix.nnz / len(tgt)
    return (
        f"{level.value:>8} {len(src):>5} {len(tgt):>6} {nnz_row:>7.1f} {build_ms:>9.0f} "
        f"{cons_us:>10.0f} {csv_us:>10.0f} {dense_us:>9.0f} {err.max():>9.1e}"
    )


def main() -> None:
    layout = build_layout(load_case(CASE))
    print(
        f"{'mesh':>8} {'n_s':>5} {'n_t':>6} {'nnz/row':>7} {'build_ms':>9} "
        f"{'consist_us':>10} {'conserv_us':>10} {'dense_us':>9} {'quad_err':>9}"
    )
    for level in MeshLevel:
        src = build_mesh(layout, level).nodes
        for n_target in (2500, 5000, 20000):
            print(row(level, layout, src, n_target))
    print("apply: (n, 3) float64 data; dense_us: the same matrix as a dense array (a global RBF)")


if __name__ == "__main__":
    main()
