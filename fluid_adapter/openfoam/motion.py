"""Mesh-motion diffusivity for a plate swinging across a narrow tank.

``displacementLaplacian`` spreads the plate's displacement u_p into the mesh by solving
div(gamma grad u) = 0. Two ways to fail at the tail's +-40 mm in a 133 mm wide tank (measured,
docs/openfoam.md):

* gamma ~ uniform: the displacement "leaks" round the plate's free edges (a zero-thickness plate
  is a crack in the domain), so the first cells ahead of the moving plate are overtaken by it
  and turn inside out (164 inverted cells on the coarse mesh);
* gamma ~ 1/d or 1/d^2 (the ``inverseDistance`` family): the near-plate cells move rigidly, but
  in the gap to the side wall the 1D profile has |du/dz| = u_p / (gamma_wall * int 1/gamma)
  > 1 at the wall (quadratic: 1.8 at 40 mm), so the wall cells invert instead.

The fix is a distance-based diffusivity that saturates: gamma = (d0 / clip(d, d_min, d0))^2,
d the distance to the plate. Within d0 of the plate cells move nearly rigidly (no leak); beyond
it gamma = 1 and the gap compresses uniformly. The 1D wall condition reads
gamma_wall * int_0^G 1/gamma dz = G - 2 d0 / 3 > u_p, i.e. with d0 = 0.2 W (W the tank width,
G = W / 2) amplitudes up to 0.37 W (49 mm here) keep every cell's volume positive. OpenFOAM reads
it through the stock ``file`` diffusivity (a constant surfaceScalarField).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from .casefiles import DIFFUSIVITY_FILE
from .fishmesh import TankGeometry
from .foamio import read_boundary, read_faces, read_points, write_dict

SATURATION_WIDTH_FRACTION = 0.2  # d0 / tank width
MIN_DISTANCE_M = 1e-4
_SAMPLE_M = 0.5e-3  # planform sampling for the distance


def max_safe_amplitude(width_m: float) -> float:
    """Largest plate displacement toward a side wall that keeps the wall cells positive."""
    d0 = SATURATION_WIDTH_FRACTION * width_m
    return width_m / 2 - 2 * d0 / 3


def face_centres(mesh_dir: Path) -> NDArray:
    """Mean of each face's points (enough to place a diffusivity value)."""
    points = read_points(mesh_dir / "points")
    offsets, labels = read_faces(mesh_dir / "faces")
    sizes = np.diff(offsets)
    sums = np.add.reduceat(points[labels], offsets[:-1], axis=0)
    return sums / sizes[:, None]


def distance_to_plate(geo: TankGeometry, x: NDArray) -> NDArray:
    samples = []
    for xs in np.arange(0.0, geo.length + _SAMPLE_M, _SAMPLE_M):
        h = geo.h(min(xs, geo.length))
        ys = np.linspace(-h / 2, h / 2, max(2, int(h / _SAMPLE_M) + 1))
        samples.append(np.column_stack([np.full_like(ys, min(xs, geo.length)), ys, 0 * ys]))
    dist, _ = cKDTree(np.concatenate(samples)).query(x)
    return dist


def plate_diffusivity(geo: TankGeometry, centres: NDArray) -> NDArray:
    d0 = SATURATION_WIDTH_FRACTION * geo.width
    d = np.clip(distance_to_plate(geo, centres), MIN_DISTANCE_M, d0)
    return (d0 / d) ** 2


def write_diffusivity(case: Path, geo: TankGeometry) -> None:
    mesh = case / "constant" / "polyMesh"
    gamma = plate_diffusivity(geo, face_centres(mesh))
    boundary = read_boundary(mesh / "boundary")
    n_internal = min(int(b["startFace"]) for b in boundary.values())
    patches = {
        name: {
            "type": "processor" if b["type"] == "processor" else "calculated",
            "value": gamma[int(b["startFace"]) : int(b["startFace"]) + int(b["nFaces"])],
        }
        for name, b in boundary.items()
    }
    write_dict(
        case / "constant" / DIFFUSIVITY_FILE,
        {
            "FoamFile": {"class": "surfaceScalarField"},
            "dimensions": [0, 0, 0, 0, 0, 0, 0],
            "internalField": gamma[:n_internal],
            "boundaryField": patches,
        },
        field=True,
    )
