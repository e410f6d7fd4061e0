"""Coupling predictors on the main job: fluid solves per window, period by period.

The predictor sets a window's first iterate; with a strongly contractive coupling (iqn-ils-am)
the number of fluid solves follows from how far it misses. Runs `fsi-run` on
`cases/fixed_head_3Hz` (OpenFOAM, coupled) once per predictor, one after the other, and
tabulates per period: mean fluid solves per window, median predictor miss (the first residual
over the tolerance's reference, `coupling/predictor_miss`), plus the wall time and the tail
amplitude and thrust against the first predictor's run (they agree to the coupling tolerance).

    .venv/bin/python benchmarks/coupling_predictors.py [--level coarse] [--periods 3]
        [--predictors linear,periodic]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fsi_orchestrator.case.loader import load_case  # noqa: E402
from fsi_orchestrator.case.timing import windows_per_period  # noqa: E402

CASE = ROOT / "cases" / "fixed_head_3Hz"


def fsi_run_per_period(out: Path, *settings: str) -> dict:
    """`fsi-run` on the main job with `--set` ``settings``: its --json summary plus, per period,
    the mean fluid solves per window, the median predictor miss and the median contraction of
    the first quasi-Newton update (predictor miss over the second residual)."""
    command = [str(Path(sys.executable).with_name("fsi-run")), str(CASE), "--output", str(out)]
    command += ["--json", "--quiet", "--overwrite"]  # a rerun of the benchmark replaces it
    for setting in settings:
        command += ["--set", setting]
    env = {**os.environ, "HDF5_USE_FILE_LOCKING": "FALSE"}
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        raise SystemExit(f"fsi-run failed ({out.name}):\n{done.stderr[-2000:]}")
    summary = json.loads(done.stdout)
    with h5py.File(out / "results.h5", "r") as h5:
        solves = h5["coupling/fluid_solves"][:, 0]
        miss = h5["coupling/predictor_miss"][:, 0]
        contraction = miss / h5["coupling/updated_miss"][:, 0]
    n = windows_per_period(load_case(CASE))
    per = [slice(k, k + n) for k in range(0, len(solves), n)]
    summary["solves_per_period"] = [float(solves[s].mean()) for s in per]
    summary["miss_per_period"] = [float(np.median(miss[s])) for s in per]
    summary["contraction_per_period"] = [float(np.median(contraction[s])) for s in per]
    return summary


def run(predictor: str, level: str, periods: int, out: Path) -> dict:
    return fsi_run_per_period(
        out,
        f"fluid.mesh_level={level}",
        f"time.periods={periods}",
        f"coupling.predictor={predictor}",
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", default="coarse", choices=["coarse", "default", "fine"])
    parser.add_argument("--periods", type=int, default=3)
    parser.add_argument("--predictors", default="linear,periodic")
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for predictor in args.predictors.split(","):
            rows[predictor] = run(predictor, args.level, args.periods, Path(tmp) / predictor)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    first = next(iter(rows.values()))
    print(f"fixed_head_3Hz, level {args.level}, {args.periods} periods after the lead-in")
    print(
        "| predictor | solves/window per period | median miss per period | wall s "
        "| tail amp. diff | thrust diff |"
    )
    print("|---|---|---|---|---|---|")
    for name, r in rows.items():
        solves = " / ".join(f"{v:.2f}" for v in r["solves_per_period"])
        miss = " / ".join(f"{v:.1e}" for v in r["miss_per_period"])
        d_amp = r["tip_amplitude_m"] - first["tip_amplitude_m"]
        d_thrust = r["mean_thrust_n"] - first["mean_thrust_n"]
        print(
            f"| {name} | {solves} | {miss} | {r['wall_s']:.0f} | {d_amp * 1e3:+.1e} mm "
            f"| {d_thrust:+.1e} N |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
