"""Loads on the body from the sampled surface fields: face forces, nodal forces, force, moment.

OpenFOAM's incompressible p and wall shear stress are kinematic (divided by the density). On a
boundary face with area vector S (pointing out of the fluid, i.e. into the body) the fluid's
force on the body is

    f = rho * (p S - |S| tau_w),

tau_w being the ``wallShearStress`` function object's -n . R_eff (the sign convention of the
``forces`` function object, which this reproduces). Thrust = -F_x: the fish swims toward -x.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from .casefiles import SAMPLE_FO
from .errors import OpenFoamRunError
from .interface import FluidInterface, face_centroids


@dataclass(frozen=True, kw_only=True)
class SurfaceLoads:
    """Loads at one time on every interface face (faces in interface order)."""

    time: float
    face_centres: NDArray  # (m, 3) of the moved mesh
    face_area_vectors: NDArray  # (m, 3), out of the fluid
    pressure_pa: NDArray  # (m,) p * rho
    face_forces: NDArray  # (m, 3) N

    @property
    def force(self) -> NDArray:
        return self.face_forces.sum(axis=0)

    @property
    def moment(self) -> NDArray:
        """About the origin (the nose point)."""
        return np.cross(self.face_centres, self.face_forces).sum(axis=0)

    @property
    def thrust(self) -> float:
        return float(-self.force[0])


def area_vectors(points: NDArray, faces: NDArray) -> NDArray:
    """Vector areas of quads (exact for any quad: half the cross product of the diagonals)."""
    return 0.5 * np.cross(
        points[faces[:, 2]] - points[faces[:, 0]], points[faces[:, 3]] - points[faces[:, 1]]
    )


def read_raw(path: Path) -> NDArray:
    """A ``raw`` surface file: rows of x y z value(s)."""
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: no sampled surface data (did the {SAMPLE_FO} function object run?)"
        )
    return np.atleast_2d(np.loadtxt(path, comments="#"))


def sample_dir(case: Path, time_name: str) -> Path:
    return case / "postProcessing" / SAMPLE_FO / time_name


def face_order(sampled: NDArray, expected: NDArray, where: Path) -> NDArray:
    """Index into the sampled rows for each expected face: identity in serial; a parallel run
    merges the processors' pieces in another order, matched here by nearest face centre."""
    if len(sampled) != len(expected):
        raise OpenFoamRunError(
            f"{where}: {len(sampled)} faces sampled, expected {len(expected)}; the case folder "
            "does not hold this run's mesh (start the run again in an empty --output)"
        )
    size = np.sqrt(np.ptp(expected, axis=0).max() ** 2 / max(len(expected), 1))
    if np.abs(sampled - expected).max() < 0.1 * size:
        return np.arange(len(expected))
    distance, order = cKDTree(sampled).query(expected)
    if len(np.unique(order)) != len(order):
        raise OpenFoamRunError(
            f"{where}: the fluid mesh's plate no longer follows the structure (face centres up "
            f"to {1e3 * distance.max():.3g} mm apart, faces about {1e3 * size:.3g} mm wide); "
            "the mesh motion failed at this deflection: take smaller windows "
            "(more time.steps_per_period) or a smaller drive"
        )
    return order


def read_loads(
    case: Path,
    time_name: str,
    interface: FluidInterface,
    displacement: NDArray,
    rho: float,
) -> SurfaceLoads:
    """Loads of the step written as ``time_name``; ``displacement`` = the interface's then."""
    folder = sample_dir(case, time_name)
    points = interface.points0 + displacement
    centres, areas, pressure, forces = [], [], [], []
    for patch in interface.patches:
        p = read_raw(folder / f"p_{patch.name}.raw")
        tau = read_raw(folder / f"wallShearStress_{patch.name}.raw")[:, 3:6]
        order = face_order(p[:, :3], face_centroids(points, patch.faces), folder / patch.name)
        p, tau = p[order], tau[order]
        s = area_vectors(points, patch.faces)
        centres.append(p[:, :3])
        areas.append(s)
        pressure.append(rho * p[:, 3])
        forces.append(rho * (p[:, 3:4] * s - np.linalg.norm(s, axis=1)[:, None] * tau))
    return SurfaceLoads(
        time=float(time_name),
        face_centres=np.concatenate(centres),
        face_area_vectors=np.concatenate(areas),
        pressure_pa=np.concatenate(pressure),
        face_forces=np.concatenate(forces),
    )
