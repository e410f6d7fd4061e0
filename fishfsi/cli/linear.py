"""The linear periodic response of the wet shell about its mean-voltage equilibrium, and what is
read from it: ``fsi-sweep --method linear``'s rows, a swimming case's figures (``fsi-run``) and the
motion the flume prescribes (flume.py).

Per frequency and harmonic (the added mass is computed once): modal superposition with static
correction, the fluid's edge drag linearized about the response itself; thrust by Lighthill's
theory on that motion, alone and with the shedding efficiency (fluid.thrust_shedding_kc).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import AnalysisKind, FluidModel, Waveform

from .compose import shell_with_fast_fluid, without_cfd
from .swimming import SWIMMING_KEYS, swimming_model

if TYPE_CHECKING:
    from solid_adapter.harmonic import ModalSweep, PeriodicResponse
    from solid_adapter.shell import ShellModel

SAMPLES_PER_PERIOD = 64
MODES = 40  # wet modes in the superposition (with static correction), up to ~300 Hz

OnRow = Callable[[str, dict, float], None]  # (point name, row, wall seconds)


class SweepError(RuntimeError):
    """A sweep that cannot go on: a launch whose MPI world does not match its tasks, a linear
    step without a finite answer (one line, non-zero exit)."""


def point_name(waveform: Waveform, frequency_hz: float) -> str:
    """A point's stable name: its run folder and its row file (``sine_3Hz``)."""
    return f"{waveform.value}_{frequency_hz:g}Hz"


@dataclass(frozen=True)
class LinearModel:
    """What every frequency's response shares: the wet shell, its mean-voltage equilibrium and
    the modal basis about it."""

    case: Case
    model: ShellModel  # with the fast fluid's added mass
    x_static: NDArray
    sweep: ModalSweep
    tip: int  # the tail tip's node

    def response(self, frequency_hz: float, waveform: Waveform) -> PeriodicResponse:
        """The periodic response to the case's drive at ``frequency_hz`` and ``waveform``; the
        edge drag's damping at that frequency."""
        from fluid_adapter.drag import edge_drag
        from solid_adapter.harmonic import damped_sweep_response, sweep_response
        from solid_adapter.piezo import DriveSignal

        case, model = self.case, self.model
        drive = DriveSignal.from_case(with_drive(case, frequency_hz, waveform))
        if case.fluid.edge_drag:
            drag = edge_drag(
                model,
                case.fluid.density_kg_m3,
                frequency_hz,
                frequency_exponent=case.fluid.edge_drag_frequency_exponent,
            )
            return damped_sweep_response(
                self.sweep,
                drive,
                self.x_static,
                drag,
                model,
                self.tip * 5 + 2,
                case_edge_inertia(case, model),
            )
        return sweep_response(self.sweep, drive, self.x_static)


def carries_edge_inertia(case: Case) -> bool:
    """The edge inertia (fluid.edge_inertia) is fitted in still liquid; a swimming body's
    edge vortices are swept off by its speed, and the swimming model leaves it out, as it
    leaves out the thrust's shedding efficiency (docs/swimming.md)."""
    return (
        case.fluid.edge_drag
        and case.fluid.edge_inertia
        and case.analysis.kind is not AnalysisKind.SWIMMING
    )


def case_edge_inertia(case: Case, model):
    """The case's edge-inertia law on ``model``'s nodes, or None where it does not apply."""
    from fluid_adapter.drag import edge_inertia

    if not carries_edge_inertia(case):
        return None
    return edge_inertia(model, case.fluid.density_kg_m3, case.fluid.edge_inertia_gamma)


def linear_model(case: Case, model: ShellModel | None = None) -> LinearModel:
    """The shell with the fast fluid about the mean voltages' equilibrium; a step without a
    finite answer (a singular or indefinite tangent) raises SweepError naming the step.
    ``model``: the case's shell with its fast fluid, when already built."""
    from solid_adapter.build import (
        mean_voltage_equilibrium,
        mean_voltage_modal_sweep,
        static_loads,
    )
    from solid_adapter.piezo import DriveSignal

    case = without_cfd(case)
    if model is None:
        model, _ = shell_with_fast_fluid(case)
    drive0 = DriveSignal.from_case(case)
    x_static = mean_voltage_equilibrium(case, model, drive0, static_loads(case, model))
    if not np.all(np.isfinite(x_static)):
        raise SweepError(
            "linear sweep, static step: the equilibrium under the mean voltages is not finite"
        )
    with np.errstate(divide="ignore", invalid="ignore"):  # checked below, in one line
        sweep = mean_voltage_modal_sweep(case, model, drive0, x_static, MODES)
    check_modal_sweep(sweep)
    tip = model.mesh.nearest_node(*model.layout.tip_point)
    return LinearModel(case=case, model=model, x_static=x_static, sweep=sweep, tip=tip)


def with_drive(case: Case, frequency_hz: float, waveform: Waveform) -> Case:
    actuation = dataclasses.replace(case.actuation, frequency_hz=frequency_hz, waveform=waveform)
    return dataclasses.replace(case, actuation=actuation)


def linear_sweep(
    case: Case,
    frequencies: list[float],
    waveforms: list[Waveform],
    done: frozenset[str] | set[str] = frozenset(),
    on_row: OnRow | None = None,
    notes: bool = True,
) -> list[dict]:
    """The rows of the points not ``done`` (point_name), each handed to ``on_row`` as it is
    finished. A step without a finite answer (a singular or indefinite tangent about the
    mean-voltage equilibrium) raises SweepError naming the step; a point whose response is
    not finite is a failed row. ``notes``: say on stderr when the response leaves small
    deflections."""
    jobs = [(w, f) for w in waveforms for f in frequencies if point_name(w, f) not in done]
    if not jobs:
        return []
    from fluid_adapter.slender_body import mean_thrust_from_shell

    linear = linear_model(case)
    model, tip = linear.model, linear.tip
    midline = _midline(model)
    xs = model.mesh.nodes[midline, 0]
    half_height = model.layout.height(xs) / 2
    swim = None
    if case.analysis.kind is AnalysisKind.SWIMMING:  # speed and turning from each motion
        swim = swimming_model(case, model, xs)
    pushes = case.fluid.model is not FluidModel.NONE  # in vacuum nothing is pushed
    length = float(np.ptp(model.mesh.nodes[:, 0]))
    rows = []
    for waveform, f in jobs:
        start = time.perf_counter()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            response = linear.response(f, waveform)
            times = np.arange(SAMPLES_PER_PERIOD + 1) / (SAMPLES_PER_PERIOD * f)
            h = response.dof_history(midline * 5 + 2, times)
            tip_z = response.dof_history(np.array([tip * 5 + 2]), times)[:, 0]
            thrusts = (
                [
                    mean_thrust_from_shell(
                        xs,
                        half_height,
                        times,
                        h,
                        density_kg_m3=case.fluid.density_kg_m3,
                        period_s=1.0 / f,
                        added_mass_coefficient=case.fluid.added_mass_coefficient,
                        shedding_kc=kc0,
                    )
                    for kc0 in (0.0, case.fluid.thrust_shedding_kc)
                ]
                if pushes
                else None
            )
        row = {
            "waveform": waveform.value,
            "frequency_hz": float(f),
            "tip_amplitude_m": float(np.ptp(tip_z) / 2),
            "status": "ok",
        }
        checked = ["tip_amplitude_m"]
        if thrusts is not None:  # Lighthill's, and the fast model's with the shedding
            row["slender_body_mean_thrust_n"] = float(thrusts[0])
            row["mean_thrust_n"] = float(thrusts[1])
            row["thrust_source"] = "slender_body"
            checked += ["slender_body_mean_thrust_n", "mean_thrust_n"]
        if swim is not None and np.all(np.isfinite(h)):
            row.update(swim.row(times, h, f))
            checked += SWIMMING_KEYS
        # the periodic response itself: no start-up to settle
        row.update(
            tip_amplitude_periodic_m=row["tip_amplitude_m"],
            tip_amplitude_periodic_uncertainty_m=0.0,
            periodic=True,
        )
        row["status"] = not_finite_status(row, checked)
        rows.append(row)
        if on_row is not None:
            on_row(point_name(waveform, f), row, time.perf_counter() - start)
    large = [(float(r["tip_amplitude_m"]), r) for r in rows]
    large = [(a, r) for a, r in large if np.isfinite(a) and a > LINEAR_RANGE * length]
    if large and notes:
        amplitude, worst = max(large, key=lambda pair: pair[0])
        print(
            f"note: the linear response exceeds a fifth of the plate's {1e3 * length:.0f} mm at "
            f"{len(large)} point(s) ({1e3 * amplitude:.0f} mm at {worst['frequency_hz']:g} Hz "
            f"{worst['waveform']}): past small deflections, near a lightly damped resonance; "
            "--method transient gives the large-deflection answer",
            file=sys.stderr,
        )
    return rows


# a tail amplitude past this fraction of the plate's length is outside the linear model
LINEAR_RANGE = 0.2


def check_modal_sweep(sweep) -> None:
    """The modal superposition needs every wet mode at a positive, finite frequency and a
    finite static correction: a singular or indefinite tangent (a mechanism, or a plate
    buckled by the mean voltages) has none."""
    omegas = np.asarray(sweep.omegas)
    bad = np.flatnonzero(~(np.isfinite(omegas) & (omegas > 0)))
    if bad.size:
        j = int(bad[0])
        raise SweepError(
            f"linear sweep, modal step: the tangent about the mean-voltage equilibrium is "
            f"singular or indefinite (wet mode {j + 1} at {omegas[j] / (2 * np.pi):.3g} Hz: a "
            "mechanism, or a plate buckled by the mean voltages), so the linear response has "
            "no finite answer; check the case with fsi-modal, or use --method transient"
        )
    if not (np.all(np.isfinite(sweep.static)) and np.all(np.isfinite(sweep.zetas))):
        raise SweepError(
            "linear sweep, static-correction step: K^-1 F about the mean-voltage equilibrium "
            "is not finite (a singular tangent); check the case with fsi-modal"
        )


def not_finite_status(row: dict, keys: Sequence[str], step: str = "linear response") -> str:
    """``row``'s status, or "failed: ..." naming the keys whose values are NaN or infinite:
    a NaN never passes as a result."""
    bad = [k for k in keys if k in row and not np.isfinite(row[k])]
    if not bad or row.get("status", "ok").startswith("failed"):
        return row.get("status", "ok")
    return f"failed: {', '.join(bad)} not finite ({step})"


def _midline(model) -> np.ndarray:
    nodes = model.mesh.nodes
    on_axis = np.flatnonzero(np.abs(nodes[:, 1]) < 1e-12 * model.layout.length_m)
    return on_axis[np.argsort(nodes[on_axis, 0])]


def swimming_summary(case: Case) -> dict:
    """fsi-run's summary of a swimming case: the figures of the case's own drive."""
    start = time.perf_counter()
    a = case.actuation
    rows = linear_sweep(without_cfd(case), [a.frequency_hz], [a.waveform])
    row = rows[0]
    if row["status"] != "ok":
        raise SweepError(f"swimming: {row['status']}")
    summary = {k: row[k] for k in SWIMMING_KEYS}
    summary.update({k: v for k, v in row.items() if k not in summary and k != "status"})
    summary["wall_s"] = time.perf_counter() - start
    return summary
