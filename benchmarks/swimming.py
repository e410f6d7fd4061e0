"""Swimming of the three robots (issue 31): speed, BL/s and swimming number against frequency,
sine and square, from the fast model (fluid_adapter/swimming.py), the turning rates of the
seed's asymmetric drives, and each curve's run time (target <= 1 min).

    python benchmarks/swimming.py [--write-docs]

``--write-docs`` replaces the generated part of docs/swimming.md. About 10 min on 2 cores.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.linear import linear_sweep, swimming_summary  # noqa: E402
from fishfsi.cli.sweep import parse_frequencies  # noqa: E402
from fishfsi.cli.swimming import MEASURED  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402
from fsi_orchestrator.case.schema import Waveform  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "swimming.md"
START, END = "<!-- swimming benchmark: start -->", "<!-- swimming benchmark: end -->"
FREQUENCIES = sorted({*parse_frequencies("2:30:2"), 15.0, 25.0})
SWIM = ("analysis.kind=swimming",)
ROBOTS = {  # the calibrated robot cases (cases/seed), swimming freely
    "original": (ROOT / "cases/swim_original_18Hz", ()),
    "serial": (ROOT / "cases/seed/serial_prototype", SWIM),
    "integrative": (ROOT / "cases/seed/integrative_prototype", SWIM),
}
# the seed's turning drives (Sec. 4.5, Sec. 5.4.2), square wave
TURNS = {
    "original, right turn, 18 Hz": (
        "original",
        ["actuation.frequency_hz=18", "actuation.right_volts=[-500.0, 500.0]"],
        MEASURED["original"]["turning_deg_s"],
    ),
    "integrative, left turn, 15 Hz": (
        "integrative",
        [
            "actuation.frequency_hz=15",
            "actuation.waveform='square'",
            "actuation.left_volts=[-500.0, 500.0]",
        ],
        MEASURED["integrative"]["turning_deg_s"],
    ),
    # the case's mean_strain_transfer = 0 holds no mean strain, so no mean bend to turn with;
    # over a turn of seconds the bond has no time to creep
    "integrative, left turn, 15 Hz, mean strain held": (
        "integrative",
        [
            "actuation.frequency_hz=15",
            "actuation.waveform='square'",
            "actuation.left_volts=[-500.0, 500.0]",
            "actuation.mean_strain_transfer=1.0",
        ],
        MEASURED["integrative"]["turning_deg_s"],
    ),
}


def curves() -> tuple[dict, dict]:
    rows, seconds = {}, {}
    for robot, (folder, overrides) in ROBOTS.items():
        case = load_case(folder, overrides)
        for waveform in (Waveform.SINE, Waveform.SQUARE):
            start = time.perf_counter()
            rows[robot, waveform.value] = linear_sweep(case, FREQUENCIES, [waveform])
            seconds[robot, waveform.value] = time.perf_counter() - start
            print(f"{robot} {waveform.value}: {seconds[robot, waveform.value]:.0f} s", flush=True)
    return rows, seconds


# the seed's least energy per distance over its frequencies, H = W / V (eq. 5-13, from the
# measured electrical energy), and 16 % of it, the MFC's best share of useful work (eq. 5-14;
# Sec. 5.3.2, 5.4.2): the old robot's 0.16 J/m of useful work, the serial's least H 2.3 J/m
# (0.37 useful), the integrative's 2.1 J/m (0.34); the seed does not say at which frequency
SEED_WORK_PER_DISTANCE_J_M = {
    "original": (0.16 / 0.16, 0.16),
    "serial": (2.3, 0.37),
    "integrative": (2.1, 0.34),
}
# a frequency the seed measured each robot's swimming at (square wave): the original's and the
# serial's top speeds, the integrative's turn
MEASURED_AT_HZ = {"original": 18.0, "serial": 25.0, "integrative": 15.0}
STILL_MOTION = "swimming.speed_coupling=false"
STRIP = "swimming.section_added_mass=strip"  # elongated-body theory's own rho pi b^2


def motion_at_speed_against_still() -> dict:
    """Each robot at its measured frequency, square wave: the figures of the motion at the
    swimming speed and of the motion in still liquid."""
    found = {}
    for robot, (folder, base) in ROBOTS.items():
        drive = [f"actuation.frequency_hz={MEASURED_AT_HZ[robot]:g}", "actuation.waveform='square'"]
        found[robot] = tuple(
            swimming_summary(load_case(folder, [*base, *drive, *extra]))
            for extra in ((), (STILL_MOTION,))
        )
        print(f"{robot}: {found[robot][0]['swimming_speed_m_s']:.2f} m/s", flush=True)
    return found


def turns() -> dict:
    found = {}
    for name, (robot, overrides, measured) in TURNS.items():
        folder, base = ROBOTS[robot]
        summary = swimming_summary(load_case(folder, [*base, *overrides]))
        found[name] = (summary, measured)
        print(f"{name}: {summary['turning_rate_deg_s']:+.1f} deg/s", flush=True)
    return found


# springs under the head (boundary.head = "elastic"): what the seed leaves open restraining it
HEAD_SPRINGS_N_PER_M = (None, 1e3, 3e3, 1e4, 3e4)


def head_springs() -> list[tuple[float | None, dict, dict]]:
    """The original robot at 18 Hz square with its head free, then on springs: speed with
    each thrust model and the tail amplitude."""
    folder, base = ROBOTS["original"]
    found = []
    for k in HEAD_SPRINGS_N_PER_M:
        held = (
            []
            if k is None
            else ["boundary.head=elastic", f"boundary.support_stiffness_n_per_m={k:g}"]
        )
        by_model = {
            m: swimming_summary(
                load_case(folder, [*base, *held, f"swimming.thrust_model={m}", STILL_MOTION, STRIP])
            )
            for m in ("lighthill", "pressure")
        }
        found.append((k, by_model["lighthill"], by_model["pressure"]))
        print(f"head springs {k}: {by_model['pressure']['swimming_speed_m_s']:.2f} m/s", flush=True)
    return found


def strip_against_potential() -> dict:
    """Each robot's 3D potential added mass over the strip theory's (rho pi b^2 per length)
    on its first two wet bending modes, free in the tank, and its square-wave speed curve
    with the strip's own added mass (swimming.section_added_mass = "strip")."""
    import numpy as np

    from fishfsi.cli.fast_model import linear_model, without_cfd
    from fluid_adapter.strip import strip_added_mass
    from solid_adapter.shell import NDOF
    from solid_adapter.solvers import mode_kind

    found = {}
    for robot, (folder, base) in ROBOTS.items():
        case = load_case(folder, [*base, STRIP])
        linear = linear_model(without_cfd(case))
        model, sweep = linear.model, linear.sweep
        strip = strip_added_mass(model, case.fluid.density_kg_m3).matrix
        ratios = []
        for j in range(sweep.rigid, len(sweep.omegas)):
            shape = sweep.shapes[j]
            if mode_kind(model, shape) != "bending":
                continue
            z = shape[2::NDOF]
            ratio = float(shape @ (model.added_mass @ shape) / (z @ strip @ z))
            ratios.append((sweep.omegas[j] / (2 * np.pi), ratio))
            if len(ratios) == 2:
                break
        found[robot] = (ratios, linear_sweep(case, FREQUENCIES, [Waveform.SQUARE]))
        print(f"{robot}: 3D / strip {ratios[0][1]:.2f}", flush=True)
    return found


def report(
    rows: dict, seconds: dict, turning: dict, springs: list, coupling: dict, strip: dict
) -> str:
    lines = [
        START,
        "",
        "Generated by `python benchmarks/swimming.py --write-docs` (the cases' default shell "
        "level, graded; potential flow in the tank for the added mass, edge drag; ITTC 1957 "
        "skin friction).",
        "",
        "| robot | waveform | peak speed [m/s] at [Hz] | peak BL/s | Sw at the peak | max Sw "
        "(f) | speed at 18 / 25 Hz [m/s] | curve time [s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (robot, waveform), sel in rows.items():
        best = max(sel, key=lambda r: r["swimming_speed_m_s"])
        sw = max(sel, key=lambda r: r["swimming_number"])
        at = {r["frequency_hz"]: r["swimming_speed_m_s"] for r in sel}
        lines.append(
            f"| {robot} | {waveform} | {best['swimming_speed_m_s']:.2f} at "
            f"{best['frequency_hz']:g} | {best['body_lengths_per_s']:.1f} | "
            f"{best['swimming_number']:.2f} | {sw['swimming_number']:.2f} "
            f"({sw['frequency_hz']:g} Hz) | {at.get(18.0, float('nan')):.2f} / "
            f"{at.get(25.0, float('nan')):.2f} | "
            f"{seconds[robot, waveform]:.0f} |"
        )
    lines += [
        "",
        "Measured (square wave): original 0.72 m/s at 18 Hz (4.3 BL/s; Sec. 4.4); serial "
        "0.792 m/s at 25 Hz, 4.6 BL/s, Sw 0.6 (Sec. 5.3.2, Table 5.8); integrative 3.5 BL/s, "
        "Sw 0.75 (Table 5.8).",
        "",
        "Each robot at a frequency the seed measured it at, square wave: the motion at the "
        "swimming speed (the default) and the motion in still liquid (`--set "
        "swimming.speed_coupling=false`); the actuators' mechanical work per distance "
        "beside the seed's least energy per distance over its frequencies (eq. 5-13, measured "
        "electrical) and the MFC's best share of it as useful work (16 %, eq. 5-14):",
        "",
        "| robot, f | speed [m/s] (still liquid's motion) | measured [m/s] | tail swing at "
        "speed [mm] (in still liquid) | actuators' power [W] | work per distance [J/m] | "
        "seed: least electrical / 16 % of it [J/m] |",
        "|---|---|---|---|---|---|---|",
    ]
    measured_speed = {
        "original": f"{MEASURED['original']['speed_m_s']:.2f}",
        "serial": f"{MEASURED['serial']['speed_m_s']:.3f}",
        "integrative": "- (3.5 BL/s max)",
    }
    for robot, (at_speed, still) in coupling.items():
        electrical, useful = SEED_WORK_PER_DISTANCE_J_M[robot]
        lines.append(
            f"| {robot}, {MEASURED_AT_HZ[robot]:g} Hz | {at_speed['swimming_speed_m_s']:.2f} "
            f"({still['swimming_speed_m_s']:.2f}) | {measured_speed[robot]} | "
            f"{at_speed['tip_amplitude_at_speed_m'] * 1e3:.1f} "
            f"({still['tip_amplitude_m'] * 1e3:.1f}) | {at_speed['drive_power_at_speed_w']:.2f} | "
            f"{at_speed.get('work_per_distance_j_m', float('nan')):.2f} | {electrical:.1f} / "
            f"{useful:.2f} |"
        )
    lines += [
        "",
        "| turning drive | model [deg/s] | measured [deg/s] | speed [m/s] | sideslip [deg] |",
        "|---|---|---|---|---|",
    ]
    for name, (s, measured) in turning.items():
        lines.append(
            f"| {name} | {s['turning_rate_deg_s']:+.1f} | {measured:+.1f} | "
            f"{s['swimming_speed_m_s']:.2f} | {s['slip_deg']:+.2f} |"
        )
    lines += [
        "",
        "Original robot, 18 Hz square, head on springs (`--set boundary.head=elastic --set "
        "boundary.support_stiffness_n_per_m=K`; the springs rest under the head weight, along "
        "x, y and z), on the motion in still liquid and with the strip's added mass (`--set "
        "swimming.speed_coupling=false --set swimming.section_added_mass=strip`: the flume's "
        "CFD below was made and compared so):",
        "",
        "| head | tail amplitude [mm] | speed, Lighthill's thrust [m/s] | speed, pressure "
        "share [m/s] | pressure share's thrust there [N] |",
        "|---|---|---|---|---|",
    ]
    for k, lighthill, pressure in springs:
        head = "free" if k is None else f"springs {k:g} N/m"
        lines.append(
            f"| {head} | {lighthill['tip_amplitude_m'] * 1e3:.1f} | "
            f"{lighthill['swimming_speed_m_s']:.2f} | {pressure['swimming_speed_m_s']:.2f} | "
            f"{pressure['pressure_thrust_at_speed_n']:+.3f} |"
        )
    lines += [
        "",
        "The 3D potential flow's added mass against the strip theory's (free, in the tank): "
        "phi^T M_3D phi / phi^T M_strip phi on each robot's first two wet bending modes, the "
        "strip with rho pi b^2 (gamma = 1). The first is the gamma of `swimming."
        'section_added_mass = "matched"` (the default); the speeds beside it are the '
        "square wave's with it and with `--set swimming.section_added_mass=strip` (gamma = 1):",
        "",
        "| robot | 3D / strip, 1st bending (f [Hz]) | 2nd bending (f [Hz]) | speed at the "
        "measured f, matched / strip [m/s] | peak speed, strip [m/s] at [Hz] |",
        "|---|---|---|---|---|",
    ]
    for robot, (ratios, curve) in strip.items():
        (f1, r1), (f2, r2) = ratios
        f = MEASURED_AT_HZ[robot]
        matched = {r["frequency_hz"]: r["swimming_speed_m_s"] for r in rows[robot, "square"]}
        at = {r["frequency_hz"]: r["swimming_speed_m_s"] for r in curve}
        best = max(curve, key=lambda r: r["swimming_speed_m_s"])
        lines.append(
            f"| {robot} | {r1:.2f} ({f1:.1f}) | {r2:.2f} ({f2:.1f}) | "
            f"{matched.get(f, float('nan')):.2f} / {at.get(f, float('nan')):.2f} at {f:g} Hz "
            f"| {best['swimming_speed_m_s']:.2f} at {best['frequency_hz']:g} |"
        )
    lines += [
        "",
        f"Per speed curve ({len(FREQUENCIES)} frequencies, 2-30 Hz) " + _timing(seconds),
        "",
        END,
    ]
    return "\n".join(lines)


def _timing(seconds: dict) -> str:
    values = sorted(seconds.values())
    return f"{values[0]:.0f}-{values[-1]:.0f} s on this machine's 2 cores, set-up included."


def write_docs(text: str) -> None:
    doc = DOC.read_text()
    head, rest = doc.split(START, 1)
    tail = rest.split(END, 1)[1]
    DOC.write_text(head + text + tail)


def main(argv: list[str]) -> None:
    rows, seconds = curves()
    text = report(
        rows,
        seconds,
        turns(),
        head_springs(),
        motion_at_speed_against_still(),
        strip_against_potential(),
    )
    print(text)
    if "--write-docs" in argv:
        write_docs(text)
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main(sys.argv[1:])
