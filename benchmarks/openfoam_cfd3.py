"""Turek & Hron CFD3 (vortex shedding, Re = 200) per turbulence model and mesh size: drag and
lift (mean, amplitude), lift frequency against the reference, and the wall time of each run.

The flow is laminar and resolved, so a turbulence model should leave it alone: how far each
model moves it from the laminar answer is its error here. As in tests/test_openfoam_cfd3.py,
a laminar run from rest develops the shedding (``--end-time``), then each model continues that
flow for ``--extra-time``; statistics over the last 4 lift periods of each.

    .venv/bin/python benchmarks/openfoam_cfd3.py [--models laminar WALE Smagorinsky kOmegaSST]
        [--body-sizes 4e-3 2.5e-3] [--end-time 6] [--extra-time 1.5] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fsi_orchestrator.case.schema import Turbulence  # noqa: E402
from turek_hron.cfd3 import (  # noqa: E402
    DRAG_AMPLITUDE_REF,
    DRAG_MEAN_REF,
    FREQUENCY_REF_HZ,
    LIFT_AMPLITUDE_REF,
    LIFT_MEAN_REF,
    run_cfd3,
    run_cfd3_from,
)

REFERENCE = {
    "drag_mean_n_m": DRAG_MEAN_REF,
    "drag_amplitude_n_m": DRAG_AMPLITUDE_REF,
    "lift_mean_n_m": LIFT_MEAN_REF,
    "lift_amplitude_n_m": LIFT_AMPLITUDE_REF,
    "frequency_hz": FREQUENCY_REF_HZ,
}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument(
        "--models", nargs="+", default=["laminar", "WALE", "Smagorinsky", "kOmegaSST"]
    )
    parser.add_argument("--body-sizes", nargs="+", type=float, default=[4e-3])
    parser.add_argument("--end-time", type=float, default=6.0)
    parser.add_argument("--extra-time", type=float, default=1.5)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for body in args.body_sizes:
            precursor = Path(tmp) / f"precursor_{body}"
            start = time.perf_counter()
            run_cfd3(precursor, body_size=body, end_time_s=args.end_time)
            report(rows, "precursor", body, start, None, args.json)
            for model in args.models:
                start = time.perf_counter()
                r = run_cfd3_from(
                    precursor,
                    Path(tmp) / f"{model}_{body}",
                    turbulence=Turbulence(model),
                    extra_time_s=args.extra_time,
                )
                report(rows, model, body, start, r, args.json)
    if args.json:
        print(json.dumps(rows))


def report(rows: list, model: str, body: float, start: float, r, quiet: bool) -> None:
    row = {"model": model, "body_size_m": body, "wall_s": time.perf_counter() - start}
    if r is not None:
        row |= {"cells": r.cells, "steps": r.steps, **{k: getattr(r, k) for k in REFERENCE}}
    rows.append(row)
    if quiet:
        return
    line = f"{model:12s} body {body * 1e3:.1f} mm {row['wall_s']:6.0f} s"
    if r is not None:
        line += f" {r.cells} cells {r.steps} steps: " + "  ".join(
            f"{k.removesuffix('_n_m').removesuffix('_hz')} {row[k]:.2f} "
            f"({100 * (row[k] - ref) / abs(ref):+.1f} %)"
            for k, ref in REFERENCE.items()
        )
    print(line, flush=True)


if __name__ == "__main__":
    main()
