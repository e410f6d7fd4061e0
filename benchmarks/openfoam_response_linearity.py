"""Is OpenFOAM's answer to one coupling window a smooth function of the window's plate motion?

The quasi-Newton coupling learns the fluid's response from differences of its answers; a
solver-noise floor near the coupling tolerance (iterative solvers stopping at their own
tolerances, PIMPLE's two outer correctors) would cap what any Jacobian can contract. This takes
the last window of a finished run (its start time folder and its plate-velocity sample), solves
that one step again with the velocity changed by eps times a first-mode-like shape
(v_z += eps max|v_z| (x / L)^2), and compares the patch pressures: a smooth map gives the same
slope (p(eps) - p(0)) / eps for every eps, and a repeated solve is identical.

    .venv/bin/fsi-run cases/fixed_head_3Hz --output OUT      # or any run that kept OUT/openfoam
    .venv/bin/python benchmarks/openfoam_response_linearity.py --run OUT [--eps 1e-2 1e-4 1e-6]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from foamlib import FoamFile

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fluid_adapter.openfoam import runner  # noqa: E402
from fluid_adapter.openfoam.casefiles import HANDSHAKE_FO, MOTION_FIELD, SAMPLE_FO  # noqa: E402
from fluid_adapter.openfoam.foamio import read_points, update_dict  # noqa: E402
from fluid_adapter.openfoam.foamrun import numeric_dirs  # noqa: E402
from fluid_adapter.openfoam.loads import read_raw  # noqa: E402


def last_window(source: Path, work: Path) -> tuple[Path, str, Path, Path]:
    """Copy the run's case, set it up for its last window alone: (case, end folder name,
    the window's velocity sample, the reference points)."""
    case = work / "case"
    shutil.copytree(
        source, case, symlinks=True, ignore=shutil.ignore_patterns("postProcessing", "log.*")
    )
    (start, _), (end, end_name) = numeric_dirs(case)[-2:]
    shutil.rmtree(case / end_name)
    control = case / "system" / "controlDict"
    update_dict(control, {"startTime": start, "endTime": end})
    with FoamFile(control) as f:  # no persistent-driver handshake: one plain launch
        if HANDSHAKE_FO in f["functions"]:
            del f["functions"][HANDSHAKE_FO]
    roots = [p for p in (case / "constant" / "boundaryData").iterdir() if not p.is_symlink()]
    # the window-end sample (named by the planned time, the folder by OpenFOAM's rounding);
    # the window's other samples and the other patch's folder link to it
    _, name = min(numeric_dirs(roots[0]), key=lambda found: abs(found[0] - end))
    sample = (roots[0] / name / MOTION_FIELD).resolve()
    return case, end_name, sample, roots[0] / "points"


def solve(case: Path, end_name: str) -> tuple[np.ndarray, float]:
    """One pimpleFoam launch over the window: the patch pressures at its end, wall seconds."""
    shutil.rmtree(case / "postProcessing", ignore_errors=True)
    shutil.rmtree(case / end_name, ignore_errors=True)
    start = time.perf_counter()
    runner.run(runner.Command(app="pimpleFoam", case=case))
    wall = time.perf_counter() - start
    folder = (
        case
        / "postProcessing"
        / SAMPLE_FO
        / numeric_dirs(case / "postProcessing" / SAMPLE_FO)[-1][1]
    )
    return np.concatenate([read_raw(f)[:, -1] for f in sorted(folder.glob("p_*.raw"))]), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, required=True, help="an fsi-run output folder")
    parser.add_argument("--eps", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fishfsi-linearity-") as tmp:
        case, end_name, sample, points_file = last_window(args.run / "openfoam", Path(tmp))
        velocity, points = read_points(sample), read_points(points_file)
        shape = np.zeros_like(points)
        shape[:, 2] = (points[:, 0] / points[:, 0].max()) ** 2
        scale = np.abs(velocity[:, 2]).max()

        def with_velocity(eps: float) -> tuple[np.ndarray, float]:
            moved = velocity + eps * scale * shape
            sample.write_bytes(FoamFile.dumps(moved, ensure_header=False))
            return solve(case, end_name)

        p0, wall = with_velocity(0.0)
        again, _ = with_velocity(0.0)
        norm = np.linalg.norm(p0)
        print(f"window ending at {end_name} s: |p| = {norm:.4e}, {wall:.1f} s per solve")
        print(f"  repeated solve: |p - p0| / |p0| = {np.linalg.norm(again - p0) / norm:.1e}")
        first = None
        for eps in args.eps:
            p, _ = with_velocity(eps)
            slope = (p - p0) / eps
            first = slope if first is None else first
            print(
                f"  eps {eps:.0e}: |p - p0| / |p0| = {np.linalg.norm(p - p0) / norm:.3e}, slope "
                f"off the eps = {args.eps[0]:.0e} slope by "
                f"{np.linalg.norm(slope - first) / np.linalg.norm(first):.2e}"
            )
        sample.write_bytes(FoamFile.dumps(velocity, ensure_header=False))


if __name__ == "__main__":
    main()
