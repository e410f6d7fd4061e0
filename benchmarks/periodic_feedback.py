"""Delayed feedback toward the periodic state (`time.periodic_feedback_per_s`): per-period tail
amplitude and mean thrust with and without it, the periods a `time.periodic_tolerance` needs,
and the wall time of each run (docs/coupling.md, "Delayed feedback toward the periodic state").

    .venv/bin/python benchmarks/periodic_feedback.py                 # fast scenes, ~2 min
    .venv/bin/python benchmarks/periodic_feedback.py --openfoam      # + coarse OpenFOAM, ~40 min
    .venv/bin/python benchmarks/periodic_feedback.py --gains 0,3,10 --json

Scenes: the piezo beam in vacuum started from rest (lightly damped: its first mode rings),
the main job's scene with the fast fluid (potential flow and the edge drag) from rest, and with
--openfoam the main job's scene on the coarse fluid level, iterated (6 periods) and explicit-am
(8 periods).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
from itertools import pairwise
from pathlib import Path

from fishfsi.cli import run as run_cli

ROOT = Path(__file__).resolve().parents[1]

BEAM = """
[geometry]
kind = "beam"
[actuation]
frequency_hz = 10.0
[analysis]
rayleigh_alpha_per_s = 3.0
[time]
periods = 12
steps_per_period = 20
[mesh]
level = "coarse"
[output]
vtk = false
"""

MAIN = str(ROOT / "cases" / "fixed_head_3Hz")
FAST = ["fluid.model=potential", "fluid.edge_drag=true", "time.start=rest", "time.periods=6"]
COARSE = ["fluid.mesh_level=coarse", "output.vtk=false"]


def scenes(beam: Path, openfoam: bool) -> dict[str, tuple[str, list[str]]]:
    out = {
        "beam in vacuum, from rest": (str(beam), ["time.start=rest"]),
        "fast fluid, from rest": (MAIN, FAST),
    }
    if openfoam:
        out["OpenFOAM coarse, iqn-ils-am"] = (MAIN, [*COARSE, "time.periods=6"])
        out["OpenFOAM coarse, explicit-am"] = (
            MAIN,
            [*COARSE, "coupling.scheme=explicit-am", "time.periods=8"],
        )
    return out


def run(case: str, sets: list[str], gain: float, output: Path) -> dict:
    args = [case, "--json", "--quiet", "--output", str(output)]
    for s in [*sets, f"time.periodic_feedback_per_s={gain:g}"]:
        args += ["--set", s]
    stdout, stderr, start = io.StringIO(), io.StringIO(), time.perf_counter()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = run_cli.main(args)
    if code != 0:
        tail = stderr.getvalue().strip().splitlines()[-3:]
        raise SystemExit(f"error: fsi-run {' '.join(args)} exited {code}: " + " | ".join(tail))
    summary = json.loads(stdout.getvalue())
    # time.periodic_tolerance counts the CFD's thrust, not a fast fluid's slender-body estimate
    cfd = summary.get("thrust_source") == "openfoam"
    return {
        "tip_amplitude_per_period_m": summary["tip_amplitude_per_period_m"],
        "mean_thrust_per_period_n": summary.get("mean_thrust_per_period_n") or [],
        "thrust_counts": cfd,
        "wall_s": time.perf_counter() - start,
    }


def changes(values: list[float]) -> list[float]:
    return [abs(b - a) / abs(b) if b else float("inf") for a, b in pairwise(values)]


def periods_to(tolerance: float, row: dict) -> int | None:
    """The first period after which every figure changed by at most ``tolerance`` over each
    of the last two periods (fishfsi.cli.run.periodic_stop's rule), or None."""
    series = [changes(row["tip_amplitude_per_period_m"])]
    if row["thrust_counts"]:
        series.append(changes(row["mean_thrust_per_period_n"]))
    for end in range(2, len(series[0]) + 1):
        if all(max(s[end - 2 : end]) <= tolerance for s in series):
            return end + 1
    return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--gains", default="0,10", help="comma-separated G in 1/s")
    parser.add_argument("--openfoam", action="store_true", help="add the coarse OpenFOAM scenes")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    gains = [float(g) for g in args.gains.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        beam = Path(tmp) / "beam"
        beam.mkdir()
        (beam / "case.toml").write_text(BEAM)
        for k, (name, (case, sets)) in enumerate(scenes(beam, args.openfoam).items()):
            for gain in gains:
                row = run(case, sets, gain, Path(tmp) / f"run{k}_{gain:g}")
                row |= {"scene": name, "gain_per_s": gain}
                row["periods_to_2_percent"] = periods_to(0.02, row)
                row["periods_to_1_percent"] = periods_to(0.01, row)
                rows.append(row)
                if not args.json:
                    amplitude = " / ".join(
                        f"{a * 1e3:.2f}" for a in row["tip_amplitude_per_period_m"]
                    )
                    ran = len(row["tip_amplitude_per_period_m"])
                    two, one = (
                        row[key] or f"not within {ran}"
                        for key in ("periods_to_2_percent", "periods_to_1_percent")
                    )
                    print(
                        f"{name}, G = {gain:g}: tail [mm] {amplitude}; periodic to 2 % after "
                        f"{two}, to 1 % after {one} periods; {row['wall_s']:.0f} s",
                        flush=True,
                    )
    if args.json:
        json.dump(rows, sys.stdout, indent=1)
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
