"""A coupled run started from the Jacobian another run learned (coupling.jacobian_from).

Runs `fsi-run` on `cases/fixed_head_3Hz` (OpenFOAM, iqn-ils-am) three times, one after the
other: a run at the source frequency that learns the quasi-Newton Jacobian, then the target
frequency cold (learning from scratch) and warm (starting from the source's Jacobian), and
tabulates per period the fluid solves per window and the median contraction of the first
quasi-Newton update (predictor miss over the second residual), the wall time, and the warm
run's tail amplitude and thrust against the cold one (they agree to the coupling tolerance).

    .venv/bin/python benchmarks/jacobian_warm_start.py [--level coarse] [--periods 2]
        [--source-hz 3] [--source-periods 4] [--target-hz 5]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from coupling_predictors import fsi_run_per_period  # noqa: E402


def run(out: Path, level: str, frequency_hz: float, periods: int, *extra: str) -> dict:
    return fsi_run_per_period(
        out,
        f"fluid.mesh_level={level}",
        f"actuation.frequency_hz={frequency_hz:g}",
        f"time.periods={periods}",
        *extra,
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", default="coarse", choices=["coarse", "default", "fine"])
    parser.add_argument("--periods", type=int, default=2, help="periods of the target runs")
    parser.add_argument("--source-hz", type=float, default=3.0)
    parser.add_argument("--source-periods", type=int, default=4)
    parser.add_argument("--target-hz", type=float, default=5.0)
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    rows = {}
    # OpenFOAM may run as 'nobody' (persistent driver as root): a world-searchable folder
    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        Path(tmp).chmod(0o755)
        source = Path(tmp) / "source"
        rows["source"] = run(source, args.level, args.source_hz, args.source_periods)
        rows["cold"] = run(Path(tmp) / "cold", args.level, args.target_hz, args.periods)
        warm = f"coupling.jacobian_from={source}"
        rows["warm"] = run(Path(tmp) / "warm", args.level, args.target_hz, args.periods, warm)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(
        f"fixed_head_3Hz, level {args.level}: source {args.source_hz:g} Hz x "
        f"{args.source_periods} periods; target {args.target_hz:g} Hz x {args.periods} periods"
    )
    print(
        "| run | solves/window per period | contraction per period | wall s "
        "| tail amp. / thrust vs cold |"
    )
    print("|---|---|---|---|---|")
    cold = rows["cold"]
    for name, r in rows.items():
        solves = " / ".join(f"{v:.2f}" for v in r["solves_per_period"])
        contraction = " / ".join(f"{v:.0f}x" for v in r["contraction_per_period"])
        diff = "-"
        if name == "warm":
            d_amp = r["tip_amplitude_m"] / cold["tip_amplitude_m"] - 1
            d_thrust = r["mean_thrust_n"] / cold["mean_thrust_n"] - 1
            diff = f"{d_amp:+.1e} / {d_thrust:+.1e}"
        print(f"| {name} | {solves} | {contraction} | {r['wall_s']:.0f} | {diff} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
