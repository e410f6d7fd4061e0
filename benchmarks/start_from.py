"""A start on another run's periodic orbit (`time.start_from`): per-period tail amplitude and
mean thrust of a run started from a finished run, their distance from a reference answer, and
the wall time in prescribed-motion periods (docs/coupling.md, "A start on another run's orbit").

    .venv/bin/python benchmarks/start_from.py --fast           # the piezo beam, ~1 min
    .venv/bin/python benchmarks/start_from.py                  # coarse source, default run, ~20 min
    .venv/bin/python benchmarks/start_from.py --source OUT     # an existing source run

Default scene: the main job's (3 Hz sine, explicit-am, time.periodic_feedback_per_s = 10). The
source runs on the coarse fluid level to a 1 % periodic tolerance; the run started from it
runs on --level (default: default) for --periods periods. The reference is the default level's
10-period all-implicit answer (docs/coupling.md, "Periodic state"). --fast: the beam in vacuum
from rest, 6 periods, then 6 more from it, against the 12-period run (a continuation).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

from fishfsi.cli import run as run_cli

sys.path.insert(0, str(Path(__file__).resolve().parent))
from periodic_feedback import BEAM  # noqa: E402  (the same lightly damped beam; periods set here)

ROOT = Path(__file__).resolve().parents[1]
MAIN = str(ROOT / "cases" / "fixed_head_3Hz")
SCENE = ["coupling.scheme=explicit-am", "time.periodic_feedback_per_s=10", "output.vtk=false"]
REFERENCE = (7.85e-3, 13.33e-3)  # default level, 10 periods all-implicit: tail m, thrust N


def run(case: str, sets: list[str], output: Path) -> dict:
    args = [case, "--json", "--quiet", "--output", str(output)]
    for s in sets:
        args += ["--set", s]
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = run_cli.main(args)
    if code != 0:
        tail = " | ".join(stderr.getvalue().strip().splitlines()[-3:])
        raise SystemExit(f"error: fsi-run {' '.join(args)} exited {code}: {tail}")
    return json.loads(stdout.getvalue())


def per_period(summary: dict) -> str:
    tails = summary["tip_amplitude_per_period_m"]
    thrusts = summary.get("mean_thrust_per_period_n") or [None] * len(tails)
    return " | ".join(
        f"{a * 1e3:.2f}" + (f" / {f * 1e3:.1f}" if f is not None else "")
        for a, f in zip(tails, thrusts, strict=True)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fast", action="store_true", help="the beam in vacuum (~1 min)")
    parser.add_argument("--source", help="an existing source run's output folder")
    parser.add_argument("--level", default="default", help="fluid mesh level of the started run")
    parser.add_argument("--periods", type=int, default=5, help="periods of the started run")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.fast:
            (work / "beam").mkdir()
            (work / "beam" / "case.toml").write_text(BEAM)
            case, rest = str(work / "beam"), ["time.start=rest", "time.periods=6"]
            full = run(case, [*rest[:1], "time.periods=12"], work / "full")
            source = run(case, rest, work / "source")
            start = [f"time.start_from={work / 'source'}", "time.periods=6"]
            started = run(case, start, work / "started")
            reference = full["tip_amplitude_per_period_m"][6:]
            gaps = [
                abs(a / b - 1)
                for a, b in zip(started["tip_amplitude_per_period_m"], reference, strict=True)
            ]
            result = {"source": source, "started": started, "largest_gap": max(gaps)}
            print(f"beam, 6 periods from rest:  {per_period(source)}")
            print(f"6 more from its checkpoint: {per_period(started)}")
            print(f"largest gap to the 12-period run's periods 7-12: {max(gaps):.1e}")
        else:
            if args.source:
                folder, source = Path(args.source), None
            else:
                folder = work / "source"
                coarse = ["fluid.mesh_level=coarse", "time.periods=8"]
                source = run(MAIN, [*SCENE, *coarse, "time.periodic_tolerance=0.01"], folder)
            sets = [*SCENE, f"fluid.mesh_level={args.level}", f"time.periods={args.periods}"]
            started = run(MAIN, [*sets, f"time.start_from={folder.resolve()}"], work / "started")
            prescribed = started["prescribed_wall_s_per_window"] * started["windows_per_period"]
            coupled = started["last_period_wall_s_per_window"] * started["windows_per_period"]
            lead_in = started["wall_s"] - args.periods * coupled
            result = {
                "source": source,
                "started": started,
                "prescribed_period_s": prescribed,
                "source_in_prescribed_periods": source["wall_s"] / prescribed if source else None,
                "set_up_and_lead_in_in_prescribed_periods": lead_in / prescribed,
                "coupled_period_ratio": coupled / prescribed,
            }
            if source:
                print(f"source (coarse):  {per_period(source)}  ({source['wall_s']:.0f} s)")
            print(f"started ({args.level}): {per_period(started)}  ({started['wall_s']:.0f} s)")
            tail_ref, thrust_ref = REFERENCE
            for k, (a, f) in enumerate(
                zip(
                    started["tip_amplitude_per_period_m"],
                    started["mean_thrust_per_period_n"],
                    strict=True,
                ),
                1,
            ):
                print(
                    f"period {k}: tail {100 * (a / tail_ref - 1):+.1f} %, "
                    f"thrust {100 * (f / thrust_ref - 1):+.1f} % from the reference"
                )
            print(
                f"wall in prescribed periods ({prescribed:.0f} s): set-up and lead-in "
                f"{result['set_up_and_lead_in_in_prescribed_periods']:.1f}, each coupled period "
                f"x{result['coupled_period_ratio']:.2f}"
                + (
                    f", the coarse source {result['source_in_prescribed_periods']:.1f}"
                    if source
                    else ""
                )
            )
        if args.json:
            print(json.dumps(result))


if __name__ == "__main__":
    main()
