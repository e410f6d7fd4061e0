"""``fsi-post PATH``: figures from results.

- a sweep (``sweep.csv`` or a folder holding it): tail amplitude and mean thrust versus driving
  frequency, one curve per waveform (the seed's Figs. 3.25, 3.28); a swimming sweep also
  speed, swimming number and turning rate with the seed's measured points (``swimming.png``);
- a run (``results.h5`` or its folder): tail-tip displacement, fluid force / thrust and coupling
  iterations versus time; with OpenFOAM's flow slices (``vtk/flow_midheight.pvd``) also the
  last one's vorticity and pressure around the fish (``flow.png``), and with its flow surfaces
  the fish and its wake in 3D (``fish3d.png``, ``period.gif``; :mod:`.pictures`).

Writes PNG files next to the input (or to ``--output``) and prints their paths.
"""

from __future__ import annotations

import copy
import csv
import errno
import io
import json
import re
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from fsi_orchestrator.case.schema import Waveform, key_spec  # noqa: E402
from fsi_orchestrator.results import write_failure  # noqa: E402

from . import pictures  # noqa: E402
from .common import (  # noqa: E402
    EXIT_BAD_INPUT,
    EXIT_FAILED,
    EXIT_OK,
    FULL,
    OneLineParser,
    WriteFault,
    add_version,
    atomic_write,
    cannot_write,
    save_figure,
)
from .outputs import first_not_finite  # noqa: E402
from .swimming import SWIMMING_KEYS, plot_swimming_sweep  # noqa: E402


def _thrust(row: dict) -> float:
    """The run's own thrust (OpenFOAM's) where it has one, else the slender-body estimate."""
    value = _float(row, "mean_thrust_n")
    return value if np.isfinite(value) else _float(row, "slender_body_mean_thrust_n")


# The seed's figures for the original fish, head held, square wave
# (../shared/reference/seed_data.toml): the tail at 1 Hz, the thrust peak, the rig's range
SEED_FSI_1HZ_MM = 34.0  # Fig. 3.28, the seed's FSI
SEED_EXPERIMENT_1HZ_MM = 24.7  # Fig. 4.8
SEED_THRUST_PEAK_HZ = 18.0  # Fig. 4.6
RIG_READABLE_N = 0.107  # Sec. 4.3.1: 0.5 N load cell through the 45 / 210 mm lever


def _float(row: dict, key: str) -> float:
    try:
        return float(row.get(key) or "nan")
    except ValueError:
        return float("nan")


def sweep_label(identity: dict | None, rows: list[dict]) -> str:
    """'openfoam, coarse' / 'slender_body, linear': the thrust's source and the mesh level."""
    sources = sorted({r.get("thrust_source") or "slender_body" for r in rows})
    if identity is None:
        return ", ".join(sources)
    case = identity.get("case", {})
    if case.get("fluid", {}).get("model") == "openfoam" and identity.get("method") != "linear":
        level = f"OpenFOAM {mesh_level(identity) or '?'}"
    else:
        level = f"shell {case.get('mesh', {}).get('level', '?')}, {identity.get('method', '?')}"
    return f"{', '.join(sources)}; {level}"


def is_original_fish(identity: dict | None) -> bool:
    geometry = (identity or {}).get("case", {}).get("geometry", {})
    return geometry.get("kind") == "fish" and geometry.get("preset") == "original"


def head_support(identity: dict | None) -> str:
    """The sweep's boundary.head (the schema's default, clamped, where the case leaves it)."""
    return str((identity or {}).get("case", {}).get("boundary", {}).get("head", "clamped"))


def overlay_seed(ax_amp, ax_thrust, head: str = "clamped") -> None:
    """The seed's measured and simulated figures the original fish's curves answer to: the
    1 Hz tail of its fixed-head experiment and FSI where the head is clamped, the thrust rig's
    peak and readable range where the head is held (clamped, as the seed's FSI, or hinged, as
    the rig's stick); none for a free or sprung head."""
    if head == "clamped":
        ax_amp.plot([1.0], [SEED_FSI_1HZ_MM], "k^", label="seed FSI, 1 Hz square (Fig. 3.28)")
        ax_amp.plot([1.0], [SEED_EXPERIMENT_1HZ_MM], "ks", label="seed experiment (Fig. 4.8)")
    if head in ("clamped", "pinned"):
        ax_thrust.axhspan(0, 1e3 * RIG_READABLE_N, color="0.85", label="rig's readable range")
        ax_thrust.axvline(SEED_THRUST_PEAK_HZ, color="k", ls="--", label="measured peak (Fig. 4.6)")


_FREQUENCY = key_spec("actuation.frequency_hz")  # a row's frequency, as a case's
assert _FREQUENCY.ge is not None and _FREQUENCY.le is not None
FREQUENCY_RANGE_HZ = (_FREQUENCY.ge, _FREQUENCY.le)
WAVEFORMS = tuple(w.value for w in Waveform)


class DivergedRun(RuntimeError):
    """A results file holding NaN: drawn up to it, and a failure (as fsi-run's exit)."""


class PostError(ValueError):
    """Input fsi-post cannot draw, said in one line."""


SWEEP_COLUMNS = ("waveform", "frequency_hz", "tip_amplitude_m")  # every sweep writes these
TEXT_COLUMNS = ("waveform", "status", "thrust_source", "periodic")
# drawn where a sweep has them: finite in every row whose status is ok
DRAWN_COLUMNS = ("mean_thrust_n", *SWIMMING_KEYS)


def read_sweep(csv_path: Path) -> tuple[list[dict], dict | None]:
    """A sweep's rows and what was swept (``sweep_case.json``; None when absent)."""
    with open(csv_path, newline="") as table:
        rows = list(csv.DictReader(table))
    if not rows:
        raise PostError(f"{csv_path}: no rows; run fsi-sweep into that folder (again)")
    missing = [c for c in SWEEP_COLUMNS if c not in rows[0]]
    if missing:
        raise PostError(f"{csv_path}: not a table fsi-sweep wrote (no column {missing[0]!r})")
    lo, hi = FREQUENCY_RANGE_HZ
    for line, row in enumerate(rows, start=2):  # line 1 is the header
        if None in row or None in row.values():  # cut short, or cells past the header's
            header = sum(k is not None for k in row)
            cells = sum(v is not None for k, v in row.items() if k is not None)
            cells += len(row.get(None) or [])
            raise PostError(
                f"{csv_path}, line {line}: {cells} cells where the header has {header} (a cut "
                "or edited table); run fsi-sweep into that folder again with --resume"
            )
        ok = row.get("status", "ok").startswith("ok")
        needed = SWEEP_COLUMNS[1:] if ok else SWEEP_COLUMNS[1:2]  # a failed point's figures
        for key, text in row.items():
            if key in TEXT_COLUMNS or not text:
                continue
            try:
                value = float(text)
            except (TypeError, ValueError):
                raise PostError(
                    f"{csv_path}, line {line}: {key} = {text!r} is not a number"
                ) from None
            drawn = ok and key in DRAWN_COLUMNS
            if (key in needed or drawn) and not np.isfinite(value):
                raise PostError(
                    f"{csv_path}, line {line}: {key} = {text!r} is not finite for a point "
                    f"whose status is {row.get('status', 'ok')!r}"
                )
            if key == "frequency_hz" and not lo <= value <= hi:
                raise PostError(
                    f"{csv_path}, line {line}: frequency_hz = {text!r} is outside the "
                    f"drive's {lo:g}..{hi:g} Hz (actuation.frequency_hz)"
                )
        if row.get("waveform") not in WAVEFORMS:
            raise PostError(
                f"{csv_path}, line {line}: waveform = {row.get('waveform')!r} is none of "
                f"{', '.join(WAVEFORMS)}"
            )
        for key in needed:
            if not row[key]:
                raise PostError(
                    f"{csv_path}, line {line}: {key} is empty for a point whose status is "
                    f"{row.get('status', 'ok')!r}"
                )
    if not any(row.get("status", "ok").startswith("ok") for row in rows):
        raise PostError(
            f"{csv_path}: no point finished (each row's status says why; its folder keeps "
            "failure.txt); nothing to draw"
        )
    identity = None
    if (csv_path.parent / "sweep_case.json").is_file():
        try:
            identity = json.loads((csv_path.parent / "sweep_case.json").read_text())
        except ValueError:
            identity = None
    return rows, identity


def mesh_level(identity: dict | None) -> str | None:
    return (identity or {}).get("case", {}).get("fluid", {}).get("mesh_level")


def check_mesh_reference(identity: dict | None, reference: dict | None, path: Path) -> None:
    """The reference must be the same sweep on another fluid mesh level, and nothing else."""
    if identity is None or reference is None:
        raise PostError(
            f"{path}: a mesh reference needs both sweeps' sweep_case.json (written by "
            "fsi-sweep) to tell that they differ only in fluid.mesh_level"
        )
    a, b = copy.deepcopy(identity), copy.deepcopy(reference)
    for side in (a, b):
        side.get("case", {}).get("fluid", {}).pop("mesh_level", None)
        side.pop("version", None)
    if a != b:
        from .sweep import identity_changes

        raise PostError(
            f"{path}: the mesh reference is another sweep, not only another fluid.mesh_level "
            f"({identity_changes(a, b)})"
        )
    if mesh_level(identity) == mesh_level(reference):
        raise PostError(
            f"{path}: the mesh reference is on the same fluid.mesh_level "
            f"({mesh_level(identity)!r}); sweep the case again with another "
            "--set fluid.mesh_level=..."
        )


def mesh_errors(
    freqs: Sequence[float],
    values: Sequence[float],
    ref_freqs: Sequence[float],
    ref_values: Sequence[float],
) -> tuple[np.ndarray, np.ndarray]:
    """The mesh level's error of each value: the difference to the reference where it has the
    same frequency; between those, their relative difference interpolated linearly in
    frequency (held constant beyond them) times the value. Returns (|error|, measured: whether
    the reference has the frequency); NaN where the reference shares no finite frequency."""
    f = np.asarray(freqs, float)
    v = np.asarray(values, float)
    ref = {float(a): float(b) for a, b in zip(ref_freqs, ref_values, strict=True)}
    measured = np.array([x in ref and np.isfinite(ref[x]) for x in f])
    shared = measured & np.isfinite(v) & (v != 0.0)
    if not shared.any():
        return np.full(f.shape, np.nan), measured
    rel = np.array([(ref[x] - y) / y for x, y in zip(f[shared], v[shared], strict=True)])
    order = np.argsort(f[shared])
    error = np.abs(np.interp(f, f[shared][order], rel[order]) * v)
    error[measured] = np.abs([ref[x] - y for x, y in zip(f[measured], v[measured], strict=True)])
    return error, measured


def plot_sweep(csv_path: Path, output: Path, mesh_reference: Path | None = None) -> Path:
    """Amplitude and thrust against frequency, one curve per waveform, with the periodic
    estimate's uncertainty as error bars where the rows carry it; the original fish's sweep
    also shows the seed's figures. With ``mesh_reference`` (the same sweep on another fluid
    mesh level, at some or all of the frequencies) its points are drawn too and the mesh
    level's error is a band about each curve; ``sweep_errors.csv`` lists both errors."""
    rows, identity = read_sweep(csv_path)
    ref_rows: list[dict] = []
    ref_identity = None
    if mesh_reference is not None:
        ref_rows, ref_identity = read_sweep(mesh_reference)
        check_mesh_reference(identity, ref_identity, mesh_reference)
    fig, (ax_amp, ax_thrust) = plt.subplots(2, 1, figsize=(6.5, 6.5), sharex=True)
    swimming = any(SWIMMING_KEYS[0] in r for r in rows)  # a swimming case's sweep
    if is_original_fish(identity):
        overlay_seed(ax_amp, ax_thrust, head_support(identity))
    table = []
    for waveform in sorted({r["waveform"] for r in rows}):
        sel = sorted(
            (r for r in rows if r["waveform"] == waveform), key=lambda r: float(r["frequency_hz"])
        )
        label = f"{waveform} ({sweep_label(identity, sel)})"
        f = [float(r["frequency_hz"]) for r in sel]
        amp = [1e3 * _float(r, "tip_amplitude_m") for r in sel]
        amp_err = [1e3 * _float(r, "tip_amplitude_periodic_uncertainty_m") for r in sel]
        thrust = [1e3 * _thrust(r) for r in sel]
        thrust_err = [1e3 * _float(r, "mean_thrust_periodic_uncertainty_n") for r in sel]
        if swimming:  # the free fish in still liquid; its figures at speed dashed beside
            label += ", still liquid"
        finite = [e if np.isfinite(e) else 0.0 for e in amp_err]
        drawn = ax_amp.errorbar(f, amp, yerr=finite, fmt="o-", capsize=2, label=label)
        finite = [e if np.isfinite(e) else 0.0 for e in thrust_err]
        ax_thrust.errorbar(f, thrust, yerr=finite, fmt="o-", capsize=2, label=label)
        colour = drawn[0].get_color()
        if swimming:
            at_speed = f"{waveform}, at the swimming speed"
            for ax, key in ((ax_amp, "tip_amplitude_at_speed_m"), (ax_thrust, "thrust_at_speed_n")):
                if any(key in r for r in sel):
                    values = [1e3 * _float(r, key) for r in sel]
                    ax.plot(f, values, "s--", mfc="none", color=colour, label=at_speed)
        if mesh_reference is None:
            continue
        ref = [r for r in ref_rows if r["waveform"] == waveform]
        ref_f = [float(r["frequency_hz"]) for r in ref]
        ref_amp = [1e3 * _float(r, "tip_amplitude_m") for r in ref]
        ref_thrust = [1e3 * _thrust(r) for r in ref]
        amp_mesh, measured = mesh_errors(f, amp, ref_f, ref_amp)
        thrust_mesh, _ = mesh_errors(f, thrust, ref_f, ref_thrust)
        ref_label = f"{waveform} ({sweep_label(ref_identity, ref)})"
        for ax, values, err, ref_values in (
            (ax_amp, amp, amp_mesh, ref_amp),
            (ax_thrust, thrust, thrust_mesh, ref_thrust),
        ):
            v = np.asarray(values)
            ax.fill_between(f, v - err, v + err, color=colour, alpha=0.18, lw=0)
            ax.plot(ref_f, ref_values, "D", mfc="none", color=colour, label=ref_label)
        for i, freq in enumerate(f):
            table.append(
                {
                    "waveform": waveform,
                    "frequency_hz": freq,
                    "tip_amplitude_mm": amp[i],
                    "tip_amplitude_periodic_uncertainty_mm": amp_err[i],
                    "tip_amplitude_mesh_error_mm": amp_mesh[i],
                    "mean_thrust_mn": thrust[i],
                    "mean_thrust_periodic_uncertainty_mn": thrust_err[i],
                    "mean_thrust_mesh_error_mn": thrust_mesh[i],
                    "mesh_error": "measured" if measured[i] else "interpolated",
                    # a failed point's NaN says why
                    "status": sel[i].get("status", ""),
                }
            )
    ax_amp.set_ylabel("tail-tip amplitude [mm]")
    ax_thrust.set_ylabel("mean thrust [mN]")
    ax_thrust.set_xlabel("driving frequency [Hz]")
    for ax in (ax_amp, ax_thrust):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    fig.tight_layout()
    if table:
        text = io.StringIO()
        # "\n" line ends, as sweep.csv (csv's default is "\r\n")
        writer = csv.DictWriter(text, fieldnames=list(table[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(table)
        atomic_write(output / "sweep_errors.csv", text.getvalue())
    target = output / "sweep.png"
    save_figure(fig, target)
    return target


def plot_run(h5_path: Path, output: Path) -> Path:
    with h5py.File(h5_path, "r") as h5:
        t = h5["time_s"][:, 0]
        tip = h5["shell/tip_displacement_m"][:, 2]
        force = h5["fluid/force_n"][:] if "fluid/force_n" in h5 else None
        thrust = h5["fluid/thrust_n"][:, 0] if "fluid/thrust_n" in h5 else None
        solves = h5["coupling/fluid_solves"][:, 0] if "coupling/fluid_solves" in h5 else None
    if len(t) == 0:
        raise PostError(
            f"{h5_path}: no windows yet (the run stopped in its set-up, or is in its first "
            "window): nothing to draw"
        )
    bad = first_not_finite(h5_path)
    if bad is not None:  # draw the windows before it, then say so and fail
        keep = bad[1]
        broken = (
            f"{h5_path}: {bad[0]} is not finite from window {keep + 1} on (a run that "
            "diverged, or a damaged file)"
        )
        if keep == 0:
            raise DivergedRun(f"{broken}; nothing to draw")
        t, tip = t[:keep], tip[:keep]
        force, thrust, solves = (None if a is None else a[:keep] for a in (force, thrust, solves))
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
    save_figure(fig, target)
    if bad is not None:
        raise DivergedRun(f"{broken}; {target} shows the {keep} windows before it")
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
    save_figure(fig, target)
    return target


def drive_period_s(results: Path) -> float | None:
    """The drive's period from the resolved case results.h5 carries (None: not recorded)."""
    import tomllib

    with h5py.File(results, "r") as h5:
        text = h5.attrs.get("case_toml")
    if text is None:
        return None
    # results written before 2026-12-03 by a sweep over numpy frequencies hold
    # "frequency_hz = np.float64(7.0)", which is not TOML
    text = re.sub(r"np\.float64\(([^()]*)\)", r"\1", str(text))
    frequency = tomllib.loads(text).get("actuation", {}).get("frequency_hz")
    if frequency is None:  # at its default the key is written as a comment
        found = re.search(r"^# frequency_hz = (\S+)  \(default\)$", text, re.MULTILINE)
        frequency = float(found.group(1)) if found else None
    return 1.0 / float(frequency) if frequency else None


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineParser(
        prog="fsi-post",
        description="Figures from results: amplitude and thrust versus frequency from a sweep, "
        "histories (and flow slices) from a run.",
    )
    add_version(parser)
    parser.add_argument("path", help="sweep.csv, results.h5 or a folder holding one")
    parser.add_argument("--output", help="folder for the figures (default: next to the input)")
    parser.add_argument(
        "--mesh-reference",
        metavar="SWEEP",
        help="the same sweep on another fluid mesh level (sweep.csv or its folder; some "
        "frequencies are enough): its points and the mesh level's error band are drawn, and "
        "sweep_errors.csv lists the periodic and the mesh errors",
    )
    args = parser.parse_args(argv)
    path = Path(args.path)
    candidates = (
        [path]
        if path.is_file()
        else [path / "sweep.csv", path / "results.h5", path / "output" / "results.h5"]
    )
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        why = "no sweep.csv or results.h5 there" if path.exists() else "no such file or folder"
        print(f"error: {path}: {why}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.mesh_reference and found.suffix != ".csv":
        print(
            f"error: --mesh-reference applies to a sweep's sweep.csv, not to the run {found}",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    output = Path(args.output) if args.output else found.parent
    try:
        output.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=output):  # a read-only mount lets mkdir pass
            pass
    except OSError as err:
        named = "--output " if args.output else "the output folder "
        print(f"error: {cannot_write(output, err, named)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        if found.suffix == ".csv":
            reference = None
            if args.mesh_reference:
                reference = Path(args.mesh_reference)
                if reference.is_dir():
                    reference = reference / "sweep.csv"
                if not reference.is_file():
                    print(f"error: --mesh-reference {reference}: no sweep.csv", file=sys.stderr)
                    return EXIT_BAD_INPUT
            print(plot_sweep(found, output, reference))
            if reference is not None:
                print(output / "sweep_errors.csv")
            swimming = plot_swimming_sweep(found, output)
            if swimming is not None:
                print(swimming)
            return EXIT_OK
        print(plot_run(found, output))
        slices = found.parent / "vtk" / "flow_midheight.pvd"
        flow = plot_flow(slices, output) if slices.is_file() else None
        if flow is not None:
            print(flow)
        for picture in pictures.draw(found.parent / "vtk", output, drive_period_s(found)):
            print(picture)
    except PostError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except DivergedRun as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as err:
        # its own pictures' writes (named WriteFault); a denied read is the input's
        if not (isinstance(err, WriteFault) or err.errno in (*FULL, errno.EROFS)):
            return _not_ours(found, err)
        where = Path(err.filename) if err.filename else output
        print(
            f"error: {write_failure(where, err, 'the inputs are untouched', 'run it again')}",
            file=sys.stderr,
        )
        return EXIT_FAILED
    except (KeyError, ValueError) as err:  # not what fsi-run / fsi-sweep write
        return _not_ours(found, err)
    return EXIT_OK


def _is_hdf5(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def _not_ours(found: Path, err: Exception) -> int:
    why = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
    if _is_hdf5(found):  # fsi-run's own file, damaged (cut short while copied, ...)
        print(
            f"error: {found}: not a readable results file ({why}): damaged or cut short; "
            "copy it again or rerun the case",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    print(
        f"error: {found}: not a table fsi-run or fsi-sweep wrote ({why}); "
        "point fsi-post at a run's output folder or a sweep's sweep.csv",
        file=sys.stderr,
    )
    return EXIT_BAD_INPUT


if __name__ == "__main__":
    raise SystemExit(main())
