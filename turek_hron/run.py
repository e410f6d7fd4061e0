"""Turek & Hron (2006) FSI benchmarks composed: the plane-strain flag
(turek_hron.plane_strain), the channel flow (turek_hron.fsi) and the
coupling, window by window.

Steady FSI1: the flag is quasi-static (StaticFlagIntegrator) and the windows are pseudo-time:
each window is coupled implicitly (IQN-ILS) and windows run until point A stops moving. FSI3
(benchmarks/turek_hron_fsi3.py): the dynamic flag, run for a given time.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fluid_adapter.openfoam.participant import OpenFoamParticipant
from fsi_orchestrator.coupling import Coupling, CouplingSettings
from fsi_orchestrator.coupling_settings import IQNILSScheme

from .channel import DEPTH, cell_count
from .fsi import (
    FSI1,
    PerUnitDepth,
    TurekHronFsi,
    body_force_n_m,
    build_fluid,
    generate_fsi_case,
)
from .plane_strain import FlagParticipant, build_flag_participant


@dataclass
class FsiHistory:
    """Per window: time (s), point A's displacement (m), drag and lift on cylinder + flag (N/m),
    fluid solves."""

    cells: int = 0
    time_s: list[float] = field(default_factory=list)
    tip_m: list[NDArray] = field(default_factory=list)
    drag_n_m: list[float] = field(default_factory=list)
    lift_n_m: list[float] = field(default_factory=list)
    fluid_solves: list[int] = field(default_factory=list)
    wall_s: float = 0.0

    def arrays(self) -> dict[str, NDArray]:
        return {
            "t": np.array(self.time_s),
            "ux": np.array([u[0] for u in self.tip_m]),
            "uy": np.array([u[1] for u in self.tip_m]),
            "drag": np.array(self.drag_n_m),
            "lift": np.array(self.lift_n_m),
        }


StopFn = Callable[[FsiHistory], bool]


def run_coupled(
    fluid: OpenFoamParticipant,
    solid: FlagParticipant,
    coupling: CouplingSettings,
    *,
    dt: float,
    max_windows: int,
    stop: StopFn | None = None,
    progress: Callable[[FsiHistory], None] | None = None,
) -> FsiHistory:
    """Couple window by window until ``stop(history)`` or ``max_windows``."""
    per_depth = PerUnitDepth(fluid, DEPTH)
    loop = Coupling(per_depth, solid.interface().points, coupling)
    history = FsiHistory(cells=cell_count(fluid.run.path))
    start = wallclock.perf_counter()
    try:
        for window in range(max_windows):
            info = loop.solve_window(solid, dt, window)
            force = body_force_n_m(fluid)
            history.time_s.append(solid.time)
            history.tip_m.append(np.asarray(solid.monitor()["tip_displacement_m"])[:2].copy())
            history.drag_n_m.append(float(force[0]))
            history.lift_n_m.append(float(force[1]))
            history.fluid_solves.append(int(info["coupling/fluid_solves"]))
            history.wall_s = wallclock.perf_counter() - start
            if progress is not None:
                progress(history)
            if stop is not None and stop(history):
                break
    finally:  # a diverged run leaves no process or pipe behind
        fluid.finalize()
    return history


def steady_reached(tolerance_rel: float, span: int = 3) -> StopFn:
    """Point A stayed within ``tolerance_rel`` of its last displacement over the last ``span``
    windows (one window's change alone is fooled by the turning points of the slow, damped
    approach to the steady state)."""

    def stop(h: FsiHistory) -> bool:
        if len(h.tip_m) <= span:
            return False
        last = h.tip_m[-1]
        change = max(np.linalg.norm(last - u) for u in h.tip_m[-1 - span : -1])
        return bool(change < tolerance_rel * np.linalg.norm(last))

    return stop


def flag_participant(
    bench: TurekHronFsi, *, static: bool, elements: tuple[int, int]
) -> FlagParticipant:
    """The benchmark's flag (arc clamp on the cylinder), undeformed; ``static``: quasi-static."""
    return build_flag_participant(
        density_kg_m3=bench.solid_density_kg_m3,
        shear_modulus_pa=bench.shear_modulus_pa,
        poisson_ratio=bench.poisson_ratio,
        elements=elements,
        static=static,
    )


def run_fsi1(
    workdir: Path,
    *,
    body_size: float = 2.5e-3,
    far_size: float = 0.02,
    dt: float = 0.5,
    max_windows: int = 24,
    tolerance_rel: float = 2e-3,
    elements: tuple[int, int] = (40, 4),
    max_courant: float = 4.0,
    progress: Callable[[FsiHistory], None] | None = None,
) -> FsiHistory:
    """FSI1 to its steady state: rigid-flag simpleFoam start, then windows of ``dt`` seconds of
    pseudo-time (quasi-static flag, IQN-ILS per window) until point A moves less than
    ``tolerance_rel`` of its displacement over three windows. PISO (one outer corrector): at
    Courant 2 the window values equal two outer correctors' to 1e-4, at 0.8 x the cost; at
    Courant 4 (half the steps) the steady state is Courant 2's to 5e-4."""
    settings = generate_fsi_case(
        workdir,
        FSI1,
        body_size=body_size,
        far_size=far_size,
        max_courant=max_courant,
        n_outer=1,
    )
    fluid = build_fluid(workdir / "fsi", settings, dt, max_windows)
    solid = flag_participant(FSI1, static=True, elements=elements)
    coupling = CouplingSettings(
        scheme_settings=IQNILSScheme(initial_relaxation=0.5, max_iterations=20), tolerance_rel=1e-4
    )
    return run_coupled(
        fluid,
        solid,
        coupling,
        dt=dt,
        max_windows=max_windows,
        stop=steady_reached(tolerance_rel),
        progress=progress,
    )
