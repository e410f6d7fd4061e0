"""The coupling interface on the OpenFOAM side: the body patches' points and faces.

Points are the union of the patches' mesh points (the two faces of the baffle share them), in
the order they first appear walking the patches' faces; each patch keeps its own point order,
which is the order of a nonuniform ``value`` of a point patch field (OpenFOAM's meshPoints:
first appearance walking the patch faces). Faces of all patches are kept (both faces of the
plate), so splitting every face force equally among its points sums to the net force.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .foamio import read_boundary, read_faces, read_points


@dataclass(frozen=True)
class PatchGeometry:
    name: str
    faces: NDArray[np.int64]  # (m, 4) indices into the interface points
    local_points: NDArray[np.int64]  # (k,) interface point index of each patch point


@dataclass(frozen=True)
class FluidInterface:
    points0: NDArray[np.float64]  # (n, 3) reference positions
    mesh_points: NDArray[np.int64]  # (n,) labels in the OpenFOAM mesh
    patches: tuple[PatchGeometry, ...]

    @property
    def faces(self) -> NDArray[np.int64]:
        return np.concatenate([p.faces for p in self.patches])

    def patch(self, name: str) -> PatchGeometry:
        return next(p for p in self.patches if p.name == name)

    def face_centres(self, displacement: NDArray | None = None) -> NDArray:
        """OpenFOAM's face centres (see :func:`face_centroids`) of the moved faces."""
        pts = self.points0 if displacement is None else self.points0 + displacement
        return face_centroids(pts, self.faces)

    def nodal_forces(self, face_forces: NDArray) -> NDArray:
        """Each face's force split equally among its points (sums to the total force)."""
        faces = self.faces
        out = np.zeros((len(self.points0), 3))
        share = face_forces / faces.shape[1]
        for corner in range(faces.shape[1]):
            np.add.at(out, faces[:, corner], share)
        return out


def face_centroids(points: NDArray, faces: NDArray) -> NDArray:
    """Face centres as OpenFOAM computes them (``face::centre``): the area-weighted centroid of
    the triangles fanned from the points' mean. On the graded peduncle's long thin faces that
    is up to 0.9 mm from the points' mean, about a tenth of a face."""
    corners = points[faces]  # (m, k, 3)
    mean = corners.mean(axis=1, keepdims=True)
    following = np.roll(corners, -1, axis=1)
    area2 = np.linalg.norm(np.cross(corners - mean, following - mean), axis=2)  # (m, k)
    centroid3 = corners + following + mean
    total = area2.sum(axis=1)
    found = total > 1e-300
    out = mean[:, 0, :].copy()
    out[found] = (area2[found, :, None] * centroid3[found]).sum(axis=1) / (3.0 * total[found, None])
    return out


def _patch_faces(faces_file: Path, start: int, count: int) -> list[NDArray[np.int64]]:
    offsets, labels = read_faces(faces_file)
    return [labels[offsets[i] : offsets[i + 1]] for i in range(start, start + count)]


def read_interface(case: Path, patches: tuple[str, ...]) -> FluidInterface:
    """The reference interface from ``constant/polyMesh``."""
    mesh = case / "constant" / "polyMesh"
    boundary = read_boundary(mesh / "boundary")
    missing = [p for p in patches if p not in boundary]
    if missing:
        raise ValueError(f"{mesh / 'boundary'}: no patch {missing}; found {list(boundary)}")
    all_points = read_points(mesh / "points")
    order: dict[int, int] = {}
    raw: list[tuple[str, list[NDArray[np.int64]]]] = []
    for name in patches:
        b = boundary[name]
        faces = _patch_faces(mesh / "faces", int(b["startFace"]), int(b["nFaces"]))
        for face in faces:
            for label in face:
                order.setdefault(int(label), len(order))
        raw.append((name, faces))
    mesh_points = np.fromiter(order, dtype=np.int64, count=len(order))
    geometries = []
    for name, faces in raw:
        local = np.array([[order[int(v)] for v in f] for f in faces], dtype=np.int64)
        first_seen = dict.fromkeys(int(v) for v in local.ravel())
        geometries.append(PatchGeometry(name, local, np.fromiter(first_seen, dtype=np.int64)))
    return FluidInterface(all_points[mesh_points], mesh_points, tuple(geometries))
