"""Mesh-level study of the prescribed-motion thrust at 3 Hz: error against the fine level versus
run time, to choose the default level (target, issue 4: <= 5 % thrust error).

The fish in its first clamped mode, 20 mm at the tail (seed Sec. 3.4.3), 3 Hz, k-omega SST,
backward Euler, 2 periods of 32 windows (fluid steps split further where the Courant number
exceeds fluid.max_courant); mean thrust -F_x over the second period. Also printed: Lighthill's
elongated-body estimate of the same motion (fluid_adapter.slender_body).

    .venv/bin/python benchmarks/openfoam_mesh_study.py [--levels coarse default fine]
        [--windows 32] [--json]

``--windows 64`` halves the window (and the fluid step) to separate time from space.
``--frequency 18 --amplitude-mm 9`` repeats the study at the seed's peak-thrust frequency with
the coupled runs' tail amplitude there (the same shape: a proxy for the coupled motion).
``--periods 8`` shows how fast the flow alone becomes periodic (mean thrust and lateral force
amplitude per period, ``per_period``). ``--set fluid.outer_correctors=4 --set
fluid.max_courant=10`` sets keys of the runs' case, as fsi-run's --set (docs/openfoam.md,
Pressure-velocity correctors).
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fishfsi.cli.prescribed import (
    ACOUSTIC_TAIL_AMPLITUDE_M,
    run_prescribed,
    slender_body_estimate,
)
from fsi_orchestrator.case.loader import case_from_dict, merge_overrides

PERIODS = 2


def run_level(
    level: str,
    root: Path,
    windows: int,
    frequency_hz: float = 3.0,
    amplitude_m: float = ACOUSTIC_TAIL_AMPLITUDE_M,
    periods: int = PERIODS,
    overrides: Sequence[str] = (),
) -> dict:
    raw = {
        "fluid": {"model": "openfoam", "mesh_level": level},
        "actuation": {"frequency_hz": frequency_hz},
    }
    case = case_from_dict(merge_overrides(raw, overrides), root)
    result = run_prescribed(
        case,
        root / level,
        amplitude_m=amplitude_m,
        periods=periods,
        steps_per_period=windows,
    )
    period = result.force_n[-windows:]
    each = [slice(k * windows, (k + 1) * windows) for k in range(periods)]
    return {
        "per_period": {
            "mean_thrust_n": [float(result.thrust_n[s].mean()) for s in each],
            "lateral_force_amplitude_n": [float(np.ptp(result.force_n[s, 2]) / 2) for s in each],
        },
        "level": level,
        "cells": result.cells,
        "windows_per_period": windows,
        "mean_thrust_n": result.mean_thrust(windows),
        "first_period_thrust_n": float(result.thrust_n[:windows].mean()),
        "lateral_force_amplitude_n": float((period[:, 2].max() - period[:, 2].min()) / 2),
        "wall_s": result.wall_s,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["coarse", "default", "fine"])
    parser.add_argument("--windows", type=int, default=32, help="windows per period")
    parser.add_argument("--frequency", type=float, default=3.0, help="Hz")
    parser.add_argument(
        "--amplitude-mm", type=float, default=1e3 * ACOUSTIC_TAIL_AMPLITUDE_M, help="at the tail"
    )
    parser.add_argument(
        "--periods",
        type=int,
        default=PERIODS,
        help="periods to run; the mean thrust is the last one's",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="a key of the runs' case, e.g. fluid.outer_correctors=4 (as fsi-run --set)",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="fishfsi-mesh-study-"))
    rows = []
    try:
        for level in args.levels:
            amplitude = 1e-3 * args.amplitude_mm
            rows.append(
                run_level(
                    level, root, args.windows, args.frequency, amplitude, args.periods, args.set
                )
            )
            print(json.dumps(rows[-1]), flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    reference = rows[-1]["mean_thrust_n"]
    estimate = slender_body_estimate(
        case_from_dict({"actuation": {"frequency_hz": args.frequency}}, root),
        amplitude_m=1e-3 * args.amplitude_mm,
    )
    print(f"slender-body estimate of the same motion: {estimate:.4f} N")
    for row in rows:
        error = abs(row["mean_thrust_n"] - reference) / abs(reference)
        print(
            f"{row['level']:8s} {row['cells']:7d} cells  thrust {row['mean_thrust_n']:.4f} N  "
            f"error vs {rows[-1]['level']} {error:6.1%}  lateral force amplitude "
            f"{row['lateral_force_amplitude_n']:.3f} N  wall {row['wall_s']:.0f} s"
        )


if __name__ == "__main__":
    main()
