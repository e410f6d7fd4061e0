"""Plane-strain flag (turek_hron.plane_strain) on the Turek & Hron (2006) CSM tests.

(a) CSM1 (static, g = 2 m/s^2): tip error against Turek & Hron's table, per mesh and clamp shape
    (the cylinder's arc or the straight line x = 0.24899), with wall time.
(b) CSM3 (dynamic, g = 2 m/s^2 switched on at t = 0, from rest): mean, amplitude and frequency
    of the tip displacement over the last full period, against the same paper.

Reference values (Turek & Hron 2006, "Proposal for numerical benchmarking of fluid-structure
interaction between an elastic object and laminar incompressible flow", tables for CSM1 and
CSM3, finest level): CSM1 ux = -7.187e-3 m, uy = -66.10e-3 m; CSM3 ux = -14.305 +- 14.305 mm,
uy = -63.607 +- 65.160 mm, frequency 1.0995 Hz.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from turek_hron.plane_strain import (  # noqa: E402
    FlagGeometry,
    build_flag_participant,
    solve_csm,
)

MATERIAL: dict[str, Any] = {
    "density_kg_m3": 1000.0,
    "shear_modulus_pa": 0.5e6,
    "poisson_ratio": 0.4,
}
CSM1_REF_M = np.array([-7.187e-3, -66.10e-3])
CSM3_REF_MM = {"ux": (-14.305, 14.305), "uy": (-63.607, 65.160)}
CSM3_REF_HZ = 1.0995
MESHES = ((10, 1), (20, 2), (40, 4), (80, 8), (160, 16))


def csm1_table() -> None:
    print("(a) CSM1: tip error against Turek & Hron (ux -7.187 mm, uy -66.10 mm)")
    print(f"{'clamp':>8} {'elements':>9} {'dofs':>6} {'ux err %':>9} {'uy err %':>9} {'time s':>7}")
    for curved in (True, False):
        for nx, ny in MESHES:
            start = time.perf_counter()
            tip = solve_csm(
                **MATERIAL,
                gravity_m_s2=2.0,
                elements=(nx, ny),
                geometry=FlagGeometry.turek_hron(curved_clamp=curved),
            )
            wall = time.perf_counter() - start
            err = 100 * (tip / CSM1_REF_M - 1)
            dofs = 2 * (2 * nx + 1) * (2 * ny + 1)
            name = "arc" if curved else "straight"
            print(f"{name:>8} {nx:>4} x {ny:<2} {dofs:>6} {err[0]:9.3f} {err[1]:9.3f} {wall:7.2f}")


def last_period(t: np.ndarray, u: np.ndarray) -> tuple[float, float, float]:
    """Mean, amplitude and frequency from the last two upward crossings of the mean (crossing
    times interpolated linearly between steps)."""
    level = 0.5 * (u.max() + u.min())
    up = np.flatnonzero((u[:-1] < level) & (u[1:] >= level))
    crossing = t[up] + (level - u[up]) * (t[up + 1] - t[up]) / (u[up + 1] - u[up])
    seg = u[up[-2] : up[-1] + 1]
    return 0.5 * (seg.max() + seg.min()), 0.5 * (seg.max() - seg.min()), 1.0 / np.diff(crossing)[-1]


def csm3(elements: tuple[int, int], dt: float, t_end: float, rho_inf: float) -> None:
    flag = build_flag_participant(**MATERIAL, gravity_m_s2=2.0, elements=elements, rho_inf=rho_inf)
    steps = int(round(t_end / dt))
    tip = np.zeros((steps, 2))
    start = time.perf_counter()
    for k in range(steps):
        flag.solve(dt)
        tip[k] = np.asarray(flag.monitor()["tip_displacement_m"])[:2]
    wall = time.perf_counter() - start
    t = dt * np.arange(1, steps + 1)
    print(
        f"(b) CSM3, {elements[0]} x {elements[1]} elements, dt = {dt} s, rho_inf = {rho_inf}, "
        f"{t_end} s: {wall:.1f} s wall, "
        f"{flag.integrator.newton_iterations / steps:.2f} Newton iterations per step"
    )
    for k, name in enumerate(("ux", "uy")):
        mean, amp, freq = last_period(t, 1e3 * tip[:, k])
        ref_mean, ref_amp = CSM3_REF_MM[name]
        print(
            f"    {name}: {mean:8.3f} +- {amp:7.3f} mm [{freq:.4f} Hz]   "
            f"reference {ref_mean} +- {ref_amp} [{CSM3_REF_HZ}]"
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, default=0.005, help="CSM3 time step (s)")
    parser.add_argument("--t-end", type=float, default=10.0, help="CSM3 end time (s)")
    parser.add_argument("--rho-inf", type=float, default=1.0)
    parser.add_argument("--elements", type=int, nargs=2, default=(40, 4))
    args = parser.parse_args(argv)
    csm1_table()
    csm3(tuple(args.elements), args.dt, args.t_end, args.rho_inf)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
