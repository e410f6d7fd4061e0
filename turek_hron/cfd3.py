"""Turek & Hron (2006) CFD3: periodic vortex shedding past the cylinder with its rigid flag.

Same channel, body, mesh and fluid as CFD1 (turek_hron/channel.py) with the inflow raised to a
mean of 2 m/s (Re = 200). Reference, per unit depth (Turek & Hron 2006, Table "CFD3"): drag
439.45 +- 5.6183 N/m, lift -11.893 +- 437.81 N/m (mean +- amplitude), lift frequency
4.3956 Hz.

It is the check of the transient solver setup the fish case uses (pimpleFoam, the same
dictionaries from casefiles.py) on a flow with a sourced periodic answer, and of the
turbulence models where they should stay out of the way: this flow is laminar and resolved,
so a model should give the laminar answer. ``WALE`` does (0.2 %); ``Smagorinsky`` damps the
lift by 28 % and ``kOmegaSST`` by 7 % (tests/test_openfoam_cfd3.py, docs/openfoam.md).
The forces come from OpenFOAM's ``forces`` function object every step (test_openfoam_turek.py
ties it to the adapter's own extraction).
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fluid_adapter.openfoam import runner
from fluid_adapter.openfoam.casefiles import (
    FORCES_FO,
    TIME_PRECISION,
    FlowSettings,
    control_dict,
    fv_schemes,
    fv_solution,
    turbulence_properties,
)
from fluid_adapter.openfoam.casefiles import initial_fields as fish_fields
from fluid_adapter.openfoam.foamio import write_dict
from fluid_adapter.openfoam.foamrun import numeric_dirs
from fsi_orchestrator.case.schema import TimeScheme, Turbulence

from .channel import (
    BODY,
    DEPTH,
    INLET,
    OUTLET,
    RHO,
    SIDES,
    WALLS,
    cell_count,
    channel_fields,
    channel_settings,
    generate_steady,
    read_force_dat,
)

U_MEAN_CFD3 = 2.0
# Turek & Hron 2006, CFD3 (N/m per unit depth; Hz)
DRAG_MEAN_REF, DRAG_AMPLITUDE_REF = 439.45, 5.6183
LIFT_MEAN_REF, LIFT_AMPLITUDE_REF = -11.893, 437.81
FREQUENCY_REF_HZ = 4.3956


@dataclass(frozen=True, kw_only=True)
class Cfd3Result:
    turbulence: Turbulence
    drag_mean_n_m: float
    drag_amplitude_n_m: float
    lift_mean_n_m: float
    lift_amplitude_n_m: float
    frequency_hz: float
    periods_averaged: int
    cells: int
    steps: int
    history: NDArray  # rows (t, drag, lift) per unit depth


@dataclass(frozen=True, kw_only=True)
class Kick:
    """A transverse body force behind the flag, its sign flipped every half shedding period,
    for ``periods`` periods from ``start_s``. From rest the shedding grows out of round-off
    and saturates at ~4.5 s (4 mm mesh); kicked so, at ~2 s. 4 m/s2 for 2 periods barely
    moved the lift (+-20 N/m), hence 25."""

    start_s: float = 0.6
    periods: int = 4
    acceleration_m_s2: float = 25.0
    box: tuple[float, float, float, float] = (0.62, 0.72, 0.17, 0.23)  # x0, x1, y0, y1 (m)

    def fv_options(self) -> dict[str, dict]:
        """constant/fvOptions: one ``vectorSemiImplicitSource`` per half period on the cells
        holding a 1 cm grid of points in ``box``."""
        x0, x1, y0, y1 = self.box
        points = [
            [float(x), float(y), DEPTH / 2]
            for x in np.arange(x0, x1 + 1e-9, 0.01)
            for y in np.arange(y0, y1 + 1e-9, 0.01)
        ]
        half = 0.5 / FREQUENCY_REF_HZ
        return {
            f"kick{i}": {
                "type": "vectorSemiImplicitSource",
                "timeStart": self.start_s + i * half,
                "duration": half,
                "selectionMode": "points",
                "points": points,
                "volumeMode": "specific",  # an acceleration (m/s2)
                "injectionRateSuSp": {"U": [[0.0, self.acceleration_m_s2 * (-1) ** i, 0.0], 0.0]},
            }
            for i in range(2 * self.periods)
        }


def flow_settings(turbulence: Turbulence, max_courant: float) -> FlowSettings:
    return replace(
        channel_settings((BODY,)),
        turbulence=turbulence,
        time_scheme=TimeScheme.BACKWARD,
        moving=False,
        max_courant=max_courant,
    )


def generate_cfd3(
    case: Path,
    *,
    turbulence: Turbulence = Turbulence.LAMINAR,
    end_time_s: float = 6.0,
    max_courant: float = 2.0,
    body_size: float = 2.5e-3,
    far_size: float = 0.02,
    kick: Kick | None = None,
) -> FlowSettings:
    """Mesh the channel (as CFD1) and write a pimpleFoam case from rest in ``case``."""
    generate_steady(case, u_mean=U_MEAN_CFD3, body_size=body_size, far_size=far_size)
    s = flow_settings(turbulence, max_courant)
    _write_system(case, s, start=0.0, end=end_time_s)
    fields = channel_fields(case, u_mean=U_MEAN_CFD3, bodies=(BODY,))
    fields.update(_turbulence_fields(s))
    for name, entries in fields.items():
        write_dict(case / "0" / name, entries, field=True)
    if kick is not None:
        write_dict(case / "constant" / "fvOptions", kick.fv_options())
    return s


def continue_cfd3(
    precursor: Path,
    case: Path,
    *,
    turbulence: Turbulence,
    extra_time_s: float,
    max_courant: float = 2.0,
) -> FlowSettings:
    """``case``: a copy of the finished ``precursor`` run that continues from its last time for
    ``extra_time_s`` with ``turbulence`` (model fields initialised as in the fish case). The
    shedding takes ~4 s to develop from rest (~2 s kicked, ``Kick``); a model is switched on
    in developed flow. The precursor's ``Kick`` is left behind."""
    if case.exists():
        shutil.rmtree(case)
    shutil.copytree(
        precursor, case, ignore=shutil.ignore_patterns("postProcessing", "log.*", "fvOptions")
    )
    last = numeric_dirs(case)[-1][1]
    # a restart reads the folder timePrecision names, not the longer name OpenFOAM may have
    # written when two steps' names clashed (2.999740477687203 -> 2.9997404776872)
    named = f"{float(last):.{TIME_PRECISION}g}"
    if named != last:
        (case / last).rename(case / named)
        last = named
    s = flow_settings(turbulence, max_courant)
    _write_system(case, s, start=float(last), end=float(last) + extra_time_s)
    for name, entries in _turbulence_fields(s).items():
        write_dict(case / last / name, entries, field=True)
    return s


def _write_system(case: Path, s: FlowSettings, *, start: float, end: float) -> None:
    control = control_dict(s, start=start, end=end, dt=1e-4)
    control.update(
        startFrom="latestTime",
        maxDeltaT=2e-3,
        writeControl="runTime",
        writeInterval=end - start,
        functions={
            FORCES_FO: {
                "type": "forces",
                "libs": ["forces"],
                "patches": [BODY],
                "rho": "rhoInf",
                "rhoInf": RHO,
                "CofR": [0, 0, 0],
                "writeControl": "timeStep",
                "writeInterval": 1,
                "log": False,
            }
        },
    )
    write_dict(case / "system" / "controlDict", control)
    write_dict(case / "system" / "fvSchemes", fv_schemes(s))
    write_dict(case / "system" / "fvSolution", fv_solution(s))
    write_dict(case / "constant" / "turbulenceProperties", turbulence_properties(s))


def _turbulence_fields(s: FlowSettings) -> dict[str, dict]:
    """nut, k, omega with the fish case's wall treatment (casefiles.initial_fields) on the
    body and channel walls; fixed inflow values and zero gradient at the outlet."""
    fish = replace(s, body_patches=(BODY,), wall_patches=(WALLS,), open_patches=(INLET,))
    out = {}
    for name, entries in fish_fields(fish).items():
        if name in ("U", "p"):
            continue
        boundary = entries["boundaryField"]
        value = entries["internalField"]
        boundary[INLET] = (
            {"type": "calculated", "value": 0.0}
            if name == "nut"
            else {"type": "fixedValue", "value": value}
        )
        boundary[OUTLET] = (
            {"type": "calculated", "value": 0.0} if name == "nut" else {"type": "zeroGradient"}
        )
        boundary[SIDES] = {"type": "empty"}
        out[name] = entries
    return out


def shedding_statistics(history: NDArray, periods: int) -> dict[str, float]:
    """Mean and amplitude ((max - min) / 2) of drag and lift over the last ``periods`` lift
    periods, and the lift frequency from its upward zero crossings (linearly interpolated)."""
    t, drag, lift = history.T
    late = lift[len(lift) // 2 :]
    centred = lift - 0.5 * (late.max() + late.min())
    up = np.flatnonzero((centred[:-1] < 0) & (centred[1:] >= 0))
    crossings = t[up] - centred[up] * (t[up + 1] - t[up]) / (centred[up + 1] - centred[up])
    if len(crossings) < periods + 1:
        raise ValueError(
            f"only {len(crossings) - 1} lift periods in the history, {periods} needed: "
            "run longer (end_time_s)"
        )
    start, end = crossings[-periods - 1], crossings[-1]
    window = (t >= start) & (t <= end)
    return {
        "drag_mean_n_m": float(np.mean(drag[window])),
        "drag_amplitude_n_m": float(np.ptp(drag[window]) / 2),
        "lift_mean_n_m": float(np.mean(lift[window])),
        "lift_amplitude_n_m": float(np.ptp(lift[window]) / 2),
        "frequency_hz": float(periods / (end - start)),
    }


def run_cfd3(
    case: Path,
    *,
    turbulence: Turbulence = Turbulence.LAMINAR,
    end_time_s: float = 6.0,
    max_courant: float = 2.0,
    periods: int = 4,
    body_size: float = 2.5e-3,
    far_size: float = 0.02,
    kick: Kick | None = None,
) -> Cfd3Result:
    """Mesh, run pimpleFoam from rest to ``end_time_s`` and average over the last periods."""
    generate_cfd3(
        case,
        turbulence=turbulence,
        end_time_s=end_time_s,
        max_courant=max_courant,
        body_size=body_size,
        far_size=far_size,
        kick=kick,
    )
    return _solve(case, turbulence, periods)


def run_cfd3_from(
    precursor: Path,
    case: Path,
    *,
    turbulence: Turbulence,
    extra_time_s: float = 1.5,
    max_courant: float = 2.0,
    periods: int = 4,
) -> Cfd3Result:
    """Continue a finished run (``run_cfd3``) with another model; statistics of the new part."""
    continue_cfd3(
        precursor,
        case,
        turbulence=turbulence,
        extra_time_s=extra_time_s,
        max_courant=max_courant,
    )
    return _solve(case, turbulence, periods)


def run_cfd3_models(
    precursor: Path,
    root: Path,
    models: Sequence[Turbulence],
    *,
    extra_time_s: float = 1.5,
    periods: int = 4,
) -> dict[Turbulence, Cfd3Result]:
    """``run_cfd3_from`` for each model (in ``root / model``), all at once: pimpleFoam runs
    serial here, so side by side they use the cores a sequence of runs would leave idle."""
    with ThreadPoolExecutor(max_workers=len(models)) as pool:
        futures = {
            model: pool.submit(
                run_cfd3_from,
                precursor,
                root / model.value,
                turbulence=model,
                extra_time_s=extra_time_s,
                periods=periods,
            )
            for model in models
        }
        return {model: future.result() for model, future in futures.items()}


def _solve(case: Path, turbulence: Turbulence, periods: int) -> Cfd3Result:
    runner.utility("pimpleFoam", case)
    forces = read_force_dat(case)
    history = np.column_stack([forces[:, 0], forces[:, 1:3] / DEPTH])
    stats = shedding_statistics(_uniform(history), periods)
    return Cfd3Result(
        turbulence=turbulence,
        periods_averaged=periods,
        cells=cell_count(case),
        steps=len(forces),
        history=history,
        **stats,
    )


def _uniform(history: NDArray) -> NDArray:
    """The history resampled at its smallest step (so plain means are time averages)."""
    t = history[:, 0]
    step = float(np.min(np.diff(t)))
    grid = np.arange(t[0], t[-1], step)
    return np.column_stack([grid] + [np.interp(grid, t, c) for c in history[:, 1:].T])
