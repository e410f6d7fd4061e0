"""Turek & Hron FSI3 with the real OpenFOAM and the plane-strain flag (case turek_hron_fsi3).

Channel, cylinder and flag of Turek & Hron (2006); fluid rho = 1000 kg/m3, nu = 1e-3 m2/s,
parabolic inflow of mean 2 m/s (Re = 200); flag St. Venant-Kirchhoff in plane strain,
rho_s = 1000 kg/m3, mu_s = 2e6 Pa, nu_s = 0.4. The fluid starts from a simpleFoam solution with
the flag rigid (no inflow ramp); pimpleFoam (backward, moving mesh) and the flag (generalized-
alpha, rho_inf = 1: the trapezoidal rule) are coupled implicitly with IQN-ILS, one window per
``--dt``. The run prints the window history and, at the end, mean +- amplitude and frequency of
point A's displacement and of drag and lift over the last complete periods, against the
reference (Turek & Hron 2006, table "FSI3", finest level):

    ux = -2.69 +- 2.53 mm, uy = 1.48 +- 34.38 mm at 5.3 Hz,
    drag = 457.3 +- 22.66 N/m, lift = 2.22 +- 149.78 N/m.

The steady start already pushes the flag, which swings at once and is periodic from ~0.8 s;
one fluid step per window (the default) makes the flag's and the cylinder's forces window
values alike. Measured: 1.6 s at 2 ms windows in 25 min on the 2-core machine, 3.6 fluid solves
per window (cases/turek_hron_fsi3/README.md has the figures); shorter runs report what they
have, ``--report`` reports a saved or killed run again.

    .venv/bin/python benchmarks/turek_hron_fsi3.py --end-time 1.6 --dt 2e-3 --settle 0.8 \
        --workdir /tmp/fsi3
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fsi_orchestrator.case.schema import CouplingScheme, TimeScheme  # noqa: E402
from fsi_orchestrator.coupling_settings import CouplingSettings, scheme_settings  # noqa: E402
from turek_hron.fsi import FSI3, build_fluid, generate_fsi_case  # noqa: E402
from turek_hron.run import FsiHistory, flag_participant, run_coupled  # noqa: E402


def oscillation(t: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """(mean, amplitude, frequency) over the last complete periods, from the upward crossings
    of the mid-range; NaN frequency when fewer than two crossings."""
    if len(y) < 3:
        return float("nan"), float("nan"), float("nan")
    mid = 0.5 * (y.max() + y.min())
    up = np.flatnonzero((y[:-1] < mid) & (y[1:] >= mid))
    if len(up) < 2:
        return mid, 0.5 * float(np.ptp(y)), float("nan")
    crossings = t[up] + (mid - y[up]) / (y[up + 1] - y[up]) * (t[up + 1] - t[up])
    last = slice(up[0], up[-1] + 1)
    lo, hi = float(y[last].min()), float(y[last].max())
    frequency = (len(crossings) - 1) / (crossings[-1] - crossings[0])
    return 0.5 * (hi + lo), 0.5 * (hi - lo), float(frequency)


SAVE_EVERY = 50  # windows


def save(h: FsiHistory, path: Path) -> None:
    d = h.arrays()
    np.savez(path, solves=np.array(h.fluid_solves), wall_s=h.wall_s, cells=h.cells, **d)


def load(path: Path) -> FsiHistory:
    d = np.load(path)
    return FsiHistory(
        cells=int(d["cells"]),
        time_s=list(d["t"]),
        tip_m=[np.array(u) for u in zip(d["ux"], d["uy"], strict=True)],
        drag_n_m=list(d["drag"]),
        lift_n_m=list(d["lift"]),
        fluid_solves=[int(n) for n in d["solves"]],
        wall_s=float(d["wall_s"]),
    )


def report(h: FsiHistory, settle_s: float = 0.0) -> None:
    """Mean, amplitude and frequency from the windows after ``settle_s`` (the growth of the
    oscillation from the rigid-flag start is not the benchmark's periodic state)."""
    data = h.arrays()
    keep = data["t"] >= settle_s
    data = {k: v[keep] for k, v in data.items()}
    rows = [
        ("ux (mm)", 1e3 * data["ux"], FSI3.ux_ref_mm),
        ("uy (mm)", 1e3 * data["uy"], FSI3.uy_ref_mm),
        ("drag (N/m)", data["drag"], FSI3.drag_ref_n_m),
        ("lift (N/m)", data["lift"], FSI3.lift_ref_n_m),
    ]
    print(
        f"\n{h.cells} cells, {len(h.time_s)} windows ({keep.sum()} after {settle_s:g} s), "
        f"{sum(h.fluid_solves)} fluid solves ({np.mean(h.fluid_solves):.2f} per window), "
        f"{h.wall_s:.0f} s"
    )
    print(f"{'quantity':12s} {'mean':>10s} {'ampl.':>10s} {'f (Hz)':>8s}   reference")
    for name, series, (mean_ref, amp_ref) in rows:
        mean, amp, freq = oscillation(data["t"], series)
        ref = f"{mean_ref:g} +- {amp_ref:g}"
        if name.startswith("uy"):
            ref += f" at {FSI3.frequency_ref_hz:g} Hz"
        print(f"{name:12s} {mean:10.4g} {amp:10.4g} {freq:8.3g}   {ref}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--end-time", type=float, default=0.1, help="simulated time (s)")
    parser.add_argument("--dt", type=float, default=1e-3, help="coupling window (s)")
    parser.add_argument("--workdir", type=Path, default=Path("benchmarks/out/turek_hron_fsi3"))
    parser.add_argument("--body-size", type=float, default=2.5e-3, help="cell size at the body")
    parser.add_argument("--far-size", type=float, default=0.02, help="cell size far away")
    parser.add_argument("--steady-iterations", type=int, default=1500)
    parser.add_argument("--tolerance", type=float, default=1e-4, help="coupling tolerance")
    parser.add_argument(
        "--scheme", choices=("iqn-ils", "iqn-imvj"), default="iqn-ils", help="quasi-Newton"
    )
    parser.add_argument(
        "--predictor", choices=("constant", "linear", "quadratic"), default="linear"
    )
    parser.add_argument(
        "--max-courant",
        type=float,
        default=10.0,
        help="fluid sub-steps per window above this Courant number (default: one step per "
        "window, so that every force is a window value; see cases/turek_hron_fsi3/README.md)",
    )
    parser.add_argument(
        "--settle", type=float, default=0.0, help="report only the windows after this time (s)"
    )
    parser.add_argument(
        "--report", action="store_true", help="only report the workdir's saved history.npz"
    )
    args = parser.parse_args(argv)
    if args.report:
        report(load(args.workdir / "history.npz"), args.settle)
        return 0

    start = time.perf_counter()
    settings = generate_fsi_case(
        args.workdir,
        FSI3,
        body_size=args.body_size,
        far_size=args.far_size,
        steady_iterations=args.steady_iterations,
        time_scheme=TimeScheme.BACKWARD,
        max_courant=args.max_courant,
    )
    print(f"case and rigid-flag start: {time.perf_counter() - start:.0f} s", flush=True)
    n_windows = max(1, round(args.end_time / args.dt))
    fluid = build_fluid(args.workdir / "fsi", settings, args.dt, n_windows)
    solid = flag_participant(FSI3, static=False, elements=(40, 4))
    coupling = CouplingSettings(
        scheme_settings=scheme_settings(
            CouplingScheme(args.scheme), relaxation=0.5, max_iterations=30
        ),
        tolerance_rel=args.tolerance,
        predictor=args.predictor,
    )

    def progress(h: FsiHistory) -> None:
        ux, uy = 1e3 * h.tip_m[-1]
        print(
            f"t = {h.time_s[-1]:.4f} s  ux = {ux:8.4f} mm  uy = {uy:8.4f} mm  "
            f"drag = {h.drag_n_m[-1]:8.3f}  lift = {h.lift_n_m[-1]:8.3f} N/m  "
            f"solves {h.fluid_solves[-1]:2d}  {h.wall_s:.0f} s",
            flush=True,
        )
        if len(h.time_s) % SAVE_EVERY == 0:  # a long run killed keeps what it computed
            save(h, args.workdir / "history.npz")

    history = run_coupled(
        fluid, solid, coupling, dt=args.dt, max_windows=n_windows, progress=progress
    )
    save(history, args.workdir / "history.npz")
    report(history, args.settle)
    return 0


if __name__ == "__main__":
    sys.exit(main())
