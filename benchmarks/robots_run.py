"""The serial and integrative robots (cases/seed/serial_prototype, integrative_prototype) through
every analysis a user runs, as the user runs them: the wet modal, the linear sweep, the fast
transient (potential flow, 1 period) at 1-25 Hz with sine and square waves, and optionally
OpenFOAM (coarse, 1 period). Each must exit 0 with finite figures; the table gives the wall
time and the tail amplitude of each.

    .venv/bin/python benchmarks/robots_run.py [--openfoam] [--json OUT.json]

About 10 min on 2 cores without --openfoam.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
ROBOTS = ("serial_prototype", "integrative_prototype")
FREQUENCIES = (1.0, 3.0, 5.0, 10.0, 15.0, 20.0, 25.0)


def command(tool: str, *args: str) -> tuple[int, dict | None, float, str]:
    """(exit status, the --json summary, wall seconds, the last stderr line)."""
    start = time.perf_counter()
    done = subprocess.run(
        [str(BIN / tool), *args, "--json", "--quiet"], capture_output=True, text=True, cwd=ROOT
    )
    wall = time.perf_counter() - start
    try:
        summary = json.loads(done.stdout)
    except json.JSONDecodeError:
        summary = None
    last = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ""
    return done.returncode, summary, wall, last


def finite(values) -> bool:
    return all(isinstance(v, float) and math.isfinite(v) for v in values)


def robot_rows(robot: str, openfoam: bool, scratch: Path) -> list[dict]:
    case = str(ROOT / "cases/seed" / robot)
    rows = []
    rc, out, wall, last = command("fsi-modal", case, "--set", "fluid.model=potential")
    ok = rc == 0 and out is not None and finite(out["wet_hz"][:3])
    rows.append(
        {"robot": robot, "analysis": "modal (wet, free)", "rc": rc, "ok": ok, "wall_s": wall}
        | ({"first_wet_hz": out["wet_hz"][0]} if ok and out else {"error": last})
    )
    freqs = ",".join(f"{f:g}" for f in FREQUENCIES)
    for method, extra in (
        ("linear", []),
        ("transient", ["--set", "fluid.model=potential", "--set", "time.periods=1"]),
    ):
        rc, out, wall, last = command(
            "fsi-sweep",
            case,
            "--method",
            method,
            "--frequencies",
            freqs,
            "--waveforms",
            "both",
            "--output",
            str(scratch / f"{robot}-{method}"),
            *extra,
        )
        points = out["rows"] if out else []
        ok = (
            rc == 0
            and len(points) == 2 * len(FREQUENCIES)
            and all(p["status"] == "ok" for p in points)
            and finite([p["tip_amplitude_m"] for p in points])
            and finite([p["slender_body_mean_thrust_n"] for p in points])
        )
        row = {
            "robot": robot,
            "analysis": f"{method} sweep, 1-25 Hz, sine and square",
            "rc": rc,
            "ok": ok,
            "wall_s": wall,
        }
        if points:
            amplitudes = [1e3 * p["tip_amplitude_m"] for p in points]
            row["tail_mm_range"] = [min(amplitudes), max(amplitudes)]
        if not ok:
            row["error"] = last
        rows.append(row)
    if openfoam:
        overrides = ["fluid.model=openfoam", "fluid.mesh_level=coarse", "time.periods=1"]
        args = [a for o in overrides for a in ("--set", o)]
        rc, out, wall, last = command(
            "fsi-run", case, *args, "--output", str(scratch / f"{robot}-openfoam")
        )
        ok = rc == 0 and out is not None and finite([out["tip_amplitude_m"]])
        rows.append(
            {"robot": robot, "analysis": "OpenFOAM coupled, coarse, 3 Hz, 1 period", "rc": rc}
            | {"ok": ok, "wall_s": wall}
            | ({"tail_mm": 1e3 * out["tip_amplitude_m"]} if ok and out else {"error": last})
        )
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--openfoam", action="store_true", help="also one coupled period each")
    parser.add_argument("--json", type=Path, help="write the rows here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        rows = [r for robot in ROBOTS for r in robot_rows(robot, args.openfoam, Path(scratch))]
    print("| robot | analysis | exit | finite | wall [s] | result |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        result = r.get("error") or (
            f"f1 {r['first_wet_hz']:.2f} Hz"
            if "first_wet_hz" in r
            else f"tail {r['tail_mm']:.1f} mm"
            if "tail_mm" in r
            else "tail {:.1f}-{:.1f} mm".format(*r["tail_mm_range"])
        )
        print(
            f"| {r['robot']} | {r['analysis']} | {r['rc']} | {'yes' if r['ok'] else 'NO'} "
            f"| {r['wall_s']:.0f} | {result} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
