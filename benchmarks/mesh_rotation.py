"""How far a fin may turn before the moving mesh folds: the integrative robot's coarse fluid
mesh alone (moveDynamicMesh, checkMesh after every step), its fin turned rigidly about the
peduncle (x = 140 mm) from 0 to 90 deg in 36 steps, with the shipped mesh motion and the stock
OpenFOAM v1912 alternatives that should rotate better (docs/openfoam.md, "Mesh motion"):

- ``laplacian``: velocityLaplacian, the plate-distance diffusivity (shipped);
- ``laplacian-patch-transformed``: the same, the first cell layer moved as the face moves
  (``interpolation patchTransformed``);
- ``laplacian-plateau-5mm``: the diffusivity flat within 5 mm of the plate (a rotation is then
  harmonic next to it);
- ``sbr-stress``: velocityDisplacement wrapping displacementSBRStress (its stress vanishes
  under rotation whatever the diffusivity);
- ``sbr-stress-patch-transformed``: the same with patchTransformed.

For each: the first angle at which a check fails, the first at which a face turns past 90 deg
(inside out), and the angle at which the mesh solver broke down, if it did.

    .venv/bin/python benchmarks/mesh_rotation.py [--json OUT.json]

About 2 min on one core.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
from foamlib import FoamFile

import fluid_adapter.openfoam.motion as motion
from fluid_adapter.openfoam.checkmesh import parse_steps
from fluid_adapter.openfoam.drivers import run_mesh_motion
from fluid_adapter.openfoam.errors import OpenFoamError
from fluid_adapter.openfoam.prescribed import _prepare
from fsi_orchestrator.case.loader import load_case

ROOT = Path(__file__).resolve().parents[1]
HINGE_X_M = 0.140  # the integrative preset's peduncle
STEPS, DT = 36, 1.0 / 120.0
LAST_DEG = 90.0
VARIANTS = (
    "laplacian",
    "laplacian-patch-transformed",
    "laplacian-plateau-5mm",
    "sbr-stress",
    "sbr-stress-patch-transformed",
)
PATCH_TRANSFORMED = "interpolation patchTransformed (fishMinusZ fishPlusZ);\n    "


def angle_deg(step: int) -> float:
    return LAST_DEG * step / STEPS


def configure(work: Path, variant: str) -> None:
    """Rewrite the generated case's mesh motion for ``variant``."""
    mesh = work / "constant" / "dynamicMeshDict"
    if variant.startswith("sbr-stress"):
        diffusivity = FoamFile(mesh)["velocityLaplacianCoeffs"]["diffusivity"]
        with FoamFile(mesh) as d:
            del d["velocityLaplacianCoeffs"]
            d["motionSolver"] = "velocityDisplacement"
            d["velocityDisplacementCoeffs"] = {
                "solver": "displacementSBRStress",
                "diffusivity": diffusivity,
            }
        with FoamFile(work / "system" / "fvSolution") as s:
            s["solvers"]['"cellDisplacement.*"'] = {
                "solver": "GAMG",
                "smoother": "GaussSeidel",
                "tolerance": 1e-8,
                "relTol": 0,
            }
    if variant.endswith("patch-transformed"):  # foamlib takes no word list with a keyword
        text = mesh.read_text()
        at = text.index("diffusivity")
        mesh.write_text(text[:at] + PATCH_TRANSFORMED + text[at:])


def run_variant(variant: str, folder: Path) -> dict:
    case = load_case(
        ROOT / "cases" / "seed" / "integrative_prototype",
        ["fluid.model=openfoam", "fluid.mesh_level=coarse", "boundary.head=clamped"],
    )
    saved = motion.MIN_DISTANCE_M
    if variant == "laplacian-plateau-5mm":
        motion.MIN_DISTANCE_M = 5e-3
    try:
        run, quality = _prepare(case, folder, DT, 1.0)
    finally:
        motion.MIN_DISTANCE_M = saved
    configure(folder, variant)
    p0 = run.interface.points0
    arm = np.clip(p0[:, 0] - HINGE_X_M, 0.0, None)

    def displacement(t: float) -> np.ndarray:
        theta = np.deg2rad(LAST_DEG) * t / (STEPS * DT)
        u = np.zeros_like(p0)
        u[:, 0] = arm * (np.cos(theta) - 1.0)
        u[:, 2] = arm * np.sin(theta)
        return u

    row: dict = {"variant": variant, "first_failed_deg": None, "inside_out_deg": None}
    try:
        checks = run_mesh_motion(run, displacement, DT, STEPS, (quality.cells, quality.points))
        row["broke_down_deg"] = None
    except OpenFoamError:
        log = (folder / "log.moveDynamicMesh").read_text()
        checks = []
        for block in log.split("\nTime = ")[1:]:  # the steps before the breakdown
            try:
                checks += parse_steps("Time = " + block, (quality.cells, quality.points))
            except OpenFoamError:
                break
        row["broke_down_deg"] = angle_deg(len(checks) + 1)
    for k, check in enumerate(checks, start=1):
        if row["first_failed_deg"] is None and not check.ok:
            row["first_failed_deg"] = angle_deg(k)
        if row["inside_out_deg"] is None and (
            check.max_non_orthogonality_deg > 90.0 or check.min_volume_m3 <= 0.0
        ):
            row["inside_out_deg"] = angle_deg(k)
    at_45 = int(STEPS * 45 / LAST_DEG)
    row["max_non_orthogonality_deg_at_45"] = (
        checks[at_45 - 1].max_non_orthogonality_deg if len(checks) >= at_45 else float("nan")
    )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the rows here")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="mesh_rotation_") as tmp:
        for variant in VARIANTS:
            folder = Path(tmp) / variant
            rows.append(run_variant(variant, folder))
            shutil.rmtree(folder, ignore_errors=True)
            print(rows[-1], flush=True)

    def deg(value: float | None) -> str:
        return "-" if value is None else f"{value:.1f}"

    print("| mesh motion | first failed check | inside out | broke down | non-orth. at 45 deg |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['variant']} | {deg(r['first_failed_deg'])} | {deg(r['inside_out_deg'])} | "
            f"{deg(r['broke_down_deg'])} | {r['max_non_orthogonality_deg_at_45']:.1f} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
