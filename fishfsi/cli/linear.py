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
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.schema import AnalysisKind, FluidModel, Waveform

from .fast_model import SweepError, linear_model, midline_nodes, without_cfd
from .swimming import SWIMMING_KEYS, SwimmingModel, swimming_model

if TYPE_CHECKING:
    pass

SAMPLES_PER_PERIOD = 64


OnRow = Callable[[str, dict, float], None]  # (point name, row, wall seconds)


def point_name(waveform: Waveform, frequency_hz: float) -> str:
    """A point's stable name: its run folder and its row file (``sine_3Hz``)."""
    return f"{waveform.value}_{frequency_hz:g}Hz"


def linear_sweep(
    case: Case,
    frequencies: list[float],
    waveforms: list[Waveform],
    done: frozenset[str] | set[str] = frozenset(),
    on_row: OnRow | None = None,
    notes: bool = True,
    refuse_a_bad_speed: bool = False,
) -> list[dict]:
    """The rows of the points not ``done`` (point_name), each handed to ``on_row`` as it is
    finished. A step without a finite answer (a singular or indefinite tangent about the
    mean-voltage equilibrium) raises SweepError naming the step; a point whose response is
    not finite is a failed row. ``notes``: say on stderr when the response leaves small
    deflections. ``refuse_a_bad_speed``: a prescribed swimming.speed_m_s past the motion's
    divergence speed is CaseError (fsi-run); otherwise each point fails alone (a sweep's
    folder is prepared by then)."""
    jobs = [(w, f) for w in waveforms for f in frequencies if point_name(w, f) not in done]
    if not jobs:
        return []
    from fluid_adapter.slender_body import mean_thrust_from_shell
    from fluid_adapter.swimming import SwimmingError

    linear = linear_model(case)
    model, tip = linear.model, linear.tip
    midline = midline_nodes(model)
    xs = model.mesh.nodes[midline, 0]
    half_height = model.layout.height(xs) / 2
    swim = None
    if case.analysis.kind is AnalysisKind.SWIMMING:  # speed and turning from each motion
        swim = swimming_model(case, model, xs)
        swim = dataclasses.replace(
            swim,
            max_speed_m_s=linear.divergence_speed_m_s,
            added_mass_coefficient=linear.section_added_mass_coefficient,
        )
        if refuse_a_bad_speed:
            refuse_a_speed_past_divergence(swim)
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
            "drive_power_w": linear.drive_power(response, waveform),
            "status": "ok",
        }
        checked = ["tip_amplitude_m", "drive_power_w"]
        if thrusts is not None:  # Lighthill's, and the fast model's with the shedding
            row["slender_body_mean_thrust_n"] = float(thrusts[0])
            row["mean_thrust_n"] = float(thrusts[1])
            row["thrust_source"] = "slender_body"
            checked += ["slender_body_mean_thrust_n", "mean_thrust_n"]
        if swim is not None and np.all(np.isfinite(h)):
            at_speed = _motion_at_speed(linear, f, waveform, response)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                history = partial(_history_at_speed, at_speed, midline * 5 + 2, times)
                try:
                    row.update(swim.row(times, history, f))
                except SwimmingError as err:  # this point's: the others go on
                    row["status"] = f"failed: {err}"
                else:
                    row.update(_at_the_speed(linear, at_speed, row, tip, times, waveform))
            checked += [*SWIMMING_KEYS, "tip_amplitude_at_speed_m", "drive_power_at_speed_w"]
            checked += ["work_per_distance_j_m"]
        # the periodic response itself: no start-up to settle
        row.update(
            tip_amplitude_periodic_m=row["tip_amplitude_m"],
            tip_amplitude_periodic_uncertainty_m=0.0,
            periodic=True,
        )
        row["status"] = not_finite_status(row, checked)
        if swim is not None and row["status"] == "ok":
            flags = swimming_flags(row, length)
            if flags:
                row["status"] = f"ok ({'; '.join(flags)})"
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
            "a transient run (fsi-sweep --method transient) gives the large-deflection answer",
            file=sys.stderr,
        )
    return rows


def refuse_a_speed_past_divergence(swim: SwimmingModel) -> None:
    """A prescribed swimming.speed_m_s at or past the motion's divergence speed is bad input,
    the same at every frequency: refused before the work, in one line naming the key."""
    speed = swim.prescribed_speed_m_s
    if speed is not None and speed >= swim.max_speed_m_s:
        raise CaseError(swim.past_divergence())


def _at_the_speed(linear, at_speed, row: dict, tip: int, times, waveform: Waveform) -> dict:
    """The motion's figures while the fish swims: its tail swing and the actuators' power at
    the speed (where the motion is the one at the speed), and the work per distance."""
    speed = float(row["swimming_speed_m_s"])
    found = {}
    if linear.speed_loads is not None:
        swimming = at_speed(speed)
        tip_at_speed = swimming.dof_history(np.array([tip * 5 + 2]), times)
        found["tip_amplitude_at_speed_m"] = float(np.ptp(tip_at_speed) / 2)
        found["drive_power_at_speed_w"] = linear.drive_power(swimming, waveform)
    # the seed's energy per distance (eq. 5-13), of the actuators' mechanical work
    power = float(found.get("drive_power_at_speed_w", row["drive_power_w"]))
    if speed > 0:  # a fish that does not swim has no work per distance
        found["work_per_distance_j_m"] = power / speed
    return found


def _motion_at_speed(linear, frequency_hz: float, waveform: Waveform, still):
    """The periodic response at a forward speed, remembered per speed; ``still`` at every
    speed where the motion is not coupled to the speed (swimming.speed_coupling)."""
    if linear.speed_loads is None:
        return lambda speed: still
    known: dict[float, object] = {0.0: still}

    def at(speed: float):
        if speed not in known:
            known[speed] = linear.response(frequency_hz, waveform, speed)
        return known[speed]

    return at


# a turn tighter than the body's length: the slender-body turning balance (quasi-steady, the
# body's sections in a nearly straight stream) does not hold there; at a low prescribed speed
# an asymmetric drive lands on such a root
TIGHT_TURN = "turning radius below the body length: outside the turning model"


# more than a body length per tail beat: fish swim at Sw 0.2-0.8 and the seed's robots at
# 0.6 and 0.75 at most (Table 5.8); at low frequencies a square wave's voltage steps ring the
# fin at its own modes, a thrust the drive frequency does not set (docs/swimming.md)
FAST_FOR_ITS_BEAT = "swimming number above 1: faster than a body length per drive period"


def swimming_flags(row: dict, length: float) -> list[str]:
    """What a swimming row's figures say about the model's reach (a note, not a failure)."""
    flags = []
    rate = abs(np.radians(row.get("turning_rate_deg_s", 0.0)))
    if rate > 0 and row["swimming_speed_m_s"] / rate < length:
        flags.append(TIGHT_TURN)
    if row["swimming_number"] > 1:
        flags.append(FAST_FOR_ITS_BEAT)
    return flags


def _history_at_speed(at_speed, dofs: np.ndarray, times: np.ndarray, speed: float) -> np.ndarray:
    return at_speed(speed).dof_history(dofs, times)


# a tail amplitude past this fraction of the plate's length is outside the linear model
LINEAR_RANGE = 0.2


def not_finite_status(row: dict, keys: Sequence[str], step: str = "linear response") -> str:
    """``row``'s status, or "failed: ..." naming the keys whose values are NaN or infinite:
    a NaN never passes as a result."""
    bad = [k for k in keys if k in row and not np.isfinite(row[k])]
    if not bad or row.get("status", "ok").startswith("failed"):
        return row.get("status", "ok")
    return f"failed: {', '.join(bad)} not finite ({step})"


def swimming_summary(case: Case, say_notes: bool = True) -> dict:
    """fsi-run's summary of a swimming case: the figures of the case's own drive, and
    ``notes`` (where the figures leave the model's reach; said on stderr with ``say_notes``)."""
    start = time.perf_counter()
    a = case.actuation
    rows = linear_sweep(without_cfd(case), [a.frequency_hz], [a.waveform], refuse_a_bad_speed=True)
    row = rows[0]
    if not row["status"].startswith("ok"):
        raise SweepError(f"swimming: {row['status'].removeprefix('failed: ')}")
    keys = {TIGHT_TURN: "turning_rate_deg_s", FAST_FOR_ITS_BEAT: "swimming_number"}
    flags = row["status"].removeprefix("ok (").removesuffix(")").split("; ")
    notes = [f"{flag} ({keys[flag]})" for flag in flags if flag in keys]
    if say_notes:
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
    summary = {k: row[k] for k in SWIMMING_KEYS}
    summary.update({k: v for k, v in row.items() if k not in summary and k != "status"})
    if notes:
        summary["notes"] = notes
    summary["wall_s"] = time.perf_counter() - start
    return summary
