"""``fsi-post PATH``: figures from results.

- a sweep (``sweep.csv`` or a folder holding it): tail amplitude and mean thrust versus driving
  frequency, one curve per waveform (the seed's Figs. 3.25, 3.28);
- a run (``results.h5`` or its folder): tail-tip displacement, fluid force / thrust and coupling
  iterations versus time.

Writes PNG files next to the input (or to ``--output``) and prints their paths.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .common import EXIT_BAD_INPUT, EXIT_OK  # noqa: E402


def _thrust(row: dict) -> float:
    """The run's own thrust (OpenFOAM's) where it has one, else the slender-body estimate."""
    value = float(row.get("mean_thrust_n") or "nan")
    return value if np.isfinite(value) else float(row["slender_body_mean_thrust_n"])


def plot_sweep(csv_path: Path, output: Path) -> Path:
    rows = list(csv.DictReader(open(csv_path)))
    fig, (ax_amp, ax_thrust) = plt.subplots(2, 1, figsize=(6.5, 6.5), sharex=True)
    for waveform in sorted({r["waveform"] for r in rows}):
        sel = [r for r in rows if r["waveform"] == waveform]
        f = [float(r["frequency_hz"]) for r in sel]
        ax_amp.plot(f, [1e3 * float(r["tip_amplitude_m"]) for r in sel], "o-", label=waveform)
        ax_thrust.plot(f, [1e3 * _thrust(r) for r in sel], "o-", label=waveform)
    ax_amp.set_ylabel("tail-tip amplitude [mm]")
    ax_thrust.set_ylabel("mean thrust [mN]")
    ax_thrust.set_xlabel("driving frequency [Hz]")
    for ax in (ax_amp, ax_thrust):
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    target = output / "sweep.png"
    fig.savefig(target, dpi=120)
    plt.close(fig)
    return target


def plot_run(h5_path: Path, output: Path) -> Path:
    with h5py.File(h5_path, "r") as h5:
        t = h5["time_s"][:, 0]
        tip = h5["shell/tip_displacement_m"][:, 2]
        force = h5["fluid/force_n"][:] if "fluid/force_n" in h5 else None
        thrust = h5["fluid/thrust_n"][:, 0] if "fluid/thrust_n" in h5 else None
        solves = h5["coupling/fluid_solves"][:, 0] if "coupling/fluid_solves" in h5 else None
    panels = 1 + (force is not None or thrust is not None) + (solves is not None)
    fig, axes = plt.subplots(panels, 1, figsize=(6.5, 2.4 * panels), sharex=True, squeeze=False)
    axes = axes[:, 0]
    axes[0].plot(t, 1e3 * tip)
    axes[0].set_ylabel("tail tip z [mm]")
    k = 1
    if thrust is not None or force is not None:
        if thrust is not None:
            axes[k].plot(t, 1e3 * thrust, label="thrust (-F_x)")
        if force is not None:
            axes[k].plot(t, 1e3 * force[:, 2], label="F_z", alpha=0.6)
        axes[k].set_ylabel("fluid force [mN]")
        axes[k].legend()
        k += 1
    if solves is not None:
        axes[k].step(t, solves, where="post")
        axes[k].set_ylabel("fluid solves / window")
    axes[-1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    target = output / "run.png"
    fig.savefig(target, dpi=120)
    plt.close(fig)
    return target


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fsi-post", description=__doc__.splitlines()[0])
    parser.add_argument("path", help="sweep.csv, results.h5 or a folder holding one")
    parser.add_argument("--output", help="folder for the figures (default: next to the input)")
    args = parser.parse_args(argv)
    path = Path(args.path)
    candidates = (
        [path]
        if path.is_file()
        else [path / "sweep.csv", path / "results.h5", path / "output" / "results.h5"]
    )
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        print(f"error: {path}: no sweep.csv or results.h5 there", file=sys.stderr)
        return EXIT_BAD_INPUT
    output = Path(args.output) if args.output else found.parent
    output.mkdir(parents=True, exist_ok=True)
    target = plot_sweep(found, output) if found.suffix == ".csv" else plot_run(found, output)
    print(target)
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
