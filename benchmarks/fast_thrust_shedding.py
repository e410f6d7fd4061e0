"""Fit the fast thrust's shedding efficiency (fluid_adapter/slender_body.py) to OpenFOAM.

On the held fish's own coupled motion OpenFOAM's mean thrust is 0.43-0.86 of Lighthill's
reactive thrust on that motion, and the share grows with the trailing edge's Keulegan-Carpenter
number KC = 2 pi a / h (a the tail amplitude, h = 50 mm the fin's height at the trailing edge):
at small KC the shed vortices stay at the edge. This script fits KC0 of the share
KC / (KC + KC0) by least squares of the log ratio (scipy) on the sine curves, whose motion is
one harmonic, on the coarse and the default fluid level apart and together, and prints each
point's ratio, the law and the KC0 each point alone would need.

    .venv/bin/python benchmarks/fast_thrust_shedding.py [--json]

The data are the coupled sweeps of benchmarks/data/openfoam_held_fish_{coarse,default}.toml.
The square wave's curve is the check, on the fast model's own motion (each harmonic on its own
KC): `benchmarks/fast_fluid_accuracy.py cases/fixed_head_3Hz --set fluid.mesh_level=coarse`.
"""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fluid_adapter.slender_body import shedding_efficiency  # noqa: E402

DATA = Path(__file__).resolve().parent / "data"
LEVELS = ("coarse", "default")
TAIL_HEIGHT_M = 0.050  # the original fish's fin at the trailing edge (seed Table 3.4)


def points(level: str) -> dict[str, np.ndarray]:
    with open(DATA / f"openfoam_held_fish_{level}.toml", "rb") as f:
        sine = tomllib.load(f)["sine"]
    return {
        "frequency_hz": np.array(sine["frequency_hz"], dtype=float),
        "kc": 2 * np.pi * 1e-3 * np.array(sine["tail_mm"]) / TAIL_HEIGHT_M,
        "ratio": np.array(sine["thrust_mn"]) / np.array(sine["slender_body_thrust_mn"]),
    }


def fit_kc0(kc: np.ndarray, ratio: np.ndarray) -> float:
    def misfit(kc0: float) -> float:
        return float(np.sum(np.log(shedding_efficiency(kc, kc0) / ratio) ** 2))

    return float(minimize_scalar(misfit, bounds=(1e-3, 10.0), method="bounded").x)


def fit() -> dict:
    data = {level: points(level) for level in LEVELS}
    result: dict = {"levels": {}}
    for level, d in data.items():
        kc0 = fit_kc0(d["kc"], d["ratio"])
        law = shedding_efficiency(d["kc"], kc0)
        result["levels"][level] = {
            "kc0": kc0,
            "frequency_hz": d["frequency_hz"].tolist(),
            "kc": d["kc"].tolist(),
            "openfoam_over_lighthill": d["ratio"].tolist(),
            "law_relative_error": (law / d["ratio"] - 1).tolist(),
            "kc0_of_each_point": (d["kc"] * (1 / d["ratio"] - 1)).tolist(),
        }
    kc = np.concatenate([d["kc"] for d in data.values()])
    ratio = np.concatenate([d["ratio"] for d in data.values()])
    kc0 = fit_kc0(kc, ratio)
    errors = shedding_efficiency(kc, kc0) / ratio - 1
    result["kc0"] = kc0
    result["median_abs_error"] = float(np.median(np.abs(errors)))
    result["max_abs_error"] = float(np.max(np.abs(errors)))
    result["lighthill_median_abs_error"] = float(np.median(np.abs(1 / ratio - 1)))
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    result = fit()
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for level, r in result["levels"].items():
        print(f"{level} level: KC0 = {r['kc0']:.3f}")
        print(f"{'f [Hz]':>7} {'KC':>6} {'OpenFOAM / Lighthill':>21} {'law':>7} {'KC0 alone':>10}")
        for f, kc, q, e, k in zip(
            r["frequency_hz"],
            r["kc"],
            r["openfoam_over_lighthill"],
            r["law_relative_error"],
            r["kc0_of_each_point"],
            strict=True,
        ):
            print(f"{f:7g} {kc:6.2f} {q:21.3f} {100 * e:+6.1f}% {k:10.2f}")
    print(
        f"both levels: KC0 = {result['kc0']:.3f}; |error| median "
        f"{100 * result['median_abs_error']:.1f} %, max {100 * result['max_abs_error']:.1f} % "
        f"(Lighthill's thrust alone: median {100 * result['lighthill_median_abs_error']:.0f} %)"
    )


if __name__ == "__main__":
    main()
