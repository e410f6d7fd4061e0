"""The fast model against OpenFOAM over a frequency curve: run time against error.

The fast model (``fsi-sweep --method linear``: potential flow in the tank, the edge drag
fitted to OpenFOAM at 3 Hz, Lighthill's thrust on its motion) is run at the frequencies and
waveforms of finished OpenFOAM transient sweeps of the same case, and each point's tail
amplitude and mean thrust are set beside OpenFOAM's periodic estimate (or its last period).
The fast curve is timed in this run; OpenFOAM's cost is the sum of each point's window times
in its results.h5 (set-up excluded). Reproduce::

    .venv/bin/python benchmarks/fast_fluid_accuracy.py cases/fixed_head_3Hz \\
        SWEEP [SWEEP ...] --set fluid.mesh_level=coarse

A later sweep's row replaces an earlier one's at the same point (e.g. a rerun with iterated
windows). The fast model gets ``fluid.edge_drag=true`` on top of ``--set``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli import sweep as sweep_cli  # noqa: E402


def _number(row: dict, *keys: str) -> float:
    for key in keys:
        text = row.get(key) or ""
        try:
            value = float(text)
        except ValueError:
            continue
        if np.isfinite(value):
            return value
    return float("nan")


def cfd_points(sweeps: list[Path]) -> dict[tuple[str, float], dict]:
    """OpenFOAM's finished points by (waveform, frequency): amplitude, thrust, window time."""
    points: dict[tuple[str, float], dict] = {}
    for folder in sweeps:
        with open(folder / "sweep.csv", newline="") as table:
            for row in csv.DictReader(table):
                if not row.get("status", "ok").startswith("ok"):
                    continue
                f = float(row["frequency_hz"])
                name = f"{row['waveform']}_{f:g}Hz"
                wall = float("nan")
                if (folder / name / "results.h5").is_file():
                    with h5py.File(folder / name / "results.h5", "r") as h5:
                        wall = float(np.sum(h5["wall_s"][()]))
                points[(row["waveform"], f)] = {
                    "tail_m": _number(row, "tip_amplitude_periodic_m", "tip_amplitude_m"),
                    "thrust_n": _number(row, "mean_thrust_periodic_n", "mean_thrust_n"),
                    "periodic": row.get("periodic") == "True",
                    "wall_s": wall,
                }
    return points


def fast_curve(case: Path, sets: list[str], points) -> tuple[dict, float]:
    """The fast sweep at the same points, and its wall time (set-up included)."""
    rows: dict[tuple[str, float], dict] = {}
    wall = 0.0
    for waveform in sorted({w for w, _ in points}):
        freqs = sorted(f for w, f in points if w == waveform)
        with tempfile.TemporaryDirectory() as out:
            argv = [str(case), "--method", "linear", "--waveforms", waveform, "--quiet"]
            argv += ["--frequencies", ",".join(f"{f:g}" for f in freqs), "--output", out]
            for s in [*sets, "fluid.edge_drag=true"]:
                argv += ["--set", s]
            start = time.perf_counter()
            code = sweep_cli.main(argv)
            wall += time.perf_counter() - start
            if code != 0:
                raise SystemExit(f"fast sweep failed (exit {code})")
            with open(Path(out) / "sweep.csv", newline="") as table:
                for row in csv.DictReader(table):
                    rows[(waveform, float(row["frequency_hz"]))] = {
                        "tail_m": float(row["tip_amplitude_m"]),
                        "thrust_n": float(row["slender_body_mean_thrust_n"]),
                    }
    return rows, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", type=Path)
    parser.add_argument("sweeps", type=Path, nargs="+", help="OpenFOAM transient sweep folders")
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()
    cfd = cfd_points(args.sweeps)
    fast, fast_wall = fast_curve(args.case, args.sets, cfd)
    print(
        "| waveform | f [Hz] | OpenFOAM tail [mm] | fast tail [mm] | error | OpenFOAM thrust "
        "[mN] | fast thrust [mN] | error | OpenFOAM windows [min] |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    errors: dict[str, list[tuple[float, float]]] = {}
    cfd_wall = 0.0
    for key in sorted(cfd):
        c, q = cfd[key], fast[key]
        e_tail = q["tail_m"] / c["tail_m"] - 1
        e_thrust = q["thrust_n"] / c["thrust_n"] - 1
        errors.setdefault(key[0], []).append((e_tail, e_thrust))
        cfd_wall += c["wall_s"] if np.isfinite(c["wall_s"]) else 0.0
        mark = "" if c["periodic"] else " (not periodic)"
        print(
            f"| {key[0]} | {key[1]:g} | {1e3 * c['tail_m']:.2f}{mark} | {1e3 * q['tail_m']:.2f} "
            f"| {100 * e_tail:+.0f} % | {1e3 * c['thrust_n']:.1f} | {1e3 * q['thrust_n']:.1f} "
            f"| {100 * e_thrust:+.0f} % | {c['wall_s'] / 60:.0f} |"
        )
    print()
    for waveform, pairs in sorted(errors.items()):
        tail, thrust = (np.abs(np.array(pairs))[:, i] for i in (0, 1))
        print(
            f"{waveform}: {len(pairs)} points; |error| of the tail median "
            f"{100 * np.median(tail):.0f} "
            f"% (max {100 * tail.max():.0f} %), of the thrust median "
            f"{100 * np.median(thrust):.0f} % (max {100 * thrust.max():.0f} %)"
        )
    print(
        f"fast curves {fast_wall:.1f} s against OpenFOAM's windows {cfd_wall / 3600:.1f} h "
        f"(x{cfd_wall / fast_wall:.0f})"
    )


if __name__ == "__main__":
    main()
