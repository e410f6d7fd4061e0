"""Fit the fast model's edge-drag law (fluid_adapter/drag.py) to OpenFOAM's damping.

The fit uses benchmarks/openfoam_added_mass.py: the clamped original fish moves in its first
mode at 3 Hz, with k-omega SST at the coarse level. It gives the lateral force's damping per tail
velocity at 1, 7.8 and 17.8 mm of tail amplitude, as c / (omega m_cfd) and m_cfd. This script
finds C0 and q of C_D = C0 KC^-q such that the law's equivalent linear damping on the same
motion gives the same three values. It prints them with the residuals and the law's exponent.

    .venv/bin/python benchmarks/fast_fluid_damping.py [--json]

Re-measure the data with `benchmarks/openfoam_added_mass.py --level coarse --json` (20 min).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.prescribed import first_mode  # noqa: E402
from fluid_adapter.drag import edge_drag, harmonic_balance_factor  # noqa: E402
from fsi_orchestrator.case.loader import load_case  # noqa: E402
from solid_adapter.build import build_shell_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# benchmarks/openfoam_added_mass.py --level coarse (docs/coupling.md, "Start correction")
TAIL_AMPLITUDE_M = np.array([1.0e-3, 7.8e-3, 17.8e-3])
DAMPING_OVER_OMEGA_M = np.array([0.12, 0.51, 0.86])
MASS_KG = np.array([0.194, 0.218, 0.255])


def model_damping(model, shape_z: np.ndarray, amplitude_m: float, c0: float, q: float) -> float:
    """Lateral force per tail velocity of the law on the mode shape (tail = 1)."""
    drag = edge_drag(model, 1820.0, 3.0, c0=c0, q=q)
    p = drag.exponent
    speed = drag.omega * amplitude_m * np.abs(shape_z)
    c_eq = harmonic_balance_factor(p) * drag.coefficients * speed**p
    return float(c_eq @ shape_z)


def fit() -> dict:
    case = load_case(ROOT / "cases" / "fixed_head_3Hz", ["fluid.model=none"])
    model = build_shell_model(case)
    _, shape = first_mode(case)
    shape_z = shape[:, 2]
    omega = 2 * np.pi * 3.0
    measured = DAMPING_OVER_OMEGA_M * omega * MASS_KG

    def unit(q: float) -> np.ndarray:
        return np.array([model_damping(model, shape_z, a, 1.0, q) for a in TAIL_AMPLITUDE_M])

    def misfit(q: float) -> float:
        r = np.log(measured) - np.log(unit(q))
        return float(np.sum((r - r.mean()) ** 2))

    q = float(minimize_scalar(misfit, bounds=(0.0, 0.8), method="bounded").x)
    c0 = float(np.exp(np.mean(np.log(measured) - np.log(unit(q)))))
    law = c0 * unit(q)
    graham_c0 = float(np.exp(np.mean(np.log(measured) - np.log(unit(1 / 3)))))
    return {
        "c0": c0,
        "q": q,
        "tail_amplitude_mm": (1e3 * TAIL_AMPLITUDE_M).tolist(),
        "measured_ns_m": measured.tolist(),
        "law_ns_m": law.tolist(),
        "relative_error": (law / measured - 1).tolist(),
        "graham_q_one_third": {
            "c0": graham_c0,
            "relative_error": (graham_c0 * unit(1 / 3) / measured - 1).tolist(),
        },
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
    print(f"C_D = {result['c0']:.3g} KC^-{result['q']:.3f}")
    print(f"{'tail [mm]':>9} {'OpenFOAM [N s/m]':>17} {'law':>8} {'error':>7}")
    for a, m, law, e in zip(
        result["tail_amplitude_mm"],
        result["measured_ns_m"],
        result["law_ns_m"],
        result["relative_error"],
        strict=True,
    ):
        print(f"{a:9.1f} {m:17.3f} {law:8.3f} {100 * e:6.1f}%")
    g = result["graham_q_one_third"]
    errors = ", ".join(f"{100 * e:.0f} %" for e in g["relative_error"])
    print(f"with Graham's q = 1/3: C0 = {g['c0']:.3g}, errors {errors}")


if __name__ == "__main__":
    main()
