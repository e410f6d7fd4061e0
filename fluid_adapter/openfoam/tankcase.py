"""Write the fish-tank case from a project case: dictionaries, mesh, baffle, checkMesh, 0/ fields.

The case folder is self-contained (re-runnable by hand: ``blockMesh; topoSet; createBaffles
-overwrite; pimpleFoam``); every program logs to ``log.<program>``.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from fsi_orchestrator.case import Case

from . import runner
from .casefiles import (
    FlowSettings,
    control_dict,
    dynamic_mesh_dict,
    fv_schemes,
    fv_solution,
    initial_fields,
    transport_properties,
    turbulence_properties,
)
from .checkmesh import MeshQuality, check_mesh
from .fishmesh import (
    FISH_PATCHES,
    INLET,
    LEVELS,
    OUTLET,
    TOP,
    WALLS,
    create_baffles_dict,
    tank_geometry,
    tank_topology,
    topo_set_actions,
)
from .foamio import write_dict
from .motion import write_diffusivity


@dataclass(frozen=True, kw_only=True)
class GeneratedCase:
    path: Path
    settings: FlowSettings
    quality: MeshQuality


def flow_settings(case: Case) -> FlowSettings:
    fl = case.fluid
    flume = fl.inflow_m_s > 0
    return FlowSettings(
        nu_m2_s=fl.kinematic_viscosity_m2_s,
        rho_kg_m3=fl.density_kg_m3,
        turbulence=fl.turbulence,
        time_scheme=fl.time_scheme,
        body_patches=FISH_PATCHES,
        wall_patches=(WALLS,),
        open_patches=(TOP,),
        inflow_m_s=fl.inflow_m_s,
        inlet_patches=(INLET,) if flume else (),
        outlet_patches=(OUTLET,) if flume else (),
        max_courant=fl.max_courant,
        n_outer=fl.outer_correctors,
        n_non_orthogonal=fl.non_orthogonal_correctors,
        # p and pFinal to 1e-5, not 1e-6: every PIMPLE outer iteration ends on pFinal in
        # v1912; at 3 Hz (default level) the thrust and lateral force kept 6 digits
        # (docs/openfoam.md, Pressure-velocity correctors)
        p_tolerance=1e-5,
    )


def write_system(path: Path, s: FlowSettings, dt: float) -> None:
    write_dict(path / "system" / "controlDict", control_dict(s, start=0.0, end=dt, dt=dt))
    write_dict(path / "system" / "fvSchemes", fv_schemes(s))
    write_dict(path / "system" / "fvSolution", fv_solution(s))
    write_dict(path / "constant" / "transportProperties", transport_properties(s))
    write_dict(path / "constant" / "turbulenceProperties", turbulence_properties(s))
    if s.moving:
        write_dict(path / "constant" / "dynamicMeshDict", dynamic_mesh_dict(s))


def write_fields(path: Path, s: FlowSettings) -> None:
    zero = path / "0"
    if zero.exists():
        shutil.rmtree(zero)
    for name, entries in initial_fields(s).items():
        write_dict(zero / name, entries, field=True)


def generate_tank_case(
    case: Case, directory: Path, *, dt: float, mesh_scale: float = 1.0
) -> GeneratedCase:
    """Build the tank case in ``directory`` (replaced if present) and check its mesh."""
    runner.check_available(("blockMesh", "topoSet", "createBaffles", "checkMesh", "pimpleFoam"))
    if directory.exists():
        shutil.rmtree(directory)
    directory.mkdir(parents=True)
    s = flow_settings(case)
    write_system(directory, s, dt)
    resolution = LEVELS[case.fluid.mesh_level].scaled(mesh_scale)
    geometry = tank_geometry(case)
    topology = tank_topology(geometry, resolution)
    write_dict(directory / "system" / "blockMeshDict", topology.dictionary())
    write_dict(directory / "system" / "topoSetDict", {"actions": topo_set_actions()})
    write_dict(directory / "system" / "createBafflesDict", create_baffles_dict())
    runner.utility("blockMesh", directory)
    runner.utility("topoSet", directory)
    runner.utility("createBaffles", directory, "-overwrite")
    quality = check_mesh(directory)
    write_diffusivity(directory, geometry)
    write_fields(directory, s)
    return GeneratedCase(path=directory, settings=s, quality=quality)
