"""Case -> OpenFOAM participant: generate (or reuse) the case folder, decompose, pick a driver."""

from __future__ import annotations

import hashlib
import json
import math
import os
import warnings
from dataclasses import asdict
from pathlib import Path

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import FluidDriver
from fsi_orchestrator.case.timing import case_schedule

from . import runner
from .casefiles import fv_solution
from .checkmesh import MeshQuality, parse
from .drivers import PersistentDriver, RelaunchDriver
from .fishmesh import FISH_PATCHES, TankGeometry, tank_geometry
from .flow_start import FlowSource
from .foamio import write_dict
from .foamrun import FoamRun
from .interface import FluidInterface, read_interface
from .motion import write_diffusivity
from .participant import OpenFoamParticipant
from .slices import Surface, fish_surfaces
from .tankcase import flow_settings, generate_tank_case

FINGERPRINT = "fishfsi-case.json"
# [fluid] keys that only set the PIMPLE loop: a reused folder gets its fvSolution rewritten,
# and a folder generated before they existed (a run resumed across versions) stays reusable
SOLUTION_KEYS = ("outer_correctors", "non_orthogonal_correctors")
# [fluid] keys added later that the folder does not depend on at all (the fast model's thrust
# and edge inertia)
UNUSED_KEYS = ("thrust_shedding_kc", "edge_inertia", "edge_inertia_gamma")


def fingerprint(case: Case, mesh_scale: float, processes: int) -> str:
    """What the generated folder depends on (geometry and fluid sections, mesh scale)."""
    left_out = SOLUTION_KEYS + UNUSED_KEYS
    fluid = {k: v for k, v in asdict(case.fluid).items() if k not in left_out}
    data = {
        "geometry": asdict(case.geometry),
        "fluid": fluid,
        "mesh_scale": mesh_scale,
        "processes": processes,
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def decompose(path: Path, processes: int, geometry: TankGeometry) -> None:
    """Hierarchical split along x (the notes: scotch is a stub in this build). decomposePar
    leaves constant/ alone, so each processor gets its own motion diffusivity."""
    write_dict(
        path / "system" / "decomposeParDict",
        {
            "numberOfSubdomains": processes,
            "method": "hierarchical",
            "coeffs": {"n": [processes, 1, 1], "order": "xyz"},
            "hierarchicalCoeffs": {"n": [processes, 1, 1], "order": "xyz"},
        },
    )
    runner.utility("decomposePar", path, "-force")
    for processor in sorted(path.glob("processor[0-9]*")):
        write_diffusivity(processor, geometry)


def prepare_case(
    case: Case, workdir: Path, *, dt: float, mesh_scale: float, processes: int, reuse: bool
) -> tuple[bool, MeshQuality]:
    """Generate the case in ``workdir`` unless an identical one is there. Returns (fresh, q)."""
    stamp = workdir / FINGERPRINT
    key = fingerprint(case, mesh_scale, processes)
    if reuse and stamp.is_file() and json.loads(stamp.read_text()).get("key") == key:
        write_dict(workdir / "system" / "fvSolution", fv_solution(flow_settings(case)))
        return False, parse((workdir / "log.checkMesh").read_text())
    generated = generate_tank_case(case, workdir, dt=dt, mesh_scale=mesh_scale)
    if processes > 1:
        decompose(workdir, processes, tank_geometry(case))
    stamp.write_text(json.dumps({"key": key, "cells": generated.quality.cells}))
    return True, generated.quality


def build_openfoam_participant(
    case: Case,
    workdir: Path,
    *,
    dt: float | None = None,
    n_windows: int | None = None,
    mesh_scale: float = 1.0,
    driver: FluidDriver | None = None,
    processes: int | None = None,
    reuse: bool = True,
    flow_from: FlowSource | None = None,
) -> OpenFoamParticipant:
    """The fish-tank fluid of ``case`` in ``workdir`` (created, or reused when it was generated
    from the same geometry/fluid settings, so a killed run can resume from its time folders).
    ``dt``/``n_windows`` default to the case's schedule; ``mesh_scale`` multiplies every cell
    size of ``fluid.mesh_level`` (tests use > 1 for small meshes). ``flow_from``: an earlier
    run's flow, mapped on where the coupling starts the fluid displaced (flow_start.py)."""
    case_dt, case_n = case_schedule(case)
    dt, n_windows = dt or case_dt, n_windows or case_n
    processes = processes or case.fluid.processes
    fresh, quality = prepare_case(
        case, workdir, dt=dt, mesh_scale=mesh_scale, processes=processes, reuse=reuse
    )
    interface = read_interface(workdir, FISH_PATCHES)
    run = FoamRun(workdir, interface, flow_settings(case), processes)
    if fresh:
        run.init_samples()
    kind = driver or case.fluid.driver
    blocked = runner.unreachable_for_nobody(workdir) if kind is FluidDriver.PERSISTENT else None
    if blocked is not None and driver is None:
        warnings.warn(
            f"fluid.driver = \"persistent\" runs OpenFOAM as 'nobody' when root (systemCall "
            f"is disabled for root), which cannot pass {blocked}: using the relaunch driver "
            "(about 10 % slower with implicit coupling). Write the output under a "
            "world-searchable folder such as /tmp (--output) to keep pimpleFoam loaded.",
            stacklevel=2,
        )
        kind = FluidDriver.RELAUNCH
    if kind is FluidDriver.PERSISTENT:
        chosen: RelaunchDriver | PersistentDriver = PersistentDriver(
            run, dt, n_windows, prelaunch=_prelaunch(case, processes)
        )
    else:
        chosen = RelaunchDriver(run, dt, prelaunch=_prelaunch(case, processes))
    windows_per_period = max(1, round(1.0 / (case.actuation.frequency_hz * dt)))
    participant = OpenFoamParticipant(
        run,
        chosen,
        dt=dt,
        n_windows=n_windows,
        flow_surfaces=flow_surfaces(case, interface),
        flow_from=flow_from,
        drift_reset_windows=windows_per_period,
    )
    participant.mesh_quality = quality
    return participant


def flow_surfaces(case: Case, interface: FluidInterface) -> tuple[Surface, ...]:
    omega = 2 * math.pi * case.actuation.frequency_hz
    q_level = case.output.vortex_q_level * omega**2
    return fish_surfaces(interface.points0, FISH_PATCHES, q_level)


def _prelaunch(case: Case, processes: int) -> bool:
    """Start the process a repeated window needs while the window is solved (drivers.py): only
    where windows are repeated (implicit coupling), serial, with a second core for its start-up."""
    repeats = case.coupling.scheme.iterates
    return repeats and processes == 1 and (os.cpu_count() or 1) >= 2
