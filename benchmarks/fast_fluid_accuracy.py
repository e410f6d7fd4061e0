"""The fast model against OpenFOAM over a frequency curve: run time against error.

The fast model (``fsi-sweep --method linear``: potential flow in the tank, the edge drag
fitted to OpenFOAM, Lighthill's thrust on its motion with the shedding efficiency fitted to
OpenFOAM, ``fluid.thrust_shedding_kc``; ``--set fluid.thrust_shedding_kc=0`` for Lighthill's
alone) is run at the frequencies and waveforms
of OpenFOAM's transient curves of the same case, and each point's tail amplitude and mean
thrust are set beside OpenFOAM's periodic estimate. Without sweep folders the reference is
benchmarks/data/openfoam_held_fish_coarse.toml, the main job's scene on the coarse level
(its wall times per point); with them, the finished sweeps' rows and the window times in their
results.h5. The fast curve is timed in this run. Reproduce::

    .venv/bin/python benchmarks/fast_fluid_accuracy.py cases/fixed_head_3Hz \\
        --set fluid.mesh_level=coarse [--fit-exponent sine]

``--fit-exponent WAVEFORM`` fits ``fluid.edge_drag_frequency_exponent`` r (scipy, bounded
0-1.5) to OpenFOAM's tail amplitudes on that waveform's curve (least squares of the log
ratio) and reports both curves at the fitted r. A later sweep's row replaces an earlier one's
at the same point (e.g. a rerun with iterated windows). The fast model gets
``fluid.edge_drag=true`` on top of ``--set``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import h5py
import numpy as np
from scipy.optimize import minimize_scalar

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


REFERENCE = Path(__file__).resolve().parent / "data" / "openfoam_held_fish_coarse.toml"


def reference_points(path: Path = REFERENCE) -> dict[tuple[str, float], dict]:
    """OpenFOAM's curves from the reference file, keyed as cfd_points keys them."""
    data = tomllib.loads(path.read_text())
    points: dict[tuple[str, float], dict] = {}
    for waveform, table in data.items():
        for i, f in enumerate(table["frequency_hz"]):
            points[(waveform, float(f))] = {
                "tail_m": 1e-3 * table["tail_mm"][i],
                "thrust_n": 1e-3 * table["thrust_mn"][i],
                "periodic": bool(table["periodic"][i]),
                "wall_s": 60.0 * table["wall_min"][i],
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
                        "thrust_n": float(row["mean_thrust_n"]),  # with the shedding
                    }
    return rows, wall


def fit_exponent(case: Path, sets: list[str], cfd: dict, waveform: str) -> float:
    """r minimizing the squared log ratio of the fast tail to OpenFOAM's on one curve."""
    points = {
        key: value
        for key, value in cfd.items()
        if key[0] == waveform and np.isfinite(value["tail_m"]) and value["tail_m"] > 0
    }
    if not points:
        raise SystemExit(f"--fit-exponent {waveform}: OpenFOAM has no finished {waveform} point")

    def misfit(r: float) -> float:
        fast, _ = fast_curve(case, [*sets, f"fluid.edge_drag_frequency_exponent={r:.4f}"], points)
        logs = [np.log(fast[k]["tail_m"] / points[k]["tail_m"]) for k in points]
        print(f"  r = {r:.3f}: rms log error of the tail {np.sqrt(np.mean(np.square(logs))):.4f}")
        return float(np.mean(np.square(logs)))

    fit = minimize_scalar(misfit, bounds=(0.0, 1.5), method="bounded", options={"xatol": 0.01})
    print(f"fitted r = {fit.x:.3f} on the {waveform} curve ({fit.nfev} fast curves)")
    return float(fit.x)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", type=Path)
    parser.add_argument(
        "sweeps", type=Path, nargs="*", help="OpenFOAM transient sweep folders (default: the file)"
    )
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--fit-exponent", choices=("sine", "square"), default=None)
    args = parser.parse_args()
    cfd = cfd_points(args.sweeps) if args.sweeps else reference_points()
    sets = list(args.sets)
    if args.fit_exponent:
        fitted = fit_exponent(args.case, sets, cfd, args.fit_exponent)
        sets.append(f"fluid.edge_drag_frequency_exponent={fitted:.3f}")
    fast, fast_wall = fast_curve(args.case, sets, cfd)
    print(
        "| waveform | f [Hz] | OpenFOAM tail [mm] | fast tail [mm] | error | OpenFOAM thrust "
        "[mN] | fast thrust [mN] | error | OpenFOAM wall [min] |"
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
        f"fast curves {fast_wall:.1f} s against OpenFOAM's {cfd_wall / 3600:.1f} h "
        f"(x{cfd_wall / fast_wall:.0f})"
    )


if __name__ == "__main__":
    main()
