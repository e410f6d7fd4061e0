"""Turek & Hron (2006) CFD1: steady laminar flow past the cylinder with its (rigid) flag.

Geometry (m): channel [0, 2.5] x [0, 0.41]; cylinder r = 0.05 at (0.2, 0.2); flag 0.35 x 0.02
attached behind it, its right end at x = 0.6, y in [0.19, 0.21]. Parabolic inflow of mean
0.2 m/s, rho = 1000 kg/m3, nu = 1e-3 m2/s (Re = 20). Reference forces on cylinder + flag, per
unit depth: drag 14.29 N/m, lift 1.119 N/m (Turek & Hron 2006, Table "CFD1").

Mesh: gmsh (quads, refined toward the body), one cell thick, converted by gmshToFoam. The run is
a steady simpleFoam; loads go through the adapter's own extraction (surface sampling of p and
wall shear stress, loads.read_loads), so this checks it against a sourced reference.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from foamlib import FoamFile
from numpy.typing import NDArray

from fluid_adapter.openfoam import runner
from fluid_adapter.openfoam.casefiles import FlowSettings, control_dict, fv_schemes, fv_solution
from fluid_adapter.openfoam.errors import OpenFoamRunError
from fluid_adapter.openfoam.foamio import read_boundary, write_dict
from fluid_adapter.openfoam.foamrun import numeric_dirs
from fluid_adapter.openfoam.interface import read_interface
from fluid_adapter.openfoam.loads import SurfaceLoads, read_loads
from fsi_orchestrator.case.schema import TimeScheme, Turbulence

LENGTH, HEIGHT = 2.5, 0.41
CENTRE, RADIUS = (0.2, 0.2), 0.05
FLAG_END_X, FLAG_HALF = 0.6, 0.01
U_MEAN, RHO, NU = 0.2, 1000.0, 1e-3
DEPTH = 0.01
DRAG_REF_N_M, LIFT_REF_N_M = 14.29, 1.119  # Turek & Hron 2006, CFD1
BODY, INLET, OUTLET, WALLS, SIDES = "body", "inlet", "outlet", "walls", "frontAndBack"
FLAG, CYLINDER = "flag", "cylinder"  # the body as two patches (FSI: only the flag moves)
FLAG_ROOT_X = CENTRE[0] + float(np.sqrt(RADIUS**2 - FLAG_HALF**2))  # 0.24899 m


@dataclass(frozen=True, kw_only=True)
class Cfd1Result:
    drag_n_m: float
    lift_n_m: float
    cells: int
    iterations: int
    loads: SurfaceLoads
    forces_fo_n_m: np.ndarray  # the forces function object's total, for comparison


def channel_settings(bodies: tuple[str, ...] = (BODY,), moving: bool = False) -> FlowSettings:
    return FlowSettings(
        nu_m2_s=NU,
        rho_kg_m3=RHO,
        turbulence=Turbulence.LAMINAR,
        time_scheme=TimeScheme.EULER,
        body_patches=bodies,
        wall_patches=(WALLS,),
        open_patches=(OUTLET,),
        moving=moving,
    )


def write_gmsh_mesh(
    path: Path, body_size: float, far_size: float, split_body: bool = False
) -> None:
    """2D quad mesh of the channel minus cylinder and flag, extruded one layer. The body is
    one patch ``body``, or with ``split_body`` two: ``cylinder`` and ``flag`` (the flag's two
    long sides and its free end)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        channel = occ.addRectangle(0, 0, 0, LENGTH, HEIGHT)
        disk = occ.addDisk(*CENTRE, 0, RADIUS, RADIUS)
        flag = occ.addRectangle(
            CENTRE[0], CENTRE[1] - FLAG_HALF, 0, FLAG_END_X - CENTRE[0], 2 * FLAG_HALF
        )
        body, _ = occ.fuse([(2, disk)], [(2, flag)])
        fluid, _ = occ.cut([(2, channel)], body)
        occ.synchronize()
        body_curves = [
            c for _, c in gmsh.model.getBoundary(fluid, oriented=False) if not _on_channel_edge(c)
        ]
        _size_field(body_curves, body_size, far_size)
        for name, value in (
            ("Mesh.RecombineAll", 1),
            ("Mesh.Algorithm", 8),
            ("Mesh.RecombinationAlgorithm", 1),
            ("Mesh.MshFileVersion", 2.2),
            ("Mesh.MeshSizeExtendFromBoundary", 0),
        ):
            gmsh.option.setNumber(name, value)
        layers = occ.extrude(fluid, 0, 0, DEPTH, numElements=[1], recombine=True)
        occ.synchronize()
        _physical_groups(layers, split_body)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def _on_channel_edge(curve: int) -> bool:
    import gmsh

    x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, curve)
    eps = 1e-5  # OCC pads bounding boxes by 1e-7
    return x1 < eps or x0 > LENGTH - eps or y1 < eps or y0 > HEIGHT - eps


def _size_field(body_curves: list[int], body_size: float, far_size: float) -> None:
    import gmsh

    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    field.setNumbers(dist, "CurvesList", body_curves)
    field.setNumber(dist, "Sampling", 400)
    ramp = field.add("Threshold")
    field.setNumber(ramp, "InField", dist)
    field.setNumber(ramp, "SizeMin", body_size)
    field.setNumber(ramp, "SizeMax", far_size)
    field.setNumber(ramp, "DistMin", 0.01)
    field.setNumber(ramp, "DistMax", 0.5)
    field.setAsBackgroundMesh(ramp)


def _physical_groups(extruded: list[tuple[int, int]], split_body: bool) -> None:
    import gmsh

    volumes = [t for d, t in extruded if d == 3]
    gmsh.model.addPhysicalGroup(3, volumes, name="fluid")
    bodies = (FLAG, CYLINDER) if split_body else (BODY,)
    groups: dict[str, list[int]] = {name: [] for name in (*bodies, INLET, OUTLET, WALLS, SIDES)}
    for _, s in gmsh.model.getEntities(2):
        x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(2, s)
        eps = 1e-5  # OCC pads bounding boxes by 1e-7
        if z1 - z0 < eps:
            groups[SIDES].append(s)
        elif x1 < eps:
            groups[INLET].append(s)
        elif x0 > LENGTH - eps:
            groups[OUTLET].append(s)
        elif y1 < eps or y0 > HEIGHT - eps:
            groups[WALLS].append(s)
        elif not split_body:
            groups[BODY].append(s)
        else:  # the cylinder's arcs end at x = FLAG_ROOT_X, the flag's faces reach x = 0.6
            groups[FLAG if x1 > FLAG_ROOT_X + 0.01 else CYLINDER].append(s)
    for name, surfaces in groups.items():
        gmsh.model.addPhysicalGroup(2, surfaces, name=name)


def _fix_patch_types(case: Path, bodies: tuple[str, ...] = (BODY,)) -> None:
    """gmshToFoam makes every patch a ``patch``: set the empty sides and the walls."""
    path = case / "constant" / "polyMesh" / "boundary"
    types = {SIDES: "empty", WALLS: "wall"} | dict.fromkeys(bodies, "wall")
    file = FoamFile(path)
    listed: Any = file[None]  # [(name, {type, nFaces, ...}), ...]
    entries = [(name, dict(entry)) for name, entry in listed]
    missing = set(types) - {name for name, _ in entries}
    if missing:
        raise OpenFoamRunError(f"{path}: gmshToFoam made no patch {sorted(missing)}")
    for name, entry in entries:
        if name in types:
            entry["type"] = types[name]
            entry.pop("physicalType", None)
    file[None] = entries


def inlet_velocity(case: Path, u_mean: float) -> np.ndarray:
    """Parabolic inflow of mean ``u_mean`` (maximum 1.5 u_mean) at the inlet face centres."""
    y = read_interface(case, (INLET,)).face_centres()[:, 1]
    u_in = np.zeros((len(y), 3))
    u_in[:, 0] = 1.5 * u_mean * 4 * y * (HEIGHT - y) / HEIGHT**2
    return u_in


def channel_fields(
    case: Path,
    *,
    u_mean: float,
    bodies: tuple[str, ...],
    moving: tuple[str, ...] = (),
    u_internal: np.ndarray | list[float] | None = None,
    p_internal: np.ndarray | float = 0.0,
) -> dict[str, dict]:
    """{name: entries} of 0/U and 0/p: parabolic inflow, p = 0 at the outlet, no slip on the
    walls and bodies (``moving`` bodies: ``movingWallVelocity``), empty front and back."""
    walls = {"type": "noSlip"}
    moving_wall = {"type": "movingWallVelocity", "value": [0.0, 0.0, 0.0]}
    u_bodies = {b: dict(moving_wall) if b in moving else dict(walls) for b in bodies}
    zero_gradient = {"type": "zeroGradient"}
    return {
        "U": {
            "dimensions": [0, 1, -1, 0, 0, 0, 0],
            "internalField": [0.0, 0.0, 0.0] if u_internal is None else u_internal,
            "boundaryField": {
                INLET: {"type": "fixedValue", "value": inlet_velocity(case, u_mean)},
                OUTLET: dict(zero_gradient),
                WALLS: walls,
                **u_bodies,
                SIDES: {"type": "empty"},
            },
        },
        "p": {
            "FoamFile": {"class": "volScalarField"},  # a nonuniform p is a scalar list
            "dimensions": [0, 2, -2, 0, 0, 0, 0],
            "internalField": p_internal,
            "boundaryField": {
                INLET: dict(zero_gradient),
                OUTLET: {"type": "fixedValue", "value": 0.0},
                WALLS: dict(zero_gradient),
                **{b: dict(zero_gradient) for b in bodies},
                SIDES: {"type": "empty"},
            },
        },
    }


def generate_steady(
    case: Path,
    *,
    u_mean: float = U_MEAN,
    bodies: tuple[str, ...] = (BODY,),
    body_size: float = 2.5e-3,
    far_size: float = 0.02,
    iterations: int = 3000,
) -> None:
    """Mesh the channel and write a simpleFoam case (rigid body) in ``case`` (replaced)."""
    if case.exists():
        shutil.rmtree(case)
    s = channel_settings(bodies)
    control = control_dict(s, start=0.0, end=float(iterations), dt=1.0)
    control.update(
        application="simpleFoam",
        writeControl="timeStep",
        writeInterval=iterations,
        writeFormat="ascii",
        adjustTimeStep=False,
    )
    at_write = {
        "executeControl": "writeTime",
        "executeInterval": 1,
        "writeControl": "writeTime",
        "writeInterval": 1,
    }
    control["functions"] = {name: {**fo, **at_write} for name, fo in control["functions"].items()}
    write_dict(case / "system" / "controlDict", control)
    write_dict(case / "system" / "fvSchemes", fv_schemes(s, steady=True))
    write_dict(case / "system" / "fvSolution", fv_solution(s, steady=True))
    write_dict(case / "constant" / "transportProperties", {"transportModel": "Newtonian", "nu": NU})
    write_dict(case / "constant" / "turbulenceProperties", {"simulationType": "laminar"})
    write_gmsh_mesh(case / "channel.msh", body_size, far_size, split_body=bodies != (BODY,))
    runner.utility("gmshToFoam", case, str(case / "channel.msh"))
    _fix_patch_types(case, bodies)
    for name, entries in channel_fields(case, u_mean=u_mean, bodies=bodies).items():
        write_dict(case / "0" / name, entries, field=True)


def generate_cfd1(case: Path, body_size: float = 2.5e-3, far_size: float = 0.02) -> None:
    generate_steady(case, body_size=body_size, far_size=far_size)


def cell_count(case: Path) -> int:
    """Cells of a one-layer mesh: half the faces of its empty front and back."""
    return int(read_boundary(case / "constant" / "polyMesh" / "boundary")[SIDES]["nFaces"]) // 2


def read_force_dat(case: Path) -> NDArray:
    """All rows (t, F_total (3)) of the ``forces`` function object, every launch in time order."""
    rows = []
    for folder in sorted(
        (case / "postProcessing").glob("fishForces/*"), key=lambda p: float(p.name)
    ):
        text = (folder / "force.dat").read_text().replace("(", " ").replace(")", " ")
        data = np.atleast_2d(np.loadtxt(text.splitlines(), comments="#"))
        rows.append(data[:, :4])
    return np.concatenate(rows) if rows else np.zeros((0, 4))


def run_cfd1(case: Path, body_size: float = 2.5e-3, far_size: float = 0.02) -> Cfd1Result:
    """Mesh, solve to steady state, and extract the loads (per unit depth)."""
    generate_cfd1(case, body_size, far_size)
    runner.utility("simpleFoam", case)
    last = numeric_dirs(case)[-1][1]
    body = read_interface(case, (BODY,))
    loads = read_loads(case, last, body, np.zeros_like(body.points0), RHO)
    fo = read_force_dat(case)[-1, 1:4] / DEPTH
    cells = cell_count(case)
    return Cfd1Result(
        drag_n_m=float(loads.force[0] / DEPTH),
        lift_n_m=float(loads.force[1] / DEPTH),
        cells=cells,
        iterations=int(float(last)),
        loads=loads,
        forces_fo_n_m=fo,
    )
