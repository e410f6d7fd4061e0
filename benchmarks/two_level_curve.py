"""The default level's 13-point sine curve made in two levels: the coarse level's sweep to its
periodic state, then the default level's sweep with every point started on its coarse point's
orbit and flow (`fsi-sweep --start-from`). Wall time of both sweeps against the 1.5 h target
of issue 27, and each point against the default level's curve from rest
(benchmarks/data/openfoam_held_fish_default.toml; docs/validation.md, "Default level").

    .venv/bin/python benchmarks/two_level_curve.py                  # both sweeps, ~1.5 h on 2 cores
    .venv/bin/python benchmarks/two_level_curve.py --ranks 1 --frequencies 3,19
    .venv/bin/python benchmarks/two_level_curve.py --table DEFAULT   # an existing sweep

Both sweeps run as a user runs them (mpiexec -n RANKS fsi-sweep ... --method transient), with
the settings of docs/validation.md's default curve: explicit-am, the delayed feedback
(10 / s), up to 10 periods, periodic to 1 %.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from fishfsi.cli.common import EXIT_FAILED
from fishfsi.cli.sweep import MPIEXEC_GRACE_S

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "cases" / "fixed_head_3Hz"
REFERENCE = ROOT / "benchmarks" / "data" / "openfoam_held_fish_default.toml"
TARGET_S = 1.5 * 3600  # issue 27: the 13-point default sine curve on 2 cores
SCENE = [
    "coupling.scheme=explicit-am",
    "time.periodic_feedback_per_s=10",
    "time.periods=10",
    "time.periodic_tolerance=0.01",
    "output.vtk=false",
]


def sweep(ranks: int, frequencies: str, output: Path, extra: list[str]) -> float:
    """Run one fsi-sweep (under mpiexec with ``ranks`` > 1); its wall time in seconds."""
    command = [str(ROOT / ".venv" / "bin" / "fsi-sweep"), str(CASE), "--method", "transient"]
    command += ["--waveforms", "sine", "--frequencies", frequencies, "--output", str(output)]
    for s in SCENE:
        command += ["--set", s]
    command += extra
    if ranks > 1:
        launcher = ["mpiexec", "-n", str(ranks)]
        if os.geteuid() == 0:
            launcher.append("--allow-run-as-root")
        command = launcher + command
    # a stop (Ctrl-C) lets the ranks end their window with a checkpoint
    env = {**os.environ, "OMPI_MCA_odls_base_sigkill_timeout": str(MPIEXEC_GRACE_S)}
    start = time.perf_counter()
    done = subprocess.run(command, env=env)
    if done.returncode not in (0, EXIT_FAILED):  # a failed point keeps its row: compare the rest
        raise SystemExit(f"error: {' '.join(command)} exited {done.returncode}")
    return time.perf_counter() - start


def rows(folder: Path) -> dict[float, dict]:
    with (folder / "sweep.csv").open() as f:
        return {float(r["frequency_hz"]): r for r in csv.DictReader(f)}


def compare(default: Path) -> list[dict]:
    """Each point of the two-level sweep against the curve from rest (periodic estimates)."""
    reference = tomllib.loads(REFERENCE.read_text())["sine"]
    by_f = {
        float(f): (a * 1e-3, t * 1e-3)
        for f, a, t in zip(
            reference["frequency_hz"], reference["tail_mm"], reference["thrust_mn"], strict=True
        )
    }
    out = []
    for f, r in sorted(rows(default).items()):
        tail = float(r.get("tip_amplitude_periodic_m") or r["tip_amplitude_m"])
        thrust = float(r.get("mean_thrust_periodic_n") or r["mean_thrust_n"])
        ref = by_f.get(f)
        out.append(
            {
                "frequency_hz": f,
                "status": r["status"],
                "windows_per_period": r["windows_per_period"],
                "tail_mm": tail * 1e3,
                "thrust_mn": thrust * 1e3,
                "tail_error": None if ref is None else tail / ref[0] - 1,
                "thrust_error": None if ref is None else thrust / ref[1] - 1,
            }
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, default=2, help="MPI ranks of both sweeps")
    parser.add_argument("--frequencies", default="1:25:2")
    parser.add_argument("--output", help="both sweeps' folder (default: benchmarks/out/...)")
    parser.add_argument("--table", metavar="DEFAULT", help="an existing default sweep: compare")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    walls = None
    if args.table:
        default = Path(args.table)
    else:
        if shutil.which("mpiexec") is None and args.ranks > 1:
            raise SystemExit("error: --ranks > 1 needs mpiexec (scripts/setup.sh installs it)")
        base = Path(args.output or ROOT / "benchmarks" / "out" / "two_level_curve")
        coarse, default = base / "coarse", base / "default"
        for folder in (coarse, default):
            if folder.exists():
                raise SystemExit(f"error: {folder} exists: remove it or give another --output")
        walls = (
            sweep(args.ranks, args.frequencies, coarse, ["--set", "fluid.mesh_level=coarse"]),
            sweep(args.ranks, args.frequencies, default, ["--start-from", str(coarse)]),
        )
    points = compare(default)
    summary: dict = {"points": points}
    if walls is not None:
        total = sum(walls)
        summary.update(
            coarse_wall_s=walls[0],
            default_wall_s=walls[1],
            total_wall_s=total,
            ratio_to_target=total / TARGET_S,
            ranks=args.ranks,
        )
    if args.json:
        print(json.dumps(summary, indent=2))
        return
    print(
        "| f [Hz] | windows per period | tail [mm] | vs from rest | thrust [mN] | vs from rest "
        "| status |"
    )
    print("|---|---|---|---|---|---|---|")
    for p in points:
        te = "-" if p["tail_error"] is None else f"{p['tail_error']:+.1%}"
        fe = "-" if p["thrust_error"] is None else f"{p['thrust_error']:+.1%}"
        print(
            f"| {p['frequency_hz']:g} | {p['windows_per_period']} | {p['tail_mm']:.3f} | {te} "
            f"| {p['thrust_mn']:.1f} | {fe} | {p['status']} |"
        )
    if walls is not None:
        print(
            f"\ncoarse sweep {walls[0] / 60:.1f} min, "
            f"default sweep from it {walls[1] / 60:.1f} min, "
            f"total {sum(walls) / 3600:.2f} h on {args.ranks} ranks: x{sum(walls) / TARGET_S:.2f} "
            "of the 1.5 h target"
        )


if __name__ == "__main__":
    sys.exit(main())
