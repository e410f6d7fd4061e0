"""Wall time per coupling window against cell count, and the adapter's own share of a window.

For each fluid mesh level: the fish in its first clamped mode at 3 Hz, 20 mm at the
tail (seed Sec. 3.4.3), 40 windows per period, solved window by window by the persistent driver
(one pimpleFoam process, handshake per window) and by the relaunch driver (one launch per
window). Printed: cells, seconds per window, the persistent driver's Python share (writing the
plate velocity samples, reading and integrating the loads, deleting stale folders), and the
relaunch overhead. Target (issue 4): adapter share <= 5 % for the persistent driver.
One fluid step per window (``fluid.max_courant = 10``, as the main job): the persistent driver
never sub-steps, and with the default Courant limit of 2 the relaunched windows did, which
counted their second step as "relaunch overhead" (1.56 s of it at the default level,
docs/openfoam.md).
With ``--processes 1 4 16`` each level is also run on MPI ranks: speed-up over serial and the
last window's lateral force against serial's (docs/openfoam.md, "Parallel scaling").

    .venv/bin/python benchmarks/openfoam_step_cost.py [--levels coarse default] [--windows 8]
        [--drivers persistent] [--processes 1 4 16] [--output rows.jsonl]
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

from fishfsi.cli.prescribed import mode_motion
from fluid_adapter.openfoam import build_openfoam_participant
from fsi_orchestrator.case.loader import case_from_dict
from fsi_orchestrator.participant import DISPLACEMENT, FORCE

WINDOWS_PER_PERIOD = 40
WARM_UP = 2  # windows not timed (start-up, first solves)


def time_driver(level: str, driver: str, windows: int, root: Path, processes: int = 1) -> dict:
    case = case_from_dict(
        {
            "fluid": {
                "model": "openfoam",
                "mesh_level": level,
                "driver": driver,
                "processes": processes,
                "max_courant": 10.0,
            },
            "coupling": {"scheme": "explicit-am"},  # one solve per window, as here
        },
        root,
    )
    dt = 1 / (3.0 * WINDOWS_PER_PERIOD)
    p = build_openfoam_participant(
        case,
        root / f"{level}-{driver}-{processes}",
        dt=dt,
        n_windows=windows + WARM_UP,
        reuse=False,
    )
    motion = mode_motion(case, p.interface().points, 0.020, 3.0, ramp_periods=0.5)
    walls = []
    for k in range(1, windows + WARM_UP + 1):
        start = time.perf_counter()
        p.read_data({DISPLACEMENT: motion.displacement(k * dt)})
        p.solve(dt)
        force = p.write_data()[FORCE]
        walls.append(time.perf_counter() - start)
        if k == WARM_UP and driver == "persistent":
            p.driver.timing = {"adapter_s": 0.0, "solver_s": 0.0}
    timing = getattr(p.driver, "timing", None)
    p.finalize()
    timed = walls[WARM_UP:]
    row = {
        "level": level,
        "driver": driver,
        "processes": processes,
        "cells": p.mesh_quality.cells,
        "s_per_window": sum(timed) / len(timed),
        # the last window's total lateral force: equal for any number of ranks
        "lateral_force_n": float(force[:, 2].sum()),
    }
    if timing:
        total = timing["adapter_s"] + timing["solver_s"]
        row["adapter_share"] = timing["adapter_s"] / total
        row["adapter_ms_per_window"] = 1e3 * timing["adapter_s"] / windows
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["coarse", "default", "fine"])
    parser.add_argument("--windows", type=int, default=8)
    parser.add_argument("--drivers", nargs="+", default=["persistent", "relaunch"])
    parser.add_argument(
        "--processes", nargs="+", type=int, default=[1], help="MPI ranks of pimpleFoam (each)"
    )
    parser.add_argument("--output", type=Path, help="also write the rows here (JSON lines)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="fishfsi-bench-"))
    root.chmod(0o755)  # as root the persistent driver runs OpenFOAM as `nobody`
    rows = []
    try:
        for level in args.levels:
            for processes in args.processes:
                for driver in args.drivers:
                    rows.append(time_driver(level, driver, args.windows, root, processes))
                    print(json.dumps(rows[-1]) if args.json else _line(rows[-1]), flush=True)
                    if args.output:
                        with args.output.open("a") as out:
                            out.write(json.dumps(rows[-1]) + "\n")
                    shutil.rmtree(root / f"{level}-{driver}-{processes}", ignore_errors=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    _summary(rows)


def _summary(rows: list[dict]) -> None:
    """Relaunch overhead per (level, ranks); speed-up and force difference against serial."""
    for level in dict.fromkeys(r["level"] for r in rows):
        here = [r for r in rows if r["level"] == level]
        for processes in dict.fromkeys(r["processes"] for r in here):
            pair = {r["driver"]: r for r in here if r["processes"] == processes}
            if {"persistent", "relaunch"} <= pair.keys():
                extra = pair["relaunch"]["s_per_window"] - pair["persistent"]["s_per_window"]
                share = extra / pair["persistent"]["s_per_window"]
                print(
                    f"{level}, {processes} rank(s): relaunch overhead {extra:.2f} s per window "
                    f"({share:.0%} of a persistent window)"
                )
        serial = {r["driver"]: r for r in here if r["processes"] == 1}
        for r in here:
            base = serial.get(r["driver"])
            if r["processes"] > 1 and base is not None:
                speedup = base["s_per_window"] / r["s_per_window"]
                diff = abs(r["lateral_force_n"] - base["lateral_force_n"])
                print(
                    f"{level}, {r['driver']}, {r['processes']} ranks: speed-up {speedup:.2f} "
                    f"(efficiency {speedup / r['processes']:.0%}), lateral force "
                    f"{diff / max(abs(base['lateral_force_n']), 1e-30):.1e} from serial"
                )


def _line(row: dict) -> str:
    text = f"{row['level']:8s} {row['driver']:10s} {row['processes']:3d} ranks "
    text += f"{row['cells']:7d} cells  "
    text += f"{row['s_per_window']:6.2f} s/window"
    if "adapter_share" in row:
        text += (
            f"  adapter {row['adapter_ms_per_window']:.1f} ms/window = {row['adapter_share']:.1%}"
        )
    return text


if __name__ == "__main__":
    main()
