"""``fsi-post PATH``: figures from results.

- a sweep (``sweep.csv`` or a folder holding it): tail amplitude and mean thrust versus driving
  frequency, one curve per waveform (the seed's Figs. 3.25, 3.28); a swimming sweep also
  speed, swimming number and turning rate with the seed's measured points (``swimming.png``);
- a run (``results.h5`` or its folder): tail-tip displacement, fluid force / thrust and coupling
  iterations versus time; with OpenFOAM's flow slices (``vtk/flow_midheight.pvd``) also the
  last one's vorticity and pressure around the fish (``flow.png``).

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
from .swimming import plot_swimming_sweep  # noqa: E402


def _thrust(row: dict) -> float:
    """The run's own thrust (OpenFOAM's) where it has one, else the slender-body estimate."""
    value = float(row.get("mean_thrust_n") or "nan")
    return value if np.isfinite(value) else float(row["slender_body_mean_thrust_n"])


def plot_sweep(csv_path: Path, output: Path) -> Path:
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
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


def plot_flow(pvd: Path, output: Path) -> Path | None:
    """The last mid-height slice: vertical vorticity (the wake's vortices in plan view) and
    kinematic pressure, in the plate's neighbourhood."""
    import xml.etree.ElementTree as ET

    import matplotlib.tri as mtri
    import pyvista as pv

    entries = [
        (float(d.get("timestep", "0")), d.get("file", "")) for d in ET.parse(pvd).iter("DataSet")
    ]
    if not entries:
        return None
    time_s, name = entries[-1]
    mesh = pv.read(pvd.parent / name).triangulate()
    xz = np.asarray(mesh.points)[:, [0, 2]]
    triangles = mesh.faces.reshape(-1, 4)[:, 1:]
    grid = mtri.Triangulation(xz[:, 0], xz[:, 1], triangles)
    near = (xz[:, 0] > -0.03) & (xz[:, 0] < 0.32)
    fields = (  # (values, colour-bar label, colour map)
        (mesh.point_data["vorticity"][:, 1], "vertical vorticity [1/s]", "RdBu_r"),
        (mesh.point_data["p"], "p / rho [m2/s2]", "coolwarm"),
    )
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for ax, (values, label, cmap) in zip(axes, fields, strict=True):
        limit = float(np.percentile(np.abs(values[near]), 99)) or 1.0
        shown = ax.tripcolor(grid, values, cmap=cmap, vmin=-limit, vmax=limit, shading="gouraud")
        fig.colorbar(shown, ax=ax, label=label)
        ax.set_xlim(-0.03, 0.32)
        ax.set_aspect("equal")
        ax.set_ylabel("z [m]")
    axes[0].set_title(f"mid-height slice at t = {time_s:.4g} s ({name})")
    axes[-1].set_xlabel("x [m] (nose at 0)")
    fig.tight_layout()
    target = output / "flow.png"
    fig.savefig(target, dpi=120)
    plt.close(fig)
    return target


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="fsi-post",
        description="Figures from results: amplitude and thrust versus frequency from a sweep, "
        "histories (and flow slices) from a run.",
    )
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
    try:
        if found.suffix == ".csv":
            print(plot_sweep(found, output))
            swimming = plot_swimming_sweep(found, output)
            if swimming is not None:
                print(swimming)
            return EXIT_OK
        print(plot_run(found, output))
        slices = found.parent / "vtk" / "flow_midheight.pvd"
        flow = plot_flow(slices, output) if slices.is_file() else None
    except (KeyError, ValueError, OSError) as err:  # not what fsi-run / fsi-sweep write
        print(
            f"error: {found}: not a table fsi-run or fsi-sweep wrote ({err!r}); "
            "point fsi-post at a run's output folder or a sweep's sweep.csv",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    if flow is not None:
        print(flow)
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
