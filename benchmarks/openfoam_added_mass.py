"""OpenFOAM's lateral force against potential flow on the same prescribed motion: how much more
inertia and how much damping the CFD's liquid carries, versus the tail amplitude.

The fixed-head fish moves in its first clamped mode at 3 Hz (fishfsi.cli.prescribed,
3 periods of 40 windows); over the last period the lateral force F_z is fitted as
a sin wt + b cos wt + c, with the tail at A sin wt:

    m_cfd = a / (w^2 A)   (N per m/s^2 of tail acceleration),   c_cfd = -b / (w A),

and m_cfd is compared with the potential model's 1 . M~ phi (the preconditioner's added mass,
fluid mesh level ``--potential-level``). Why the coupled tail swings about half as far as the
potential-flow estimate, and what the start correction (fsi_orchestrator.start_orbit) fits.

    .venv/bin/python benchmarks/openfoam_added_mass.py [--level coarse]
        [--amplitudes-mm 1 7.8 17.8] [--potential-level coarse] [--turbulence kOmegaSST]
        [--json]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.compose import added_mass_for_preconditioning  # noqa: E402
from fishfsi.cli.prescribed import first_mode, run_prescribed  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from solid_adapter.build import build_shell_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
WINDOWS = 40


def potential_mass(case) -> float:
    """Lateral force of the potential model per unit tail acceleration in the first mode."""
    model = build_shell_model(case)
    matrix = added_mass_for_preconditioning(case, model).matrix
    _, shape = first_mode(case)
    return float(np.ones(len(matrix)) @ matrix @ shape[:, 2])


def one_amplitude(case, amplitude_m: float, folder: Path) -> dict:
    result = run_prescribed(case, folder, amplitude_m=amplitude_m, periods=3)
    t, fz = result.times_s[-WINDOWS:], result.force_n[-WINDOWS:, 2]
    w = 2 * np.pi * case.actuation.frequency_hz
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    a, b, _ = np.linalg.lstsq(basis, fz, rcond=None)[0]
    mass = a / (w**2 * amplitude_m)
    return {
        "amplitude_mm": 1e3 * amplitude_m,
        "mass_kg": float(mass),
        "damping_ns_m": float(-b / (w * amplitude_m)),
        "damping_over_omega_m": float(-b / (w * amplitude_m) / (w * mass)),
        "mean_thrust_n": result.mean_thrust(WINDOWS),
        "wall_s": result.wall_s,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", default="coarse")
    ap.add_argument("--amplitudes-mm", type=float, nargs="+", default=[1.0, 7.8, 17.8])
    ap.add_argument("--potential-level", default="coarse")
    ap.add_argument("--turbulence", default="kOmegaSST", help="kOmegaSST, Smagorinsky, laminar")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        [
            f"fluid.mesh_level={args.level}",
            f"coupling.added_mass_mesh_level={args.potential_level}",
            f"fluid.turbulence={args.turbulence}",
        ],
    )
    m_pot = potential_mass(case)
    root = Path(tempfile.mkdtemp(prefix="fishfsi-added-mass-"))
    root.chmod(0o755)
    try:
        rows = [one_amplitude(case, 1e-3 * a, root / f"a{a:g}") for a in args.amplitudes_mm]
    finally:
        shutil.rmtree(root, ignore_errors=True)
    for r in rows:
        r["mass_over_potential"] = r["mass_kg"] / m_pot
    if args.json:
        print(json.dumps({"potential_mass_kg": m_pot, "rows": rows}, indent=1))
        return
    print(
        f"potential model ({args.potential_level}): {m_pot:.4f} kg; "
        f"OpenFOAM ({args.level}, {args.turbulence}):"
    )
    print(f"{'tail [mm]':>9} {'m_cfd [kg]':>10} {'/ m_pot':>8} {'c/(w m)':>8} {'thrust [N]':>10}")
    for r in rows:
        print(
            f"{r['amplitude_mm']:9.1f} {r['mass_kg']:10.4f} {r['mass_over_potential']:8.3f} "
            f"{r['damping_over_omega_m']:8.3f} {r['mean_thrust_n']:10.4f}"
        )


if __name__ == "__main__":
    main()
