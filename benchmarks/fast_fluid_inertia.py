"""Fit the fast model's edge-inertia law (fluid_adapter/drag.py) to OpenFOAM's inertia.

The data are benchmarks/openfoam_added_mass.py's (as for benchmarks/fast_fluid_damping.py):
the clamped original fish moves in its first mode at 3 Hz, k-omega SST, coarse level, and the
lateral force's in-phase part per tail acceleration is m_cfd = 0.194 / 0.218 / 0.255 kg at 1 /
7.8 / 17.8 mm of tail amplitude. m_cfd = m0 + s a is nearly exact; the law's extra lateral
inertia on the same shape is gamma rho a sum_i A_i |phi_i| phi_i, so gamma = s / (rho sum A
|phi| phi). m0, the small-amplitude mass, is potential flow's (0.170 kg converged) plus the
coarse CFD's own excess (0.189 kg on the 102k-cell level): the law leaves it to the potential
model.

    .venv/bin/python benchmarks/fast_fluid_inertia.py [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.fast_fluid_damping import MASS_KG, TAIL_AMPLITUDE_M  # noqa: E402
from fishfsi.cli.prescribed import first_mode  # noqa: E402
from fluid_adapter.drag import edge_inertia  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from solid_adapter.build import build_shell_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DENSITY = 1820.0


def fit() -> dict:
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", ["fluid.model=none"])
    model = build_shell_model(case)
    _, shape = first_mode(case)
    phi = shape[:, 2]
    unit = float(edge_inertia(model, DENSITY, gamma=1.0).coefficients @ (np.abs(phi) * phi))
    slope, m0 = np.polyfit(TAIL_AMPLITUDE_M, MASS_KG, 1)
    line = m0 + slope * TAIL_AMPLITUDE_M
    return {
        "gamma": float(slope / unit),
        "slope_kg_per_m": float(slope),
        "small_amplitude_mass_kg": float(m0),
        "tail_amplitude_mm": (1e3 * TAIL_AMPLITUDE_M).tolist(),
        "openfoam_mass_kg": MASS_KG.tolist(),
        "line_mass_kg": line.tolist(),
        "relative_error": (line / MASS_KG - 1).tolist(),
        "nodes": int(model.n_nodes),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    result = fit()
    if args.json:
        print(json.dumps(result, indent=1))
        return
    print(
        f"gamma = {result['gamma']:.3f}: m_cfd = {result['small_amplitude_mass_kg']:.4f} kg + "
        f"{result['slope_kg_per_m']:.3f} kg/m x tail amplitude"
    )
    print(f"{'tail [mm]':>9} {'OpenFOAM [kg]':>14} {'line':>8} {'error':>7}")
    for a, m, line, e in zip(
        result["tail_amplitude_mm"],
        result["openfoam_mass_kg"],
        result["line_mass_kg"],
        result["relative_error"],
        strict=True,
    ):
        print(f"{a:9.1f} {m:14.3f} {line:8.4f} {100 * e:6.2f}%")


if __name__ == "__main__":
    main()
