"""The periodic start's cost with a fast fluid: each harmonic's operator solved by elimination
onto the normal DOFs (``solid_adapter.harmonic.NormalElimination``, kept through the edge
drag's fixed point) against a sparse LU of the whole operator at every step, timed alternately
in one run: the ratio, and the largest difference of the two orbits' tail motion relative to
its amplitude.

    .venv/bin/python benchmarks/start_orbit_solve.py [--repeats 2]

Scenes: the thrust rig's square wave at 18 Hz (6 harmonics, the drag's fixed point), hinged as
the case holds it and clamped, and the main job's 3 Hz sine.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.fast_model import shell_with_fast_fluid  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402
from solid_adapter import harmonic  # noqa: E402
from solid_adapter.build import (  # noqa: E402
    build_integrator,
    periodic_orbit,
    static_loads,
)
from solid_adapter.piezo import DriveSignal  # noqa: E402
from solid_adapter.shell import NDOF  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENES = {
    "thrust rig, hinged, 18 Hz square": ("cases/seed/thrust_rig", []),
    "thrust rig, clamped, 18 Hz square": ("cases/seed/thrust_rig", ["boundary.head=clamped"]),
    "main job, 3 Hz sine": ("cases/fixed_head_3Hz", []),
}


def orbit(folder: str, overrides: list[str], eliminate: bool) -> tuple[float, np.ndarray]:
    """Wall time of the periodic start and the tail's normal motion over one period."""
    case = load_case(ROOT / folder, ["fluid.model=potential", *overrides])
    model, _ = shell_with_fast_fluid(case, edge_inertia=True)
    integrator = build_integrator(case, model)
    drive = DriveSignal.from_case(case)
    harmonic.DENSE_NORMAL_BLOCK = 0.5 if eliminate else float("inf")
    start = time.perf_counter()
    response = periodic_orbit(case, model, drive, static_loads(case, model), integrator)
    wall = time.perf_counter() - start
    tip = model.mesh.nearest_node(*model.layout.tip_point) * NDOF + 2
    times = np.linspace(0.0, 2 * np.pi / response.omega, 200, endpoint=False)
    return wall, response.dof_history(np.array([tip]), times)[:, 0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    print(f"{'scene':<36} {'eliminated s':>12} {'sparse LU s':>11} {'ratio':>6} {'difference':>10}")
    for name, (folder, overrides) in SCENES.items():
        walls: dict[bool, list[float]] = {True: [], False: []}
        tails: dict[bool, np.ndarray] = {}
        for _ in range(args.repeats):
            for eliminate in (True, False):
                wall, tail = orbit(folder, overrides, eliminate)
                walls[eliminate].append(wall)
                tails[eliminate] = tail
        fast, plain = np.median(walls[True]), np.median(walls[False])
        amplitude = np.ptp(tails[False]) / 2
        diff = np.abs(tails[True] - tails[False]).max() / amplitude
        print(f"{name:<36} {fast:>12.2f} {plain:>11.2f} {plain / fast:>6.1f} {diff:>10.1e}")


if __name__ == "__main__":
    main()
