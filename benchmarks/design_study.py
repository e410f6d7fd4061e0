"""Times fsi-design on the two shipped studies and checks the objective of each best design
against more converged evaluations of it.

- ``studies/fig5_5_peduncle``: 10 one-at-a-time designs (target: at most 1 min on 2 cores);
- ``studies/integrative``: 200 designs, Sobol start + differential evolution (target: at
  most 10 min).

For each study's best design the objective is evaluated again (a) with the shell and the
potential fluid one mesh level finer (shell ``fine``, fluid ``default``) and (b) by the time
march of fsi-run on the study's own meshes (40 steps per period, 3 periods from the periodic
start); the relative differences are the fast evaluation's error against those. Writes
``OUTPUT/design_study.json`` and prints it.

    python benchmarks/design_study.py --workers 2 --output /tmp/design_bench
    python benchmarks/design_study.py --only fig5_5_peduncle
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = {"fig5_5_peduncle": 60.0, "integrative": 600.0}  # target wall seconds


def run_study(name: str, output: Path, workers: int) -> tuple[dict, float]:
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.design", str(ROOT / "studies" / name)]
        + ["--output", str(output / name), "--overwrite", "--workers", str(workers)]
        + ["--json", "--quiet"],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{name}: fsi-design failed: {done.stderr.strip()}")
    return json.loads(done.stdout), wall


def converged_errors(best_case: Path, quantity: str, fast: float) -> dict:
    """The best design's objective on finer meshes (linear) and by the time march."""
    from fishfsi.design.evaluate import linear_figures, transient_figures
    from fsi_orchestrator.case import load_case

    finer = load_case(best_case, ["mesh.level=fine", "fluid.mesh_level=default"])
    start = time.perf_counter()
    fine = linear_figures(finer)[quantity]
    fine_s = time.perf_counter() - start
    case = load_case(best_case, ["time.periods=3", "output.vtk=false"])
    start = time.perf_counter()
    march = transient_figures(case, best_case / "transient")[quantity]
    march_s = time.perf_counter() - start
    return {
        "fast": fast,
        "finer_mesh": fine,
        "finer_mesh_rel_error": (fast - fine) / fine,
        "finer_mesh_wall_s": fine_s,
        "transient": march,
        "transient_rel_error": (fast - march) / march,
        "transient_wall_s": march_s,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--output", default="/tmp/design_bench")
    parser.add_argument("--only", choices=tuple(STUDIES), action="append")
    parser.add_argument("--no-converged", action="store_true", help="timings only")
    args = parser.parse_args(argv)
    output = Path(args.output)
    output.mkdir(parents=True, exist_ok=True)
    report = {}
    for name in args.only or STUDIES:
        summary, wall = run_study(name, output, args.workers)
        best = summary["best"]
        entry = {
            "designs": summary["evaluations"],
            "ok": summary["ok"],
            "infeasible": summary["infeasible"],
            "failed": summary["failed"],
            "workers": args.workers,
            "wall_s": wall,
            "target_s": STUDIES[name],
            "best": best,
        }
        print(f"{name}: {summary['evaluations']} designs in {wall:.0f} s", file=sys.stderr)
        if not args.no_converged:
            quantity = next(iter(best["objectives"]))
            entry["error"] = converged_errors(Path(best["case"]), quantity, best["objective"])
        report[name] = entry
        (output / "design_study.json").write_text(json.dumps(report, indent=1))
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
