"""The tank with the fish plate: a structured multi-block (blockMesh) H-grid whose grid lines
follow the planform, the plate as a zero-thickness baffle.

Frame (the shell's): x along the body (nose at 0, tail at L), y across the plate (vertical in the
tank, open top at +y), z normal to the plate (swing direction). The tank spans
``[-nose_x, tank_length - nose_x] x [-depth/2, depth/2] x [-width/2, width/2]``.

Blocks: x columns front | plate segments (split where h(x) has kinks, so the curved block edges
stay close to the straight ones) | back; y rows below | plate | above, whose inner lines follow
y = +-h(x)/2 (polyLine edges) and continue straight ahead of and behind the plate; z layers
below | above the plate. The faces between the two plate-row blocks over 0 <= x <= L are turned
into two wall patches by ``topoSet`` + ``createBaffles`` (blockMesh itself refuses a face that
two blocks share and two patches claim): ``fishPlusZ`` (the plate's +z face, fluid on +z) and
``fishMinusZ``. They share their points, which is what a plate's mid-surface motion needs.

Why a baffle rather than a 0.8 mm thick body: the shell gives mid-surface displacements; a thin
body would need the faces offset along the rotated normal and cells of ~0.1 mm at its rim, i.e.
5-10x more cells and a much smaller stable time step, to resolve a thickness 0.5 % of the body
length that carries no load of its own (the shell already accounts for it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.planform import planform
from fsi_orchestrator.case.schema import MeshLevel

from .grading import Spacing, graded, two_sided, uniform

PATCH_PLUS_Z = "fishPlusZ"
PATCH_MINUS_Z = "fishMinusZ"
FISH_PATCHES = (PATCH_PLUS_Z, PATCH_MINUS_Z)
WALLS = "walls"
TOP = "top"
INLET = "inlet"  # a flume's front wall (fluid.inflow_m_s > 0)
OUTLET = "outlet"  # a flume's back wall
_CURVE_POINTS = 40  # polyLine points per curved block edge


@dataclass(frozen=True, kw_only=True)
class Resolution:
    """Target cell sizes (m) of one mesh level."""

    edge_m: float  # along x and y at the plate's rim (nose, tail, upper and lower edges)
    plate_m: float  # along x and y over the plate, away from its rim
    normal_m: float  # first cell normal to the plate (z)
    side_wall_m: float  # z size at the side walls z = +-width/2
    far_m: float  # x and y size at the front/back walls, the bottom and the top

    def scaled(self, factor: float) -> Resolution:
        return Resolution(**{k: v * factor for k, v in self.__dict__.items()})


LEVELS = {
    MeshLevel.COARSE: Resolution(
        edge_m=4.0e-3, plate_m=8.0e-3, normal_m=3.0e-3, side_wall_m=12e-3, far_m=50e-3
    ),
    # the fine level's rim and first cell, the former default's (102k cells) interior: the
    # prescribed-motion thrust depends on the rim (within 0.4 % of fine, 45 % of its cells;
    # the former default was 7.6 % low; docs/openfoam.md)
    MeshLevel.DEFAULT: Resolution(
        edge_m=1.6e-3, plate_m=5.0e-3, normal_m=1.3e-3, side_wall_m=8e-3, far_m=35e-3
    ),
    MeshLevel.FINE: Resolution(
        edge_m=1.6e-3, plate_m=3.3e-3, normal_m=1.3e-3, side_wall_m=5.5e-3, far_m=24e-3
    ),
}


@dataclass(frozen=True, kw_only=True)
class TankGeometry:
    """Tank walls and plate planform in the fish frame (m)."""

    x_front: float
    x_back: float
    depth: float
    width: float
    length: float  # plate length L
    plate_breaks: tuple[float, ...]  # 0 = x_0 < ... < x_n = L, block boundaries along the plate
    height: Callable[[NDArray], NDArray]  # plate height h(x), |y| <= h/2
    flume: bool = False  # front wall an inlet, back wall an outlet

    def h(self, x: float) -> float:
        return float(self.height(np.array([min(max(x, 0.0), self.length)]))[0])


def tank_geometry(case: Case) -> TankGeometry:
    fl = case.fluid
    plate = planform(case)
    length = plate.length_m
    nose = fl.tank_nose_x_m if fl.tank_nose_x_m is not None else (fl.tank_length_m - length) / 2
    return TankGeometry(
        x_front=-nose,
        x_back=fl.tank_length_m - nose,
        depth=fl.tank_depth_m,
        width=fl.tank_width_m,
        length=length,
        plate_breaks=plate.kinks_m,
        height=plate.height,
        flume=fl.inflow_m_s > 0,
    )


@dataclass(frozen=True)
class Block:
    vertices: tuple[int, ...]
    cells: tuple[int, int, int]
    grading: tuple[object, object, object]
    zone: str | None = None


@dataclass(frozen=True, kw_only=True)
class BlockTopology:
    """Everything blockMeshDict needs, as plain Python data."""

    vertices: NDArray  # (n, 3)
    blocks: tuple[Block, ...]
    edges: tuple[tuple[int, int, NDArray], ...]  # polyLine (start, end, interior points)
    patches: dict[str, tuple[str, list[tuple[int, int, int, int]]]]  # name -> (type, faces)

    @property
    def n_cells(self) -> int:
        return int(sum(np.prod(b.cells) for b in self.blocks))

    def dictionary(self) -> dict:
        blocks: list = []
        for b in self.blocks:
            blocks += ["hex", list(b.vertices)]
            blocks += [b.zone] if b.zone else []
            blocks += [list(b.cells), "simpleGrading", list(b.grading)]
        edges: list = []
        for start, end, pts in self.edges:
            edges += ["polyLine", start, end, pts.tolist()]
        return {
            "scale": 1,
            "vertices": self.vertices.tolist(),
            "blocks": blocks,
            "edges": edges,
            "boundary": [
                (name, {"type": kind, "faces": [list(f) for f in faces]})
                for name, (kind, faces) in self.patches.items()
            ],
            "mergePatchPairs": [],
        }


# Outward faces of a hex block (blockMesh's local vertex numbering).
_FACE = {
    "x0": (0, 4, 7, 3),
    "x1": (1, 2, 6, 5),
    "y0": (0, 1, 5, 4),
    "y1": (3, 7, 6, 2),
    "z0": (0, 3, 2, 1),
    "z1": (4, 5, 6, 7),
}


def check_tank(geo: TankGeometry, res: Resolution) -> None:
    """The tank must leave at least one rim cell between the plate and each wall, or the
    grading has no room (a CaseError naming the key and its least value)."""
    h_max = float(np.max(geo.height(np.linspace(0, geo.length, 200))))
    ahead, behind = -geo.x_front, geo.x_back - geo.length
    if min(ahead, behind) < res.edge_m:
        raise CaseError(
            f"case.toml: fluid.tank_length_m / fluid.tank_nose_x_m: the tank leaves "
            f"{ahead:.3g} m ahead of the nose and {behind:.3g} m behind the tail; the mesh "
            f"needs at least {res.edge_m:g} m on each side (a tank at least "
            f"{geo.length + 2 * res.edge_m:.3g} m long, the plate centred)"
        )
    if geo.depth < h_max + 2 * res.edge_m:
        raise CaseError(
            f"case.toml: fluid.tank_depth_m ({geo.depth:g} m) is too small for the mesh "
            f"grading around the {h_max:.3g} m high plate: at least {h_max + 2 * res.edge_m:.3g} m"
        )
    if geo.width < 2 * res.normal_m:
        raise CaseError(
            f"case.toml: fluid.tank_width_m ({geo.width:g} m) is too small for the mesh "
            f"grading: at least {2 * res.normal_m:.3g} m"
        )


def tank_topology(geo: TankGeometry, res: Resolution) -> BlockTopology:
    check_tank(geo, res)
    xs = np.array([geo.x_front, *geo.plate_breaks, geo.x_back])
    zs = np.array([-geo.width / 2, 0.0, geo.width / 2])
    x_cells = _x_spacings(geo, res)
    y_cells = _y_spacings(geo, res)
    z_cells = _z_spacings(geo, res)
    nx, ny, nz = len(xs), 4, len(zs)

    def vid(i: int, j: int, k: int) -> int:
        return (k * ny + j) * nx + i

    vertices = np.array(
        [_vertex(geo, xs[i], j, zs[k]) for k in range(nz) for j in range(ny) for i in range(nx)]
    )
    blocks: list[Block] = []
    patches: dict[str, tuple[str, list[tuple[int, int, int, int]]]] = {
        # a flume's walls slip: no wall for the turbulence model's wall distance
        WALLS: ("patch" if geo.flume else "wall", []),
        TOP: ("patch", []),
    }
    if geo.flume:
        patches.update({INLET: ("patch", []), OUTLET: ("patch", [])})
    for k in range(nz - 1):
        for j in range(ny - 1):
            for i in range(nx - 1):
                corners = [vid(i, j, k), vid(i + 1, j, k), vid(i + 1, j + 1, k), vid(i, j + 1, k)]
                corners += [c + nx * ny for c in corners]
                plate = j == 1 and 0 < i < nx - 2
                zone = ("plateBelow" if k == 0 else "plateAbove") if plate else None
                sx, sy, sz = x_cells[i], y_cells[j], z_cells[k]
                blocks.append(
                    Block(
                        tuple(corners),
                        (sx.cells, sy.cells, sz.cells),
                        (sx.grading, sy.grading, sz.grading),
                        zone,
                    )
                )
                _add_wall_faces(patches, corners, i, j, k, nx, ny, nz)
    return BlockTopology(
        vertices=vertices,
        blocks=tuple(blocks),
        edges=_curved_edges(geo, xs, zs, vid),
        patches=patches,
    )


def _vertex(geo: TankGeometry, x: float, j: int, z: float) -> tuple[float, float, float]:
    half = geo.h(x) / 2
    y = (-geo.depth / 2, -half, half, geo.depth / 2)[j]
    return (float(x), y, float(z))


def _add_wall_faces(patches, corners, i, j, k, nx, ny, nz) -> None:
    def face(name: str) -> tuple[int, int, int, int]:
        a, b, c, d = (corners[n] for n in _FACE[name])
        return (a, b, c, d)

    walls, top = patches[WALLS][1], patches[TOP][1]
    front, back = (patches[INLET][1], patches[OUTLET][1]) if INLET in patches else (walls, walls)
    if i == 0:
        front.append(face("x0"))
    if i == nx - 2:
        back.append(face("x1"))
    if j == 0:
        walls.append(face("y0"))
    if j == ny - 2:
        top.append(face("y1"))
    if k == 0:
        walls.append(face("z0"))
    if k == nz - 2:
        walls.append(face("z1"))


def _curved_edges(geo: TankGeometry, xs: NDArray, zs: NDArray, vid) -> tuple:
    edges = []
    for i in range(1, len(xs) - 2):  # plate segments
        x = np.linspace(xs[i], xs[i + 1], _CURVE_POINTS)[1:-1]
        half = geo.height(x) / 2
        for k, z in enumerate(zs):
            for j, sign in ((1, -1.0), (2, 1.0)):
                pts = np.column_stack([x, sign * half, np.full_like(x, z)])
                edges.append((vid(i, j, k), vid(i + 1, j, k), pts))
    return tuple(edges)


def _x_spacings(geo: TankGeometry, res: Resolution) -> list[Spacing]:
    breaks = geo.plate_breaks
    out = [graded(-geo.x_front, res.far_m, res.edge_m)]
    n_seg = len(breaks) - 1
    for s in range(n_seg):
        seg = breaks[s + 1] - breaks[s]
        if n_seg == 1:
            out.append(two_sided(seg, res.edge_m, res.plate_m))
        elif s == 0:
            out.append(graded(seg, res.edge_m, res.plate_m))
        elif s == n_seg - 1:
            out.append(graded(seg, res.plate_m, res.edge_m))
        else:
            out.append(uniform(seg, res.plate_m))
    out.append(graded(geo.x_back - geo.length, res.edge_m, res.far_m))
    return out


def _y_spacings(geo: TankGeometry, res: Resolution) -> list[Spacing]:
    h_max = float(np.max(geo.height(np.linspace(0, geo.length, 200))))
    outer = geo.depth / 2 - h_max / 2
    return [
        graded(outer, res.far_m, res.edge_m),
        two_sided(h_max, res.edge_m, res.plate_m),
        graded(outer, res.edge_m, res.far_m),
    ]


def _z_spacings(geo: TankGeometry, res: Resolution) -> list[Spacing]:
    side = graded(geo.width / 2, res.normal_m, res.side_wall_m)
    return [Spacing(side.cells, 1 / float(side.grading)), side]  # type: ignore[arg-type]


# --------------------------------------------------------------------------- baffle dicts
def topo_set_actions() -> list[dict]:
    """Face set between the plate-row blocks above and below z = 0, oriented along +z."""
    return [
        _action("above", "cellSet", "new", "zoneToCell", {"zone": "plateAbove"}),
        _action("plate", "faceSet", "new", "cellToFace", {"set": "above", "option": "all"}),
        _action("below", "cellSet", "new", "zoneToCell", {"zone": "plateBelow"}),
        _action("plate", "faceSet", "subset", "cellToFace", {"set": "below", "option": "all"}),
        _action(
            "plate",
            "faceZoneSet",
            "new",
            "setAndNormalToFaceZone",
            {"faceSet": "plate", "normal": [0, 0, 1]},
        ),
    ]


def _action(name: str, kind: str, action: str, source: str, info: dict) -> dict:
    return {"name": name, "type": kind, "action": action, "source": source, "sourceInfo": info}


def create_baffles_dict() -> dict:
    # With the zone oriented along +z the master side is the owner, i.e. the cell below the
    # plate: its boundary face is the plate's -z face.
    return {
        "internalFacesOnly": True,
        "baffles": {
            "plate": {
                "type": "faceZone",
                "zoneName": "plate",
                "patches": {
                    "master": {"name": PATCH_MINUS_Z, "type": "wall"},
                    "slave": {"name": PATCH_PLUS_Z, "type": "wall"},
                },
            }
        },
    }
