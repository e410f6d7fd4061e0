"""Prescribed (one-way) plate kinematics: a mode shape times sin(2 pi f t).

The shape comes in as a callable, points (n, 2|3) -> translations (u_x, u_y, u_z) (n, 3),
scaled so that the tail tip (trailing edge at y = 0) moves 1 m along z; the motion moves it
``amplitude_m``. The composition root hands in the clamped fish's first mode from the shell
solver (fishfsi/cli/prescribed.py). Default amplitude: the seed's acoustic-model tail
amplitude at 3 Hz, about 20 mm (Sec. 3.4.3, Fig. 3.17; shared/reference/seed_data.toml,
robot_original.transient_acoustic).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.planform import planform

from .checkmesh import MeshQuality
from .drivers import run_batch, run_mesh_motion
from .foamrun import FoamRun
from .loads import SurfaceLoads

ACOUSTIC_TAIL_AMPLITUDE_M = 0.020  # seed Sec. 3.4.3 / Fig. 3.17, "near to 20 mm" at 3 Hz
LARGEST_TAIL_AMPLITUDE_M = 0.040  # issue 4: the seed's largest tail motion, about +-40 mm


# the unit mode shape on points: (n, 2|3) -> (n, 3), tail tip z = 1
ShapeOnPoints = Callable[[NDArray], NDArray]
# a periodic motion's harmonics on points: (n, 2|3) -> [(k, complex (n, 3))], u = sum Im(X_k e^ikwt)
HarmonicsOnPoints = Callable[[NDArray], list[tuple[int, NDArray]]]


def start_ramp(t: float, ramp_periods: float, frequency_hz: float) -> float:
    """(1 - cos) / 2 from 0 to 1 over ``ramp_periods`` periods, then 1."""
    t_ramp = ramp_periods / frequency_hz
    if t >= t_ramp:
        return 1.0
    return 0.5 * (1 - np.cos(np.pi * t / t_ramp))


@dataclass(frozen=True, kw_only=True)
class ModeMotion:
    """u(x, t) = amplitude * ramp(t) * shape(x) * sin(2 pi f t) on a fixed set of points;
    ramp rises as (1 - cos) over ``ramp_periods`` so the plate does not start with a jerk (an
    impulsive start rings the pressure for several steps)."""

    shape: NDArray  # (n, 3), tail tip z = 1
    amplitude_m: float
    frequency_hz: float
    ramp_periods: float = 0.0

    def ramp(self, t: float) -> float:
        return start_ramp(t, self.ramp_periods, self.frequency_hz)

    def displacement(self, t: float) -> NDArray:
        s = np.sin(2 * np.pi * self.frequency_hz * t)
        return self.amplitude_m * self.ramp(t) * s * self.shape


@dataclass(frozen=True, kw_only=True)
class PeriodicMotion:
    """u(x, t) = ramp(t) * sum_k Im(X_k(x) e^(i k w t)): a periodic response (a linear
    analysis's harmonics) on a fixed set of points, started with ModeMotion's ramp."""

    harmonics: list[tuple[int, NDArray]]  # (k, complex (n, 3))
    frequency_hz: float
    ramp_periods: float = 0.0

    def displacement(self, t: float) -> NDArray:
        omega = 2 * np.pi * self.frequency_hz
        u = sum(np.imag(X * np.exp(1j * k * omega * t)) for k, X in self.harmonics)
        return start_ramp(t, self.ramp_periods, self.frequency_hz) * np.asarray(u)


def mode_motion(
    shape: ShapeOnPoints,
    points: NDArray,
    amplitude_m: float,
    frequency_hz: float,
    ramp_periods: float = 0.0,
) -> ModeMotion:
    return ModeMotion(
        shape=shape(points),
        amplitude_m=amplitude_m,
        frequency_hz=frequency_hz,
        ramp_periods=ramp_periods,
    )


@dataclass(frozen=True, kw_only=True)
class PrescribedResult:
    """Loads history of a prescribed-motion run and the last step's surface loads."""

    times_s: NDArray  # (n,)
    force_n: NDArray  # (n, 3)
    moment_nm: NDArray  # (n, 3)
    last: SurfaceLoads  # pressure and face forces at the final time
    cells: int
    wall_s: float
    case_path: Path

    @property
    def thrust_n(self) -> NDArray:
        return -self.force_n[:, 0]

    def mean_thrust(self, steps_per_period: int, periods: int = 1) -> float:
        """Mean of -F_x over the last ``periods`` periods (whole periods: no phase bias)."""
        return float(self.thrust_n[-steps_per_period * periods :].mean())


def _prepare(
    case: Case, workdir: Path, dt: float, mesh_scale: float
) -> tuple[FoamRun, MeshQuality]:
    from .build import prepare_case
    from .fishmesh import FISH_PATCHES
    from .interface import read_interface
    from .tankcase import flow_settings

    _, quality = prepare_case(
        case, workdir, dt=dt, mesh_scale=mesh_scale, processes=case.fluid.processes, reuse=False
    )
    interface = read_interface(workdir, FISH_PATCHES)
    run = FoamRun(workdir, interface, flow_settings(case), case.fluid.processes)
    run.init_samples()
    return run, quality


def run_prescribed(
    case: Case,
    workdir: Path,
    shape: ShapeOnPoints,
    *,
    amplitude_m: float = ACOUSTIC_TAIL_AMPLITUDE_M,
    periods: float = 2.0,
    steps_per_period: int = 40,
    mesh_scale: float = 1.0,
    ramp_periods: float = 0.5,
    frequency_hz: float | None = None,
    write_every: int | None = None,
) -> PrescribedResult:
    """One-way run: the fish moves in ``shape``, one pimpleFoam launch."""
    f = frequency_hz or case.actuation.frequency_hz
    return _run_motion(
        case,
        workdir,
        lambda points: mode_motion(shape, points, amplitude_m, f, ramp_periods).displacement,
        f,
        periods,
        steps_per_period,
        mesh_scale,
        write_every,
    )


def run_periodic(
    case: Case,
    workdir: Path,
    harmonics: HarmonicsOnPoints,
    *,
    periods: float = 2.0,
    steps_per_period: int = 40,
    mesh_scale: float = 1.0,
    ramp_periods: float = 0.5,
    write_every: int | None = None,
) -> PrescribedResult:
    """One-way run: the fish moves in a periodic response at the case's drive frequency."""
    f = case.actuation.frequency_hz
    return _run_motion(
        case,
        workdir,
        lambda points: (
            PeriodicMotion(
                harmonics=harmonics(points), frequency_hz=f, ramp_periods=ramp_periods
            ).displacement
        ),
        f,
        periods,
        steps_per_period,
        mesh_scale,
        write_every,
    )


def _run_motion(
    case: Case,
    workdir: Path,
    motion_on: Callable[[NDArray], Callable[[float], NDArray]],
    frequency_hz: float,
    periods: float,
    steps_per_period: int,
    mesh_scale: float,
    write_every: int | None,
) -> PrescribedResult:
    dt, n = 1.0 / (frequency_hz * steps_per_period), round(periods * steps_per_period)
    start = time.perf_counter()
    run, quality = _prepare(case, workdir, dt, mesh_scale)
    displacement = motion_on(run.interface.points0)
    history = run_batch(run, displacement, dt, n, write_every=write_every)
    return PrescribedResult(
        times_s=np.array([h.time for h in history]),
        force_n=np.array([h.force for h in history]),
        moment_nm=np.array([h.moment for h in history]),
        last=history[-1],
        cells=quality.cells,
        wall_s=time.perf_counter() - start,
        case_path=workdir,
    )


def check_motion(
    case: Case,
    workdir: Path,
    shape: ShapeOnPoints,
    *,
    amplitude_m: float = LARGEST_TAIL_AMPLITUDE_M,
    periods: float = 2.0,
    steps_per_period: int = 24,
    mesh_scale: float = 1.0,
    ramp_periods: float = 0.5,
    frequency_hz: float | None = None,
) -> tuple[MeshQuality, list[MeshQuality]]:
    """The mesh alone through the prescribed motion (no flow): the generated mesh's quality
    and a full mesh check after every window."""
    f = frequency_hz or case.actuation.frequency_hz
    dt, n = 1.0 / (f * steps_per_period), round(periods * steps_per_period)
    run, quality = _prepare(case, workdir, dt, mesh_scale)
    motion = mode_motion(shape, run.interface.points0, amplitude_m, f, ramp_periods)
    counts = (quality.cells, quality.points)
    return quality, run_mesh_motion(run, motion.displacement, dt, n, counts)


def slender_body_estimate(
    case: Case,
    shape: ShapeOnPoints,
    amplitude_m: float = ACOUSTIC_TAIL_AMPLITUDE_M,
    frequency_hz: float | None = None,
    n_x: int = 120,
    n_t: int = 64,
) -> float:
    """Mean thrust (N) of the same motion from Lighthill's elongated-body theory
    (fluid_adapter.slender_body, fixed head): the CFD's first check."""
    from fluid_adapter.slender_body import slender_body_thrust

    f = frequency_hz or case.actuation.frequency_hz
    plate = planform(case)
    x = np.linspace(0.0, plate.length_m, n_x)
    midline = shape(np.column_stack([x, 0 * x]))[:, 2]
    t = np.arange(n_t) / (n_t * f)
    h = amplitude_m * np.sin(2 * np.pi * f * t)[:, None] * midline[None, :]
    history = slender_body_thrust(
        x, plate.height(x) / 2, h, t[1], density_kg_m3=case.fluid.density_kg_m3
    )
    return history.mean_thrust_n
