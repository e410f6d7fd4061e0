"""Turek & Hron (2006) FSI benchmarks: the channel flow around the cylinder and the flag.

Same channel, cylinder and flag as CFD1 (turek_hron/channel.py), fluid rho = 1000 kg/m3,
nu = 1e-3 m2/s, parabolic inflow; the flag is a St. Venant-Kirchhoff solid in plane strain
(turek_hron.plane_strain, rho_s = 1000 kg/m3, nu_s = 0.4):

* FSI1: mean inflow 0.2 m/s, mu_s = 0.5e6 Pa (Re = 20): a steady deflection;
* FSI3: mean inflow 2 m/s, mu_s = 2e6 Pa (Re = 200): self-excited oscillation at about 5.3 Hz.

Fluid: the CFD1 mesh with the body split into two patches, ``cylinder`` (fixed) and ``flag``
(moving, pointMotionU from the coupling as in foamrun.py), run by pimpleFoam with
``velocityLaplacian`` motion and a quadratic inverse-distance diffusivity; the fluid starts from
a simpleFoam solution with the flag rigid. Only the flag is the coupling interface; the
cylinder's loads are read from the same surface sampling for drag and lift.

Units: the mesh is one cell (DEPTH = 0.01 m) thick, so the fluid's forces are for 0.01 m of span;
the plane-strain flag works per unit depth (N/m). ``PerUnitDepth`` divides the fluid's forces by
DEPTH on their way to the coupling; drag and lift are reported per unit depth as well.

This module is the fluid's side; the coupled runs (flag + channel + coupling) are composed in
turek_hron/run.py.
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from foamlib import FoamFieldFile
from numpy.typing import NDArray

from fluid_adapter.openfoam import runner
from fluid_adapter.openfoam.casefiles import BODY_MOTION_BC, MOTION_FIELD, FlowSettings
from fluid_adapter.openfoam.drivers import RelaunchDriver
from fluid_adapter.openfoam.foamio import write_dict
from fluid_adapter.openfoam.foamrun import FoamRun, numeric_dirs
from fluid_adapter.openfoam.interface import read_interface
from fluid_adapter.openfoam.loads import read_loads
from fluid_adapter.openfoam.participant import OpenFoamParticipant
from fluid_adapter.openfoam.tankcase import write_system
from fsi_orchestrator.case.schema import TimeScheme
from fsi_orchestrator.participant import FORCE, InterfaceMesh, Participant, State

from .channel import (
    CYLINDER,
    DEPTH,
    FLAG,
    INLET,
    OUTLET,
    SIDES,
    WALLS,
    channel_fields,
    channel_settings,
    generate_steady,
)

BODIES = (FLAG, CYLINDER)


@dataclass(frozen=True, kw_only=True)
class TurekHronFsi:
    """One benchmark's parameters and its reference values (Turek & Hron 2006, tables "FSI1"
    and "FSI3", finest level). Oscillating quantities are (mean, amplitude)."""

    name: str
    u_mean_m_s: float
    solid_density_kg_m3: float
    shear_modulus_pa: float
    poisson_ratio: float = 0.4
    ux_ref_mm: tuple[float, float]
    uy_ref_mm: tuple[float, float]
    drag_ref_n_m: tuple[float, float]
    lift_ref_n_m: tuple[float, float]
    frequency_ref_hz: float | None = None  # of uy (FSI3)


FSI1 = TurekHronFsi(
    name="FSI1",
    u_mean_m_s=0.2,
    solid_density_kg_m3=1000.0,
    shear_modulus_pa=0.5e6,
    ux_ref_mm=(0.0227, 0.0),
    uy_ref_mm=(0.8209, 0.0),
    drag_ref_n_m=(14.295, 0.0),
    lift_ref_n_m=(0.7638, 0.0),
)
FSI3 = TurekHronFsi(
    name="FSI3",
    u_mean_m_s=2.0,
    solid_density_kg_m3=1000.0,
    shear_modulus_pa=2.0e6,
    ux_ref_mm=(-2.69, 2.53),
    uy_ref_mm=(1.48, 34.38),
    drag_ref_n_m=(457.3, 22.66),
    lift_ref_n_m=(2.22, 149.78),
    frequency_ref_hz=5.3,
)


# --------------------------------------------------------------------------- the fluid case


def generate_fsi_case(
    workdir: Path,
    bench: TurekHronFsi,
    *,
    body_size: float = 2.5e-3,
    far_size: float = 0.02,
    steady_iterations: int = 3000,
    time_scheme: TimeScheme = TimeScheme.EULER,
    max_courant: float = 2.0,
    n_outer: int = 2,
) -> FlowSettings:
    """``workdir/steady``: simpleFoam with the flag rigid; ``workdir/fsi``: the pimpleFoam
    moving-mesh case on the same mesh, starting from the steady fields. Returns its settings."""
    steady, fsi = workdir / "steady", workdir / "fsi"
    generate_steady(
        steady,
        u_mean=bench.u_mean_m_s,
        bodies=BODIES,
        body_size=body_size,
        far_size=far_size,
        iterations=steady_iterations,
    )
    runner.utility("simpleFoam", steady)
    last = steady / numeric_dirs(steady)[-1][1]
    if fsi.exists():
        shutil.rmtree(fsi)
    shutil.copytree(steady / "constant" / "polyMesh", fsi / "constant" / "polyMesh")
    settings = flow_settings(time_scheme, max_courant, n_outer)
    write_system(fsi, settings, dt=1.0)
    fields = channel_fields(
        fsi,
        u_mean=bench.u_mean_m_s,
        bodies=BODIES,
        moving=(FLAG,),
        u_internal=np.asarray(FoamFieldFile(last / "U").internal_field),
        p_internal=FoamFieldFile(last / "p").internal_field,
    )
    fields[MOTION_FIELD] = point_motion()
    for name, entries in fields.items():
        write_dict(fsi / "0" / name, entries, field=True)
    return settings


def flow_settings(time_scheme: TimeScheme, max_courant: float, n_outer: int) -> FlowSettings:
    return replace(
        channel_settings(BODIES, moving=True),
        time_scheme=time_scheme,
        max_courant=max_courant,
        n_outer=n_outer,
        motion_diffusivity=("quadratic", "inverseDistance", [FLAG]),
    )


def point_motion() -> dict:
    """pointMotionU: the flag from the coupling's samples, everything else fixed, 2D sides."""
    fixed = {"type": "fixedValue", "value": [0.0, 0.0, 0.0]}
    return {
        "FoamFile": {"class": "pointVectorField"},
        "dimensions": [0, 1, -1, 0, 0, 0, 0],
        "internalField": [0.0, 0.0, 0.0],
        "boundaryField": {
            **{name: dict(fixed) for name in (INLET, OUTLET, WALLS, CYLINDER)},
            FLAG: dict(BODY_MOTION_BC),
            SIDES: {"type": "empty"},
        },
    }


def build_fluid(
    fsi: Path, settings: FlowSettings, dt: float, n_windows: int
) -> OpenFoamParticipant:
    """The flag patch of the generated case as a coupling participant (relaunch driver)."""
    run = FoamRun(fsi, read_interface(fsi, (FLAG,)), settings)
    run.init_samples()
    return OpenFoamParticipant(run, RelaunchDriver(run, dt), dt=dt, n_windows=n_windows)


class PerUnitDepth:
    """The fluid participant seen per unit depth: its forces (N on ``depth`` m of span) are
    divided by ``depth`` (-> N/m, what the plane-strain flag reads). Everything else passes
    through unchanged."""

    def __init__(self, fluid: Participant, depth_m: float) -> None:
        if not depth_m > 0:
            raise ValueError(f"`depth_m` must be > 0, got {depth_m}")
        self.fluid, self.depth_m = fluid, depth_m
        self.name = fluid.name

    @property
    def time(self) -> float:
        return self.fluid.time

    def interface(self) -> InterfaceMesh:
        return self.fluid.interface()

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        self.fluid.read_data(data)

    def solve(self, dt: float) -> None:
        self.fluid.solve(dt)

    def write_data(self) -> dict[str, NDArray]:
        data = self.fluid.write_data()
        data[FORCE] = data[FORCE] / self.depth_m
        return data

    def store_checkpoint(self) -> None:
        self.fluid.store_checkpoint()

    def restore_checkpoint(self) -> None:
        self.fluid.restore_checkpoint()

    def save_state(self) -> dict[str, NDArray | float | int]:
        return self.fluid.save_state()

    def load_state(self, state: State) -> None:
        self.fluid.load_state(state)

    def finalize(self) -> None:
        self.fluid.finalize()


def body_force_n_m(fluid: OpenFoamParticipant) -> NDArray:
    """Force on cylinder + flag per unit depth at the last window end: the flag's from the
    participant's window loads, the cylinder's from the same sampling (rigid, end value)."""
    run = fluid.run
    flag = np.asarray(fluid.monitor()["force_n"])
    cylinder = read_interface(run.path, (CYLINDER,))
    name = run.time_folder(fluid.time, fluid.dt)
    cyl = read_loads(run.path, name, cylinder, np.zeros_like(cylinder.points0), run.rho)
    return (flag + cyl.force) / DEPTH
