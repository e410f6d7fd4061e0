"""The robot model against the seed's experiments, in one report.

Calibration, on the original fish only. Two unknowns the seed does not give are fitted with
scipy.optimize to the two measured tail amplitudes of the original robot:
- the MFC's electrode spacing W (eq. 3-11);
- how far the holder grips the head (boundary.clamp_length_m).
The measurements are 19 mm at 3 Hz sine (Fig. 4.4) and 24.7 mm at 1 Hz square with the head
held (Fig. 4.8). The fit is then frozen. Everything else is a prediction:
- the wet bending modes of all three robots (Tables 3.7/4.2, 5.1/5.3, 5.5/5.7);
- the tail amplitudes of the optimized robots;
- the thrust curve's peak frequency and magnitude (Fig. 4.6);
- 5 Hz against 3 Hz thrust.
A sensitivity table shows how each output moves with the assumptions the seed leaves open.

The fast model throughout: potential flow in the tank (coarse levels), with the edge drag
fitted to OpenFOAM as the fluid damping (fluid_adapter/drag.py). Amplitudes are those of
`fsi-sweep --method linear`: the linear periodic response about the mean-voltage equilibrium,
with the drag linearized about it. Thrust is Lighthill's slender-body estimate on that
motion, each harmonic's share weighed by the shedding efficiency fitted to OpenFOAM
(fluid.thrust_shedding_kc).

    .venv/bin/python benchmarks/seed_validation.py [--json] [--write-docs]

``--write-docs`` replaces the generated part of docs/validation.md. Takes about 11 min on 2
cores.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import brentq, minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.fast_model import case_edge_inertia  # noqa: E402
from fishfsi.cli.modal import wet_modes_about_mean_voltage  # noqa: E402
from fluid_adapter.drag import edge_drag  # noqa: E402
from fluid_adapter.fast import fast_added_mass  # noqa: E402
from fluid_adapter.slender_body import mean_thrust_from_shell  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from solid_adapter.buckling import mean_voltage_buckling_factor  # noqa: E402
from solid_adapter.build import (  # noqa: E402
    build_shell_model,
    mean_voltage_equilibrium,
    mean_voltage_modal_sweep,
    static_loads,
)
from solid_adapter.harmonic import damped_sweep_response, sweep_response  # noqa: E402
from solid_adapter.piezo import DriveSignal  # noqa: E402
from solid_adapter.shell import NDOF  # noqa: E402
from solid_adapter.solvers import modal_analysis, mode_kind  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SEED = ROOT / "cases" / "seed"
DOC = ROOT / "docs" / "validation.md"
START, END = "<!-- seed_validation: start -->", "<!-- seed_validation: end -->"

# The seed's figures (shared/reference/seed_data.toml), with their sources.
MEASURED_3HZ_SINE_MM = 19.0  # Fig. 4.4, Sec. 4.2.2 (seed's simulation: 20 mm, Fig. 3.17)
MEASURED_1HZ_SQUARE_MM = 24.7  # Fig. 4.8, Sec. 4.3.2 (seed's FSI: 34 mm, Fig. 3.28)
BENDING = {  # robot: (seed's simulation, measured) bending modes, Hz
    "original": ((5.99, 24.99, 36.3), (6.0, 25.0, 36.0)),  # Tables 3.7 / 4.2
    "serial": ((3.95, 20.5, 29.0), (4.0, 21.0, 29.0)),  # Table 5.1 / 5.3
    "integrative": ((2.5, 9.5, 11.8), (2.0, 10.0, 12.0)),  # Table 5.5 / 5.7
}
CASE_OF = {
    "original": "amplitude_3Hz",
    "serial": "serial_prototype",
    "integrative": "integrative_prototype",
}
THRUST_PEAK_HZ = 18.0  # Fig. 4.6
THRUST_READABLE_N = 0.107  # 0.5 N load cell x 45 / 210 mm lever, Sec. 4.3.1
THRUST_FREQUENCIES_HZ = (1, 3, 5, 7, 10, 13, 14, 15, 16, 17, 18, 20, 22, 25)
W_BOUNDS_M = (0.3e-3, 0.8e-3)  # around the 0.51 mm the data sheet's free strain implies
HELD_BOUNDS_M = (0.008, 0.030)  # head weight's rear edge .. well into the actuator
MODES = 40  # as fsi-sweep --method linear
E_BOUNDS_PA = (15e9, 35e9)  # around the seed's three CFRP moduli, 20.05-29.5 GPa


@dataclass
class FastModel:
    """Builds the fast model of a case, keeping the added mass of each shell mesh."""

    cache: dict
    evaluations: int = 0
    # the edge drag linearized on every harmonic's velocity (False: the fundamental's alone)
    all_harmonics: bool = True

    def model(self, case):
        model = build_shell_model(case)
        key = (case.geometry.preset, case.fluid.domain, model.mesh.nodes.round(9).tobytes())
        if key not in self.cache:
            self.cache[key] = fast_added_mass(case, model)
        model.set_added_mass(self.cache[key].matrix)
        if case.fluid.edge_drag:
            model.fluid_damping = edge_drag(
                model,
                case.fluid.density_kg_m3,
                case.actuation.frequency_hz,
                all_harmonics=self.all_harmonics,
                frequency_exponent=case.fluid.edge_drag_frequency_exponent,
            )
        return model

    def orbit(self, case) -> dict:
        """Tail amplitude (mm) and slender-body mean thrust (N) of the periodic response, as
        fsi-sweep --method linear computes it: modal superposition about the mean-voltage
        equilibrium, the edge drag linearized about the response itself."""
        self.evaluations += 1
        model = self.model(case)
        drive = DriveSignal.from_case(case)
        x_static = mean_voltage_equilibrium(case, model, drive, static_loads(case, model))
        sweep = mean_voltage_modal_sweep(case, model, drive, x_static, MODES)
        nodes = model.mesh.nodes
        midline = np.flatnonzero(np.abs(nodes[:, 1]) < 1e-12)
        midline = midline[np.argsort(nodes[midline, 0])]
        tip = int(midline[-1])
        if model.fluid_damping is not None:
            inertia = case_edge_inertia(case, model)
            response = damped_sweep_response(
                sweep, drive, x_static, model.fluid_damping, model, tip * NDOF + 2, inertia
            )
        else:
            response = sweep_response(sweep, drive, x_static)
        f = case.actuation.frequency_hz
        times = np.arange(128) / (128 * f)
        xs = nodes[midline, 0]
        h = response.dof_history(midline * NDOF + 2, times)
        thrust = mean_thrust_from_shell(
            xs,
            model.layout.height(xs) / 2,
            times,
            h,
            density_kg_m3=case.fluid.density_kg_m3,
            period_s=1 / f,
            shedding_kc=case.fluid.thrust_shedding_kc,
        )
        return {"tip_mm": 1e3 * float(np.ptp(h[:, -1]) / 2), "thrust_n": float(thrust)}

    def bending_modes(self, case, count: int = 3, about_mean_voltage: bool = False) -> list[float]:
        """The first wet bending modes (fsi-modal's wet_hz); ``about_mean_voltage``: about the
        static state under the drive's mean voltages, with their prestress, as the seed's
        robots were driven when it read their modes (fsi-modal's wet_hz_at_mean_voltage)."""
        model = self.model(case)
        if about_mean_voltage:
            drive = DriveSignal.from_case(case)
            result = wet_modes_about_mean_voltage(case, model, drive, 4 * count + 2)
        else:
            result = modal_analysis(model, 4 * count + 2)
        found = [
            float(f)
            for f, s in zip(result.frequencies_hz, result.shapes, strict=True)
            if mode_kind(model, s) == "bending"
        ]
        return found[:count]


CORE_MODULUS: list[str] = []  # the fitted CFRP modulus as an override, once known


def case(name: str, *overrides: str):
    return load_case(SEED / name, ["fluid.model=potential", *CORE_MODULUS, *overrides])


def fit_core_modulus(fast: FastModel) -> float:
    """The CFRP modulus that puts the free original fish's first wet bending mode on the
    measured 6 Hz (Table 4.2). The seed's CFRP sets disagree: 20.05 / 20.5 / 29.5 GPa
    (Tables 3.2, 3.5, 3.9)."""
    target = BENDING["original"][1][0]

    def misfit(e: float) -> float:
        CORE_MODULUS[:] = [f"material.youngs_modulus_pa={float(e)!r}"]
        free = case(CASE_OF["original"], "boundary.head=free")
        return float(np.log(fast.bending_modes(free, 1)[0] / target))

    lo, hi = E_BOUNDS_PA
    if misfit(lo) > 0:
        e = lo
    elif misfit(hi) < 0:
        e = hi
    else:
        e = brentq(misfit, lo, hi, xtol=1e7)
    CORE_MODULUS[:] = [f"material.youngs_modulus_pa={float(e)!r}"]
    return float(e)


def held(w: float, length: float, *more: str):
    return case(
        "amplitude_3Hz",
        f"actuation.electrode_spacing_m={float(w)!r}",
        f"boundary.clamp_length_m={float(length)!r}",
        *more,
    )


def calibration_pair(fast: FastModel, w: float, length: float) -> np.ndarray:
    """Model tail amplitudes (mm) of the two measured settings."""
    sine = fast.orbit(held(w, length))["tip_mm"]
    square = fast.orbit(held(w, length, "actuation.frequency_hz=1.0", "actuation.waveform=square"))[
        "tip_mm"
    ]
    return np.array([sine, square])


def best_spacing(fast: FastModel, length: float) -> tuple[float, float]:
    """For one held length: the W that best fits both amplitudes in log terms (each amplitude
    is near a power of W; two evaluations fix the power) and the misfit."""
    measured = np.log([MEASURED_3HZ_SINE_MM, MEASURED_1HZ_SQUARE_MM])
    w0, w1 = 0.5e-3, 0.6e-3
    a0, a1 = np.log(calibration_pair(fast, w0, length)), np.log(calibration_pair(fast, w1, length))
    slope = (a1 - a0) / np.log(w1 / w0)
    # minimize sum (a0 + slope s - measured)^2 over s = log(w / w0)
    s = float(np.sum(slope * (measured - a0)) / np.sum(slope**2))
    w = float(np.clip(w0 * np.exp(s), *W_BOUNDS_M))
    misfit = float(np.sum((a0 + slope * np.log(w / w0) - measured) ** 2))
    return w, misfit


def calibrate(fast: FastModel) -> dict:
    modulus = fit_core_modulus(fast)
    fits: dict[float, tuple[float, float]] = {}

    def misfit(length: float) -> float:
        fits[length] = best_spacing(fast, length)
        return fits[length][1]

    result = minimize_scalar(
        misfit, bounds=HELD_BOUNDS_M, method="bounded", options={"xatol": 1e-3}
    )
    length = float(result.x)
    w = fits[length][0] if length in fits else best_spacing(fast, length)[0]
    model = calibration_pair(fast, w, length)
    # the two amplitudes cannot both be met, and along a valley of (W, held length) they are
    # missed alike (17-22 mm held within 2 % of the least misfit): the frozen values stay
    # unless the refit misses clearly less, so a rerun does not move every case by a step
    # the search took along the valley
    frozen = load_case(SEED / "amplitude_3Hz")
    w0, length0 = frozen.actuation.electrode_spacing_m, frozen.boundary.clamp_length_m
    at_frozen = calibration_pair(fast, w0, length0)
    refit = {"electrode_spacing_m": w, "clamp_length_m": length, "misfit": _misfit(model)}
    kept = _misfit(at_frozen) <= (1 + KEEP_FROZEN) * refit["misfit"]
    if kept:
        w, length, model = w0, length0, at_frozen
    return {
        "core_modulus_pa": modulus,
        "electrode_spacing_m": w,
        "clamp_length_m": length,
        "sine_3hz_mm": float(model[0]),
        "square_1hz_mm": float(model[1]),
        "misfit": _misfit(model),
        "frozen_kept": kept,
        "refit": refit,
        "tried_lengths_m": sorted(fits),
    }


# the frozen calibration stays while its misfit is within this fraction of the refit's
KEEP_FROZEN = 0.02


def _misfit(model_mm: np.ndarray) -> float:
    """Squared log misses of the two measured amplitudes (as best_spacing's)."""
    measured = np.log([MEASURED_3HZ_SINE_MM, MEASURED_1HZ_SQUARE_MM])
    return float(np.sum((np.log(model_mm) - measured) ** 2))


def predictions(fast: FastModel, w: float, length: float) -> dict:
    spacing = f"actuation.electrode_spacing_m={float(w)!r}"
    out: dict = {"modes": {}, "amplitudes": {}}
    for robot, name in CASE_OF.items():
        free = case(name, spacing, "boundary.head=free")
        out["modes"][robot] = fast.bending_modes(free)
    for robot in ("serial", "integrative"):
        name = CASE_OF[robot]
        out["amplitudes"][robot] = {
            "free_mm": fast.orbit(case(name, spacing))["tip_mm"],
            "held_mm": fast.orbit(
                case(
                    name,
                    spacing,
                    "boundary.head=clamped",
                    f"boundary.clamp_length_m={float(length)!r}",
                )
            )["tip_mm"],
        }
    thrust, clamped = [], []
    for f in THRUST_FREQUENCIES_HZ:
        drive = f"actuation.frequency_hz={f}"
        # the rig (cases/seed/thrust_rig): hinged at the nose, where the stick touches it
        thrust.append({"frequency_hz": f, **fast.orbit(case("thrust_rig", spacing, drive))})
        row = fast.orbit(held(w, length, drive, "actuation.waveform=square"))
        clamped.append({"frequency_hz": f, **row})
    out["thrust_curve"] = thrust
    out["thrust_curve_clamped"] = clamped
    return out


def sensitivity(fast: FastModel, w: float, length: float) -> list[dict]:
    """Output change per assumption change, about the calibrated model."""
    spacing = f"actuation.electrode_spacing_m={float(w)!r}"

    def outputs(held_more=(), serial_more=(), integrative_more=()) -> dict:
        sine = fast.orbit(held(w, length, *held_more))["tip_mm"]
        serial = fast.bending_modes(
            case("serial_prototype", spacing, "boundary.head=free", *serial_more), 1
        )[0]
        integrative = fast.bending_modes(
            case("integrative_prototype", spacing, "boundary.head=free", *integrative_more), 1
        )[0]
        return {"sine_3hz_mm": sine, "serial_f1_hz": serial, "integrative_f1_hz": integrative}

    base = outputs()
    rows = [{"assumption": "calibrated model", **base}]
    changes = [
        (
            "electrode spacing W +10 %",
            [f"actuation.electrode_spacing_m={1.1 * float(w)!r}"],
            [],
            [],
        ),
        ("held length +5 mm", [f"boundary.clamp_length_m={float(length) + 5e-3!r}"], [], []),
        ("no edge drag (potential flow only)", ["fluid.edge_drag=false"], [], []),
        ("structural loss factor x2 (0.026)", ["material.loss_factor=0.026"], [], []),
        ("drive model seed-stress", [], ["actuation.drive_model=seed-stress"], []),
        (
            "peduncle 10 mm further back (planform)",
            [],
            ["geometry.peduncle_x_m=0.150"],
            ["geometry.peduncle_x_m=0.150"],
        ),
        (
            "taper starts 10 mm later (planform)",
            [],
            ["geometry.taper_start_x_m=0.122"],
            ["geometry.taper_start_x_m=0.122"],
        ),
    ]
    for label, h, s, i in changes:
        row = outputs(tuple(h), tuple(s), tuple(i))
        rows.append({"assumption": label, **{k: row[k] - base[k] for k in base}, "absolute": row})
    return rows


# shares of the drive's mean induced strain that the laminate holds (actuation.mean_strain_transfer)
MEAN_HELD = (0.0, 0.25, 0.3, 0.4, 0.45, 0.5, 0.6, 1.0)


def mean_strain_held(fast: FastModel, w: float) -> list[dict]:
    """The free robots' first wet bending modes about the mean voltages' equilibrium, per
    share of the mean strain held, the same on all three (the same MFCs and bond); the
    integrative robot's on the fine shell level too, as its modes near buckling depend on
    it. None where that mean buckles the plate: the share it does so at instead."""
    from fsi_orchestrator.case import CaseError

    spacing = f"actuation.electrode_spacing_m={float(w)!r}"
    columns: dict[str, tuple[str, tuple[str, ...]]] = {
        robot: (name, ()) for robot, name in CASE_OF.items()
    }
    columns["integrative, fine shell"] = (CASE_OF["integrative"], ("mesh.level=fine",))
    rows = []
    for held_share in MEAN_HELD:
        row: dict = {"mean_strain_transfer": held_share}
        for column, (name, more) in columns.items():
            free = case(
                name,
                spacing,
                "boundary.head=free",
                f"actuation.mean_strain_transfer={held_share!r}",
                *more,
            )
            try:
                row[column] = fast.bending_modes(free, 3, about_mean_voltage=True)
            except CaseError:  # the mean buckles it: say at which share
                mean = DriveSignal.from_case(free).mean
                factor = mean_voltage_buckling_factor(fast.model(free), mean)
                row[column] = None
                row[f"{column}_buckles_at"] = held_share * factor
        rows.append(row)
    return rows


def mesh_convergence(fast: FastModel, w: float) -> list[dict]:
    """First wet bending mode of the three free robots per shell mesh level, with the columns
    graded to the outline (the product) and uniform (as before the grading), fluid coarse."""
    from solid_adapter import mesh as shell_mesh

    spacing = f"actuation.electrode_spacing_m={float(w)!r}"
    rows = []
    graded = shell_mesh.GRADING_EXPONENT
    for label, exponent in (("graded", graded), ("uniform", 0.0)):
        shell_mesh.GRADING_EXPONENT = exponent
        try:
            for level in ("coarse", "default", "fine"):
                row = {"columns": label, "level": level}
                for robot, name in CASE_OF.items():
                    free = case(name, spacing, "boundary.head=free", f"mesh.level={level}")
                    row[robot] = fast.bending_modes(free, 1)[0]
                rows.append(row)
        finally:
            shell_mesh.GRADING_EXPONENT = graded
    return rows


def _refit_note(cal: dict) -> str:
    r = cal["refit"]
    refit = (
        f"This run's refit lands at W = {1e3 * r['electrode_spacing_m']:.3f} mm and "
        f"{1e3 * r['clamp_length_m']:.1f} mm held (misfit {r['misfit']:.4f}, the squared log "
        f"misses of the two amplitudes)"
    )
    if cal["frozen_kept"]:
        return (
            f"{refit}; the frozen values miss by {cal['misfit']:.4f}, within "
            f"{100 * KEEP_FROZEN:.0f} %, and stay: the two amplitudes are missed alike along a "
            "valley of spacing and held length."
        )
    return f"{refit}, more than {100 * KEEP_FROZEN:.0f} % below the frozen values': refreeze them."


def _pct(model: float, reference: float) -> str:
    return f"{100 * (model / reference - 1):+.0f} %"


def report(
    cal: dict,
    pred: dict,
    sens: list[dict],
    conv: list[dict],
    wall_s: float,
    evaluations: int,
    held_mean: list[dict],
) -> str:
    lines = [
        START,
        "",
        "Made by `.venv/bin/python benchmarks/seed_validation.py --write-docs` "
        f"({evaluations} model evaluations, {wall_s / 60:.0f} min on 2 cores). Fast model: "
        "default shell level (columns graded to the outline), potential flow in the tank "
        "(coarse), edge drag and edge inertia fitted to OpenFOAM, the "
        "linear periodic response (fsi-sweep --method linear).",
        "",
        "**Calibration** (original fish only; fitted, then frozen in the cases):",
        "",
        "| unknown | prior range | fitted | fitted to |",
        "|---|---|---|---|",
        f"| CFRP modulus | {E_BOUNDS_PA[0] / 1e9:.0f}-{E_BOUNDS_PA[1] / 1e9:.0f} GPa (seed: "
        f"20.05 / 20.5 / 29.5) | {cal['core_modulus_pa'] / 1e9:.1f} GPa | first wet bending "
        "mode, 6 Hz (Table 4.2) |",
        f"| electrode spacing W (eq. 3-11) | {1e3 * W_BOUNDS_M[0]:.1f}-{1e3 * W_BOUNDS_M[1]:.1f}"
        f" mm | {1e3 * cal['electrode_spacing_m']:.3f} mm | both amplitudes |",
        f"| held length of the head (`boundary.clamp_length_m`) | "
        f"{1e3 * HELD_BOUNDS_M[0]:.0f}-{1e3 * HELD_BOUNDS_M[1]:.0f} mm | "
        f"{1e3 * cal['clamp_length_m']:.1f} mm | both amplitudes |",
        "",
        _refit_note(cal),
        "",
        "| experiment | seed's simulation | measured | model | error | role |",
        "|---|---|---|---|---|---|",
        f"| original, 3 Hz sine, head held (Fig. 4.4) | 20 mm | {MEASURED_3HZ_SINE_MM:g} mm | "
        f"{cal['sine_3hz_mm']:.1f} mm | {_pct(cal['sine_3hz_mm'], MEASURED_3HZ_SINE_MM)} | "
        "calibration |",
        f"| original, 1 Hz square, head held (Fig. 4.8) | 34 mm | {MEASURED_1HZ_SQUARE_MM:g} mm"
        f" | {cal['square_1hz_mm']:.1f} mm | "
        f"{_pct(cal['square_1hz_mm'], MEASURED_1HZ_SQUARE_MM)} | calibration |",
    ]
    for robot, (sim, measured) in BENDING.items():
        model = pred["modes"][robot]
        for k in range(min(len(model), len(measured))):
            role = "prediction"
            if robot == "original":
                role = "calibration" if k == 0 else "check (not fitted)"
            lines.append(
                f"| {robot}, wet bending mode {k + 1}, free | {sim[k]:g} Hz | {measured[k]:g} Hz"
                f" | {model[k]:.2f} Hz | {_pct(model[k], measured[k])} | {role} |"
            )
    seed_amp = {"serial": 52.0, "integrative": 62.0}  # Secs. 5.3.1, 5.4.1 (simulated)
    for robot, amp in pred["amplitudes"].items():
        lines.append(
            f"| {robot}, 3 Hz sine tail amplitude, free / held | {seed_amp[robot]:g} mm | - |"
            f" {amp['free_mm']:.1f} / {amp['held_mm']:.1f} mm | - | prediction |"
        )
    curve = pred["thrust_curve"]
    peak = max(curve, key=lambda r: r["thrust_n"])
    at = {r["frequency_hz"]: r["thrust_n"] for r in curve}
    lines += [
        f"| thrust rig: peak frequency (Fig. 4.6) | - | {THRUST_PEAK_HZ:g} Hz | "
        f"{peak['frequency_hz']:g} Hz | - | prediction |",
        f"| thrust rig: peak thrust | - | <= {THRUST_READABLE_N} N readable | "
        f"{peak['thrust_n']:.3f} N | - | prediction |",
        f"| thrust 5 Hz / 3 Hz (Sec. 3.5.2.4, the seed's FSI: below 1) | < 1 | - | "
        f"{at[5] / at[3]:.2f} | - | prediction |",
        "",
        "Thrust curve of the original fish on the rig (square wave, slender-body thrust on "
        "the fast model's motion with the shedding efficiency, `fluid.thrust_shedding_kc`), "
        "hinged at the nose where the stick touches it (`cases/seed/thrust_rig`), and with "
        "the head clamped as in the seed's FSI:",
        "",
        "| f [Hz] | " + " | ".join(f"{r['frequency_hz']:g}" for r in curve) + " |",
        "|---|" + "---|" * len(curve),
        "| hinged: tail [mm] | " + " | ".join(f"{r['tip_mm']:.1f}" for r in curve) + " |",
        "| hinged: thrust [mN] | " + " | ".join(f"{1e3 * r['thrust_n']:.1f}" for r in curve) + " |",
        "| clamped: tail [mm] | "
        + " | ".join(f"{r['tip_mm']:.1f}" for r in pred["thrust_curve_clamped"])
        + " |",
        "| clamped: thrust [mN] | "
        + " | ".join(f"{1e3 * r['thrust_n']:.1f}" for r in pred["thrust_curve_clamped"])
        + " |",
        "",
        "**Sensitivity** (change of each output when one assumption changes, about the "
        "calibrated model):",
        "",
        "| assumption | 3 Hz held tail [mm] | serial f1 [Hz] | integrative f1 [Hz] |",
        "|---|---|---|---|",
    ]
    for row in sens:
        fmt = "{:.2f}" if row["assumption"] == "calibrated model" else "{:+.2f}"
        lines.append(
            f"| {row['assumption']} | {fmt.format(row['sine_3hz_mm'])} | "
            f"{fmt.format(row['serial_f1_hz'])} | {fmt.format(row['integrative_f1_hz'])} |"
        )
    lines += [
        "",
        "**The mean strain held** (`actuation.mean_strain_transfer`, the same share on all "
        "three robots; the cases hold 1, 1 and 0): the first wet bending modes of the free "
        "robots about the equilibrium under the drive's mean voltages, with its prestress, as "
        "the robots were driven when the seed read their modes (`fsi-modal`'s "
        "`wet_hz_at_mean_voltage`); the integrative robot's also on the fine shell level, "
        "since near buckling they depend on it:",
        "",
        "| share held | original f1 / f2 [Hz] | serial f1 / f2 [Hz] | integrative f1 / f2 / f3 "
        "[Hz] | integrative, fine shell f1 / f2 / f3 [Hz] |",
        "|---|---|---|---|---|",
    ]
    shown = {"original": 2, "serial": 2, "integrative": 3, "integrative, fine shell": 3}
    for row in held_mean:
        cells = []
        for column, count in shown.items():
            modes = row[column]
            if modes is None:
                cells.append(f"buckles at {row[f'{column}_buckles_at']:.2f} held")
            else:
                cells.append(" / ".join(f"{f:.2f}" for f in modes[:count]))
        lines.append(f"| {row['mean_strain_transfer']:g} | " + " | ".join(cells) + " |")
    measured = [
        " / ".join(f"{f:g}" for f in BENDING[column.split(",")[0]][1][:count])
        for column, count in shown.items()
    ]
    lines.append("| measured | " + " | ".join(measured) + " |")
    lines += [
        "",
        "**Mesh convergence** (first wet bending mode, free, fluid coarse; the shell levels "
        "have 8 x 2, 16 x 4 and 32 x 8 elements before the columns are split at the layout's "
        "edges):",
        "",
        "| shell columns | level | original [Hz] | serial [Hz] | integrative [Hz] |",
        "|---|---|---|---|---|",
    ]
    for row in conv:
        lines.append(
            f"| {row['columns']} | {row['level']} | {row['original']:.2f} | "
            f"{row['serial']:.2f} | {row['integrative']:.2f} |"
        )
    lines += ["", END]
    return "\n".join(lines)


def write_docs(text: str) -> None:
    doc = DOC.read_text(encoding="utf-8")
    if START in doc and END in doc:
        head, rest = doc.split(START, 1)
        tail = rest.split(END, 1)[1]
        doc = head + text + tail
    else:
        doc = doc.rstrip("\n") + "\n\n" + text + "\n"
    DOC.write_text(doc, encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--write-docs", action="store_true")
    args = ap.parse_args()
    start = time.perf_counter()
    fast = FastModel(cache={})
    cal = calibrate(fast)
    print(f"calibrated: {cal}", file=sys.stderr, flush=True)
    pred = predictions(fast, cal["electrode_spacing_m"], cal["clamp_length_m"])
    sens = sensitivity(fast, cal["electrode_spacing_m"], cal["clamp_length_m"])
    conv = mesh_convergence(fast, cal["electrode_spacing_m"])
    held_mean = mean_strain_held(fast, cal["electrode_spacing_m"])
    wall = time.perf_counter() - start
    text = report(cal, pred, sens, conv, wall, fast.evaluations, held_mean)
    if args.write_docs:
        write_docs(text)
    if args.json:
        summary = {"calibration": cal, "predictions": pred, "sensitivity": sens}
        summary |= {"mesh_convergence": conv, "mean_strain_held": held_mean}
        print(json.dumps(summary, indent=1))
    else:
        print(text)


if __name__ == "__main__":
    main()
