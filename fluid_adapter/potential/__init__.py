"""Fast fluid: incompressible potential flow around the plate, as an interface added mass.

``build_added_mass(case, shell_model)`` meshes the liquid (sphere or tank) around the shell's own
outline and returns the added-mass operator on the shell's nodal normal accelerations.
"""

from __future__ import annotations

import hashlib

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import FluidDomain, MeshLevel

from .mesh import BoxDomain, FluidMesh, MeshSizes, SphereDomain, boundary_polygon, build_fluid_mesh
from .model import AddedMass, added_mass

# Sizes as fractions of the body length: near the plate, along its outline (the pressure jump's
# square-root singularity), far away, and the distance over which the size grows. P2 elements.
# The default level is chosen in benchmarks/potential_mesh.py.
MESH_LEVELS = {
    MeshLevel.COARSE: dict(near=0.09, edge=0.03, far=0.30, growth=0.5),
    MeshLevel.DEFAULT: dict(near=0.048, edge=0.018, far=0.18, growth=0.5),
    MeshLevel.FINE: dict(near=0.03, edge=0.009, far=0.12, growth=0.5),
}


def mesh_sizes(level: MeshLevel, length_m: float) -> MeshSizes:
    s = MESH_LEVELS[level]
    return MeshSizes(
        near_plate_m=s["near"] * length_m,
        edge_m=s["edge"] * length_m,
        far_m=s["far"] * length_m,
        growth_distance_m=s["growth"] * length_m,
    )


def fluid_domain(case: Case, length_m: float) -> SphereDomain | BoxDomain:
    f = case.fluid
    if f.domain is FluidDomain.SPHERE:
        return SphereDomain(centre=(length_m / 2, 0.0, 0.0), radius_m=f.domain_diameter_m / 2)
    nose = f.tank_nose_x_m if f.tank_nose_x_m is not None else (f.tank_length_m - length_m) / 2
    return BoxDomain(
        x0=-nose,
        x1=f.tank_length_m - nose,
        y0=-f.tank_depth_m / 2,
        y1=f.tank_depth_m / 2,
        z0=-f.tank_width_m / 2,
        z1=f.tank_width_m / 2,
    )


def build_fluid(case: Case, shell_model) -> FluidMesh:
    length = shell_model.layout.length_m
    return build_fluid_mesh(
        boundary_polygon(shell_model.mesh.mesh),
        fluid_domain(case, length),
        mesh_sizes(case.fluid.mesh_level, length),
    )


_CACHE: dict[tuple, AddedMass] = {}


def build_added_mass(case: Case, shell_model) -> AddedMass:
    """The added mass of the case's liquid on this shell mesh. Kept for the process: a sweep or
    a design study over drive parameters or boundary conditions meshes and solves it once."""
    key = (
        hashlib.sha1(shell_model.mesh.nodes.tobytes()).hexdigest(),
        fluid_domain(case, shell_model.layout.length_m),
        case.fluid.mesh_level,
        case.fluid.density_kg_m3,
    )
    if key not in _CACHE:
        fluid = build_fluid(case, shell_model)
        _CACHE[key] = added_mass(fluid, shell_model.mesh.basis.probes, case.fluid.density_kg_m3)
    return _CACHE[key]


__all__ = [
    "AddedMass",
    "BoxDomain",
    "MeshSizes",
    "SphereDomain",
    "build_added_mass",
    "build_fluid",
    "fluid_domain",
    "mesh_sizes",
]
