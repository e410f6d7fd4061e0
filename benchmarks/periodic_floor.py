"""How early can a coupled run's periodic state be known? The floor that the period-to-period
noise and the slow wet mode set, measured on finished runs.

For each ``results.h5`` (a transient run's output, or every point of a sweep folder) this
prints the tail amplitude and mean thrust per period, the largest relative change over the
last three periods (what a stop on ``time.periodic_tolerance`` must wait out), and two
estimates of the periodic amplitude made from the first n periods only:

- ``aitken``: the shipped estimate (:func:`fsi_orchestrator.periodic.estimate`), from the
  per-period amplitudes;
- ``inversion``: the tail history split into a periodic part and decaying modes. The
  transient's poles come from the matrix pencil of d_k = y_(k+P) - y_k (the period's lag
  cancels the periodic part), then one least-squares fit gives the periodic part per phase and
  each mode's weight.

Both are compared with the run's last period. Reproduce::

    .venv/bin/python benchmarks/periodic_floor.py SWEEP_OR_RUN [...] [--modes 4]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.post import drive_period_s  # noqa: E402
from fsi_orchestrator.periodic import estimate  # noqa: E402


def pencil_poles(d: np.ndarray, modes: int) -> np.ndarray:
    """Poles of the damped exponentials in ``d`` (matrix pencil, rank ``modes``)."""
    n = len(d)
    rows = n // 2
    hankel = np.array([d[i : i + rows + 1] for i in range(n - rows)])
    u, s, vh = np.linalg.svd(hankel[:, :-1], full_matrices=False)
    r = min(modes, int(np.sum(s > 1e-12 * s[0])))
    reduced = np.diag(1 / s[:r]) @ u[:, :r].conj().T @ hankel[:, 1:] @ vh[:r].conj().T
    poles = np.linalg.eigvals(reduced)
    return poles[np.abs(poles) < 1.0]  # decaying modes only


def inversion_amplitude(y: np.ndarray, per_period: int, modes: int) -> float:
    """Amplitude of the periodic part of ``y`` (whole or partial periods, at least 1.25)."""
    poles = pencil_poles(y[per_period:] - y[:-per_period], modes)
    k = np.arange(len(y))
    columns = [(k % per_period == p).astype(complex) for p in range(per_period)]
    columns += [z**k for z in poles]
    coef = np.linalg.lstsq(np.array(columns).T, y.astype(complex), rcond=None)[0]
    periodic = coef[:per_period].real
    return float(periodic.max() - periodic.min()) / 2


def study(path: Path, modes: int) -> None:
    with h5py.File(path) as f:
        tail = f["shell/tip_displacement_m"][:, 2] * 1e3
        thrust = f["fluid/thrust_n"][:, 0] * 1e3 if "fluid/thrust_n" in f else None
        dt_s = float(f.attrs["dt_s"])
    per_period = round(drive_period_s(path) / dt_s)
    n = len(tail) // per_period
    if n < 3:
        print(f"{path}: {n} periods, too few")
        return
    periods = [slice(k * per_period, (k + 1) * per_period) for k in range(n)]
    amp = [float(np.ptp(tail[s])) / 2 for s in periods]
    mean = [float(np.mean(thrust[s])) for s in periods] if thrust is not None else []
    final = amp[-1]

    def last_change(v: list[float]) -> float:
        return max(abs(b - a) / abs(b) for a, b in zip(v[-4:-1], v[-3:], strict=True))

    print(f"{path.parent.name}: {n} periods of {per_period} windows")
    print("  tail amplitude [mm] per period: " + " ".join(f"{a:.3f}" for a in amp))
    if mean:
        print("  mean thrust [mN] per period:    " + " ".join(f"{m:.2f}" for m in mean))
        print(
            f"  largest change over the last 3 periods: amplitude {last_change(amp):.1%}, "
            f"thrust {last_change(mean):.1%}"
        )
    for periods_used in (1.5, 2.0, 3.0, 4.0):
        end = int(periods_used * per_period)
        if end > len(tail) - per_period:
            break
        shipped = estimate(amp[: int(periods_used)])
        inverted = inversion_amplitude(tail[:end], per_period, modes)
        shipped_text = f"{(shipped.value / final - 1):+.1%}" if shipped else "-"
        print(
            f"  from {periods_used:.1f} periods, off the last period: aitken {shipped_text}, "
            f"inversion {inverted / final - 1:+.1%}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="run or sweep output folders")
    parser.add_argument("--modes", type=int, default=4, help="decaying modes fitted (2 per pair)")
    args = parser.parse_args()
    for folder in args.folders:
        for path in sorted(folder.glob("results.h5")) + sorted(folder.glob("*/results.h5")):
            study(path, args.modes)


if __name__ == "__main__":
    main()
