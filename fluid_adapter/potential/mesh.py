"""Tetrahedral mesh of the liquid around a thin plate, with the plate as a two-sided crack.

The plate (a polygon in the plane z = 0) is embedded in the fluid volume (a sphere, like the
seed's modal model, Sec. 3.4.2.1, or the experiment's tank) with gmsh/OpenCASCADE; gmsh's Crack
plugin then duplicates the nodes on the plate so that the pressure can jump across it, while the
plate's outline stays sealed (the pressure is continuous around the edge).
"""

from __future__ import annotations

import signal
from collections import defaultdict
from dataclasses import dataclass

import gmsh
import numpy as np
import skfem
from numpy.typing import NDArray


@dataclass(frozen=True, kw_only=True)
class SphereDomain:
    centre: tuple[float, float, float]
    radius_m: float


@dataclass(frozen=True, kw_only=True)
class BoxDomain:
    """Axis-aligned tank; the face at y = y1 is the open top (p = 0)."""

    x0: float
    x1: float
    y0: float
    y1: float
    z0: float
    z1: float


@dataclass(frozen=True, kw_only=True)
class MeshSizes:
    near_plate_m: float
    far_m: float
    growth_distance_m: float  # distance from the plate over which the size grows
    edge_m: float | None = None  # finer size along the plate's outline (pressure singularity)


@dataclass(frozen=True)
class FluidMesh:
    mesh: skfem.MeshTet
    upper_facets: NDArray  # plate facets wetted from +z
    lower_facets: NDArray  # plate facets wetted from -z
    dirichlet_facets: NDArray  # p = 0 (sphere surface, or the tank's open top)

    @property
    def n_nodes(self) -> int:
        return self.mesh.p.shape[1]


def boundary_polygon(mesh: skfem.Mesh) -> NDArray:
    """Vertices of a 2D mesh's outer boundary as one ordered loop (n, 2)."""
    edges = mesh.facets[:, mesh.boundary_facets()].T
    neighbours: dict[int, list[int]] = defaultdict(list)
    for a, b in edges:
        neighbours[a].append(b)
        neighbours[b].append(a)
    start = int(edges[0, 0])
    loop, previous, current = [start], -1, start
    while True:
        nxt = next(v for v in neighbours[current] if v != previous)
        if nxt == start:
            break
        loop.append(nxt)
        previous, current = current, nxt
    return mesh.p[:, loop].T.copy()


def _restore(handlers: dict) -> None:
    for signum, handler in handlers.items():
        try:
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)
        except ValueError:  # off the main thread Python cannot put one back: mesh on it
            pass


def build_fluid_mesh(
    polygon: NDArray, domain: SphereDomain | BoxDomain, sizes: MeshSizes
) -> FluidMesh:
    # gmsh's initialize and finalize leave SIGINT and SIGTERM at their C defaults, and a
    # SIGTERM (SLURM's time limit) then killed the command without a word: the Python
    # handlers are put back after each (one that arrives while gmsh meshes acts when it returns)
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        gmsh.initialize(interruptible=False)
        _restore(handlers)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fluid")
        plate = _geometry(polygon, domain)
        group = gmsh.model.addPhysicalGroup(2, plate)
        _size_field(plate, sizes)
        gmsh.model.mesh.generate(3)
        gmsh.plugin.setNumber("Crack", "Dimension", 2)
        gmsh.plugin.setNumber("Crack", "PhysicalGroup", group)
        gmsh.plugin.run("Crack")
        points, tets = _extract()
    finally:
        gmsh.finalize()
        _restore(handlers)
    mesh = skfem.MeshTet(np.ascontiguousarray(points.T), np.ascontiguousarray(tets.T))
    return _classify(mesh, domain, scale=float(np.ptp(polygon[:, 0])))


def _geometry(polygon: NDArray, domain: SphereDomain | BoxDomain) -> list[int]:
    occ = gmsh.model.occ
    pts = [occ.addPoint(x, y, 0.0) for x, y in polygon]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    plate = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    if isinstance(domain, SphereDomain):
        volume = occ.addSphere(*domain.centre, domain.radius_m)
    else:
        d = domain
        volume = occ.addBox(d.x0, d.y0, d.z0, d.x1 - d.x0, d.y1 - d.y0, d.z1 - d.z0)
    occ.fragment([(3, volume)], [(2, plate)])
    occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)])
    plates = [t for _, t in gmsh.model.getEntities(2) if _is_flat_at_zero(t)]
    if not plates:
        raise RuntimeError(
            "potential flow mesh: the plate did not end up inside the fluid "
            "domain (is the domain large enough?)"
        )
    return plates


def _is_flat_at_zero(tag: int) -> bool:
    box = gmsh.model.getBoundingBox(2, tag)
    return abs(box[5] - box[2]) < 1e-6 and abs(box[2]) < 1e-6


def _size_field(plate: list[int], sizes: MeshSizes) -> None:
    """Fine at the plate, growing to ``far_m``; finer still along the outline, where the
    pressure jump has its square-root singularity and first-order elements lose accuracy."""
    field = gmsh.model.mesh.field
    fields = [
        _threshold(
            field, "SurfacesList", plate, sizes.near_plate_m, sizes.far_m, sizes.growth_distance_m
        )
    ]
    if sizes.edge_m is not None:
        edges = [t for _, t in gmsh.model.getBoundary([(2, p) for p in plate], oriented=False)]
        fields.append(
            _threshold(
                field, "CurvesList", edges, sizes.edge_m, sizes.far_m, sizes.growth_distance_m
            )
        )
    smallest = field.add("Min")
    field.setNumbers(smallest, "FieldsList", fields)
    field.setAsBackgroundMesh(smallest)
    for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{option}", 0)


def _threshold(
    field, entity_key: str, tags: list[int], size_min: float, size_max: float, distance_max: float
) -> int:
    distance = field.add("Distance")
    field.setNumbers(distance, entity_key, tags)
    field.setNumber(distance, "Sampling", 100)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    field.setNumber(threshold, "SizeMin", size_min)
    field.setNumber(threshold, "SizeMax", size_max)
    field.setNumber(threshold, "DistMin", 0.0)
    field.setNumber(threshold, "DistMax", distance_max)
    return threshold


def _extract() -> tuple[NDArray, NDArray]:
    tags, coords, _ = gmsh.model.mesh.getNodes()
    _, nodes = gmsh.model.mesh.getElementsByType(4)
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    tets = index[nodes.astype(np.int64)].reshape(-1, 4)
    used = np.unique(tets)
    remap = -np.ones(len(tags), dtype=np.int64)
    remap[used] = np.arange(len(used))
    return coords.reshape(-1, 3)[used], remap[tets]


def _classify(mesh: skfem.MeshTet, domain: SphereDomain | BoxDomain, scale: float) -> FluidMesh:
    tol = 1e-9 * scale
    facets = mesh.boundary_facets()
    z = mesh.p[2, mesh.facets[:, facets]]
    on_plate = np.all(np.abs(z) < tol, axis=0)
    owner = mesh.f2t[0, facets]
    owner_z = mesh.p[2, mesh.t[:, owner]].mean(axis=0)
    plate = facets[on_plate]
    upper = plate[owner_z[on_plate] > 0]
    lower = plate[owner_z[on_plate] < 0]
    outer = facets[~on_plate]
    if isinstance(domain, BoxDomain):
        y = mesh.p[1, mesh.facets[:, outer]]
        outer = outer[np.all(np.abs(y - domain.y1) < tol * 10, axis=0)]
    if len(upper) == 0 or len(lower) == 0 or len(outer) == 0:
        raise RuntimeError(
            "potential flow mesh: the plate crack or the p = 0 boundary was not "
            "found (check the plate outline and the domain size)"
        )
    return FluidMesh(mesh=mesh, upper_facets=upper, lower_facets=lower, dirichlet_facets=outer)
