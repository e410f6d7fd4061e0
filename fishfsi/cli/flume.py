"""The flume check of the swimming model with CFD (docs/swimming.md): the free fish's periodic
motion, from the fast model, prescribed in OpenFOAM with a uniform inflow U through the tank's
front wall and an outlet at its back wall (``fluid.inflow_m_s``).

A swimming case with ``fluid.model = "openfoam"`` runs it at ``swimming.speed_m_s``. The mean
x force on the plate is its thrust less its skin friction at that speed; the plate is a
zero-thickness baffle, so the head weight's and the float's form drag come from the swimming
model's sourced coefficients. Their balance, ``cfd_net_force_n``, is what a flume's balance
would read: 0 at the self-propelled speed. The fast model's figures at the same speed and on
the same motion stand beside it.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case, CaseError

from .common import atomic_write, json_text
from .fast_model import linear_model, without_cfd
from .linear import swimming_summary

FLUME_FILE = "flume.json"
FORCES_FILE = "flume_forces.csv"


class FlumeError(RuntimeError):
    """A flume run that gave no finite mean force."""


def free_body_harmonics(case: Case) -> tuple[NDArray, list[tuple[int, NDArray]]]:
    """The shell nodes (n, 2) and the harmonics (k, complex (n, 3)) of the nodal translations of
    the fast model's periodic response about the mean-voltage equilibrium at the case's drive
    (as fsi-sweep --method linear computes it, recoil included: the head is free), at the
    flume's speed (swimming.speed_coupling; in still liquid where that is false)."""
    from solid_adapter.shell import NDOF

    linear = linear_model(case)
    a = case.actuation
    response = linear.response(a.frequency_hz, a.waveform, case.swimming.speed_m_s or 0.0)
    harmonics = [(k, X.reshape(-1, NDOF)[:, :3]) for k, X in response.harmonics]
    return linear.model.mesh.nodes.copy(), harmonics


def flume_case(case: Case) -> Case:
    """The OpenFOAM tank turned into a flume at the swimming case's speed."""
    speed = case.swimming.speed_m_s
    if speed is None or speed <= 0:
        raise CaseError(
            'swimming.speed_m_s: a swimming case with fluid.model = "openfoam" is a flume and '
            "needs its inflow speed > 0 (e.g. --set swimming.speed_m_s=0.8)"
        )
    given = case.fluid.inflow_m_s
    if given and given != speed:
        raise CaseError(
            f"fluid.inflow_m_s = {given:g}: a swimming flume takes its inflow from "
            f"swimming.speed_m_s ({speed:g}); leave fluid.inflow_m_s unset"
        )
    return dataclasses.replace(case, fluid=dataclasses.replace(case.fluid, inflow_m_s=speed))


def period_means(times: NDArray, values: NDArray, period_s: float) -> list[float]:
    """Mean of ``values`` over each whole period (window ends at ``times``)."""
    per = round(period_s / float(times[1] - times[0]))
    whole = len(values) // per
    return [float(values[i * per : (i + 1) * per].mean()) for i in range(whole)]


def flume_summary(case: Case, output: Path, say=print) -> dict:
    """Run the flume at ``swimming.speed_m_s`` and return fsi-run's summary (also written to
    OUTPUT/flume.json, the force history to OUTPUT/flume_forces.csv)."""
    from fluid_adapter.openfoam.prescribed import run_periodic

    from .prescribed import mode_on_points

    start = time.perf_counter()
    flume = flume_case(case)
    output.mkdir(parents=True, exist_ok=True)
    fast = swimming_summary(without_cfd(case))  # thrust and drag at the same speed
    nodes, harmonics = free_body_harmonics(case)
    t = case.time
    windows = round(t.periods * t.steps_per_period)
    say(
        f"flume: OpenFOAM ({case.fluid.mesh_level.value} level), inflow "
        f"{flume.fluid.inflow_m_s:g} m/s, {windows} windows of the fast model's free-body motion"
    )
    result = run_periodic(
        flume,
        output / "fluid",
        lambda points: [(k, mode_on_points(nodes, X, points)) for k, X in harmonics],
        periods=t.periods,
        steps_per_period=t.steps_per_period,
        mesh_scale=case.fluid.mesh_scale,
    )
    period = 1.0 / case.actuation.frequency_hz
    per_period = period_means(result.times_s, result.thrust_n, period)
    if not per_period or not np.all(np.isfinite(per_period)):
        raise FlumeError(f"flume: OpenFOAM gave no finite mean force ({output / 'fluid'})")
    change = abs(per_period[-1] - per_period[-2]) if len(per_period) > 1 else float("inf")
    tolerance = t.periodic_tolerance or 0.02
    # the scale: the mean, or where that is near zero, the force's swing over the period
    last = result.thrust_n[-round(t.steps_per_period) :]
    scale = max(abs(per_period[-1]), float(np.std(last)))
    form = fast["head_weight_drag_n"] + fast["float_drag_n"]
    cfd = per_period[-1]
    summary = {
        **fast,
        "inflow_m_s": flume.fluid.inflow_m_s,
        # the plate: thrust less its skin friction, mean over the last period
        "cfd_plate_force_n": cfd,
        "cfd_plate_force_per_period_n": per_period,
        "cfd_periodic": change <= tolerance * scale,
        # with the form drag of what the baffle does not model: a flume balance's reading
        "cfd_net_force_n": cfd - form,
        "model_plate_force_n": (fast["lighthill_thrust_at_speed_n"] - fast["skin_friction_drag_n"]),
        "model_pressure_plate_force_n": (
            fast["pressure_thrust_at_speed_n"] - fast["skin_friction_drag_n"]
        ),
        "cfd_cells": result.cells,
        "cfd_wall_s": result.wall_s,
        "wall_s": time.perf_counter() - start,
    }
    history = np.column_stack([result.times_s, result.force_n])
    np.savetxt(output / FORCES_FILE, history, delimiter=",", header="t_s,Fx_n,Fy_n,Fz_n")
    atomic_write(output / FLUME_FILE, json_text(summary, indent=1))
    return summary
