"""One fluid solve per window under the plain and the smoothed period rule (docs/coupling.md,
"The explicit rule"): the coarse main job's scene with explicit-am and the delayed feedback,
per-period tail amplitude and mean thrust, the window-to-window bursts of the lateral force,
and how far the last periods lie from iterated windows continued from the smoothed run.

    .venv/bin/python benchmarks/explicit_rule.py            # ~9 min on 2 cores (OpenFOAM)
    .venv/bin/python benchmarks/explicit_rule.py --periods 8 --json

The two explicit runs go side by side (one core each); the iterated continuation follows.
The plain rule is the one explicit windows used before ``period-smooth``: the benchmark swaps
``EXPLICIT_RULES`` in the run's process.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

from fishfsi.cli.run import period_amplitudes, period_means

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "fixed_head_3Hz"
WINDOWS = 40  # the case's steps per period
RULES = {"plain": ("constant", "period"), "smooth": ("constant", "period-smooth")}
LAUNCH = """
import sys
import fsi_orchestrator.coupling as coupling
coupling.EXPLICIT_RULES = {rules!r}
from fishfsi.cli.run import main
sys.exit(main({args!r}))
"""


def fsi_run(rules: tuple[str, ...], args: list[str], log: Path) -> subprocess.Popen:
    code = LAUNCH.format(rules=rules, args=args)
    with log.open("w") as stderr:  # the child keeps its own copy of the descriptor
        return subprocess.Popen(
            [sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=stderr
        )


def per_period(folder: Path) -> dict[str, list[float]]:
    with h5py.File(folder / "results.h5") as f:
        tip = f["shell/tip_displacement_m"][:, 2]
        thrust = f["fluid/thrust_n"][:, 0]
        force = f["fluid/force_n"][:, 2]
        wall = f["wall_s"][:, 0]
    n = len(tip) // WINDOWS
    periods = [slice(k * WINDOWS, (k + 1) * WINDOWS) for k in range(n)]
    swing = (force[-WINDOWS:].max() - force[-WINDOWS:].min()) / 2
    # the lateral force's departure from the mean of its neighbours, over its swing: a pure
    # 3 Hz sine gives 1 - cos(2 pi / 40) = 0.012 at most (harmonics add to it), a burst more
    bump = np.abs(force[1:-1] - (force[:-2] + force[2:]) / 2) / swing
    return {
        "tail_mm": [1e3 * a for a in period_amplitudes(tip, WINDOWS)],
        "thrust_mn": [1e3 * m for m in period_means(thrust, WINDOWS)],
        "burst": [float(bump[max(p.start - 1, 0) : p.stop - 1].max()) for p in periods],
        "wall_s_per_window": period_means(wall, WINDOWS),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=int, default=10)
    parser.add_argument("--iterated-periods", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    opts = parser.parse_args(argv)
    common = [
        str(CASE),
        "--quiet",
        "--set", "fluid.mesh_level=coarse",
        "--set", "time.periodic_feedback_per_s=10",
    ]  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="explicit_rule_") as tmp:
        out = Path(tmp)
        explicit = [*common, "--set", "coupling.scheme=explicit-am"]
        runs = {
            name: fsi_run(
                rules,
                [*explicit, "--set", f"time.periods={opts.periods}", "--output", str(out / name)],
                out / f"{name}.log",
            )
            for name, rules in RULES.items()
        }
        for name, proc in runs.items():
            if proc.wait() != 0:
                print(f"error: the {name} run failed:\n{(out / f'{name}.log').read_text()[-2000:]}")
                return 1
        total = opts.periods + opts.iterated_periods
        iterated = [
            *common,
            "--set",
            "coupling.scheme=iqn-ils-am",
            "--set",
            f"time.periods={total}",
        ]
        subprocess.run(["cp", "-a", str(out / "smooth"), str(out / "iterated")], check=True)
        proc = fsi_run(
            RULES["smooth"],
            [*iterated, "--output", str(out / "iterated"), "--resume"],
            out / "it.log",
        )
        if proc.wait() != 0:
            print(
                f"error: the iterated continuation failed:\n{(out / 'it.log').read_text()[-2000:]}"
            )
            return 1
        result = {name: per_period(out / name) for name in (*RULES, "iterated")}
    ref = result["iterated"]
    reference = {"tail_mm": ref["tail_mm"][-1], "thrust_mn": ref["thrust_mn"][-1]}
    tail = max(opts.periods - 5, 0)
    for name in RULES:
        r = result[name]
        r["last_periods_off_iterated_pct"] = {
            key: 100 * max(abs(v / reference[key] - 1) for v in r[key][tail:]) for key in reference
        }
    if opts.json:
        print(json.dumps({"reference": reference, **result}, indent=1))
        return 0
    print(
        "iterated windows' last period (reference): "
        f"{reference['tail_mm']:.3f} mm, {reference['thrust_mn']:.2f} mN"
    )
    for name in RULES:
        r = result[name]
        print(f"\n{name} period rule, one fluid solve per window:")
        print("| period | tail [mm] | thrust [mN] | largest burst / swing | s per window |")
        print("|---|---|---|---|---|")
        for k, row in enumerate(
            zip(r["tail_mm"], r["thrust_mn"], r["burst"], r["wall_s_per_window"], strict=True)
        ):
            print(f"| {k + 1} | {row[0]:.3f} | {row[1]:.2f} | {row[2]:.3f} | {row[3]:.2f} |")
        off = r["last_periods_off_iterated_pct"]
        print(
            f"last 5 periods off the reference by up to {off['tail_mm']:.2f} % (tail), "
            f"{off['thrust_mn']:.2f} % (thrust)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
