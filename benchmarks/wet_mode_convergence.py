"""First wet bending mode of the seed's three robots (free, potential flow in the tank) as the
meshes are refined, extrapolated to zero size, and what the converged figure makes of the
optimized robots' predictions once the original fish is recalibrated to its measured 6 Hz.

The liquid's element size along the plate's outline (the pressure jump's square-root
singularity) is what converges slowest: it is halved twice from the default level's, at the
default shell level, and the sequence is extrapolated (Richardson, with the observed ratio of
successive changes). The shell's own refinement is then measured once, on the finest-but-one
outline: the fine shell level against the default. (On the coarse liquid level a finer shell
also refines the liquid along the outline, since the liquid is meshed on the shell's outline
polygon; there the two cannot be told apart.)

The validation fits the CFRP modulus so that the original fish's first mode is 6 Hz (Table
4.2) on the default shell and coarse liquid levels; a modulus scales every robot's modes
alike, so the prediction on converged meshes is a robot's converged mode times 6 Hz over the
original fish's.

    .venv/bin/python benchmarks/wet_mode_convergence.py [--json]

Takes about 20 min on 2 cores.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import fluid_adapter.potential as potential  # noqa: E402
from fishfsi.cli.modal import modal_summary  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402
from fsi_orchestrator.case.schema import MeshLevel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = {  # case folder, measured first mode [Hz] (Tables 4.2, 5.3, 5.7)
    "original": ("amplitude_3Hz", 6.0),
    "serial": ("serial_prototype", 4.0),
    "integrative": ("integrative_prototype", 2.0),
}
# outline sizes (fraction of the body length): the default level's, then halved twice
OUTLINE = (0.018, 0.009, 0.0045)


@contextlib.contextmanager
def outline_size(edge: float):
    """The default liquid level with another size along the outline (and no cached operator)."""
    level = potential.MESH_LEVELS[MeshLevel.DEFAULT]
    potential.MESH_LEVELS[MeshLevel.DEFAULT] = {**level, "edge": edge}
    potential._CACHE.clear()
    try:
        yield
    finally:
        potential.MESH_LEVELS[MeshLevel.DEFAULT] = level
        potential._CACHE.clear()


def first_bending(folder: str, *overrides: str) -> tuple[float, float]:
    case = load_case(
        ROOT / "cases/seed" / folder,
        ["fluid.model=potential", "boundary.head=free", "analysis.num_modes=3", *overrides],
    )
    start = time.perf_counter()
    s = modal_summary(case)
    f = next(f for f, k in zip(s["wet_hz"], s["wet_kinds"], strict=True) if k == "bending")
    return f, time.perf_counter() - start


def extrapolate(values: list[float]) -> tuple[float, float]:
    """The limit of a sequence whose changes shrink by a constant ratio, from its last three
    members, and that ratio (0.5: first order under halving)."""
    a, b, c = values[-3:]
    ratio = (c - b) / (b - a)
    if not 0.0 < ratio < 1.0:
        return c, ratio  # not yet in its asymptotic range: no extrapolation
    return c + (c - b) * ratio / (1.0 - ratio), ratio


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows: dict[str, dict] = {}
    for name, (folder, measured) in ROBOTS.items():
        row: dict = {"measured_hz": measured, "wall_s": {}}
        base, _ = first_bending(folder, "fluid.mesh_level=coarse")
        row["validation_hz"] = base  # default shell, coarse liquid: the validation's figure
        outline = []
        for edge in OUTLINE:
            with outline_size(edge):
                f, wall = first_bending(folder, "fluid.mesh_level=default")
            outline.append(f)
            row["wall_s"][f"outline {edge}"] = wall
        with outline_size(OUTLINE[1]):
            fine, row["wall_s"]["fine shell"] = first_bending(
                folder, "fluid.mesh_level=default", "mesh.level=fine"
            )
        row["outline_hz"], row["fine_shell_hz"] = outline, fine
        fluid_limit, row["outline_ratio"] = extrapolate(outline)
        row["fluid_factor"] = fluid_limit / base
        row["shell_factor"] = fine / outline[1]
        row["converged_hz"] = fluid_limit * row["shell_factor"]
        rows[name] = row
    scale = ROBOTS["original"][1] / rows["original"]["converged_hz"]
    for row in rows.values():
        row["recalibrated_hz"] = row["converged_hz"] * scale
        row["recalibrated_error"] = row["recalibrated_hz"] / row["measured_hz"] - 1
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    edges = " / ".join(f"{e:g}" for e in OUTLINE)
    print(f"first wet bending mode [Hz], free; liquid outline sizes {edges} of the length")
    print(
        f"{'robot':>12} {'validation':>10} {'outline sequence':>22} {'limit':>6} "
        f"{'fine shell':>10} {'converged':>9} {'recalibrated':>12} {'measured':>8} {'error':>6}"
    )
    for name, r in rows.items():
        o = " / ".join(f"{f:.3f}" for f in r["outline_hz"])
        print(
            f"{name:>12} {r['validation_hz']:10.3f} {o:>22} "
            f"{r['validation_hz'] * r['fluid_factor']:6.3f} "
            f"{100 * (r['shell_factor'] - 1):+9.2f}% {r['converged_hz']:9.3f} "
            f"{r['recalibrated_hz']:12.3f} {r['measured_hz']:8.1f} "
            f"{100 * r['recalibrated_error']:+5.1f}%"
        )
    walls = rows["integrative"]["wall_s"]
    print("wall [s], integrative: " + ", ".join(f"{k} {v:.0f}" for k, v in walls.items()))


if __name__ == "__main__":
    main()
