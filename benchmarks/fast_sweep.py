"""The fast sweep: 13 frequencies 1-25 Hz, sine and square (target <= 60 s), the linear method's
amplitude against the nonlinear time-domain run at 3 Hz, and the cost of applying the interface
added-mass operator once (target < 5 ms)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.fast_model import shell_with_fast_fluid  # noqa: E402
from fishfsi.cli.linear import linear_sweep  # noqa: E402
from fishfsi.cli.run import run_dynamic  # noqa: E402
from fishfsi.cli.sweep import parse_frequencies  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402
from fsi_orchestrator.case.schema import Waveform  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OVERRIDES = ["fluid.model=potential", "fluid.damping_ratio=0.05", "output.vtk=false"]


def main() -> None:
    case = load_case(ROOT / "cases/fixed_head_3Hz", OVERRIDES)
    start = time.perf_counter()
    model, added = shell_with_fast_fluid(case)
    t_setup = time.perf_counter() - start
    a = np.random.default_rng(0).normal(size=model.n_nodes)
    n = 200
    t0 = time.perf_counter()
    for _ in range(n):
        added.force(a)
    t_apply = (time.perf_counter() - t0) / n
    start = time.perf_counter()
    rows = linear_sweep(case, parse_frequencies("1:25:2"), [Waveform.SINE, Waveform.SQUARE])
    t_sweep = time.perf_counter() - start
    print(
        f"added mass: {added.matrix.shape} dense, build {t_setup:.1f} s (cached afterwards), "
        f"one application {1e3 * t_apply:.3f} ms"
    )
    print(f"sweep of {len(rows)} runs (13 frequencies x 2 waveforms): {t_sweep:.1f} s")
    lin3 = next(
        r["tip_amplitude_m"] for r in rows if r["waveform"] == "sine" and r["frequency_hz"] == 3.0
    )
    start = time.perf_counter()
    nonlinear = run_dynamic(case, Path("/tmp/fast_sweep_bench"), False, False)
    t_run = time.perf_counter() - start
    print(
        f"3 Hz sine tail amplitude: linear {1e3 * lin3:.2f} mm, nonlinear time domain "
        f"{1e3 * nonlinear['tip_amplitude_m']:.2f} mm ({t_run:.1f} s), difference "
        f"{100 * (lin3 / nonlinear['tip_amplitude_m'] - 1):.1f} %"
    )


if __name__ == "__main__":
    main()
