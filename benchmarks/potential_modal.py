"""Wet modal analysis (fsi-modal with fluid.model = "potential") per fluid mesh level: error of
the first two wet bending frequencies against the fine level, and wall time (mesh + added mass +
eigen-solve). Target: <= 10 s at <= 5 % error (test: Table 3.7 within 5 %)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.modal import modal_summary  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def run(level: str) -> tuple[list[float], float, int]:
    case = load_case(
        ROOT / "cases/fish_modal_free",
        ["fluid.model=potential", f"fluid.mesh_level={level}", "analysis.num_modes=4"],
    )
    start = time.perf_counter()
    s = modal_summary(case)
    bending = [f for f, k in zip(s["wet_hz"], s["wet_kinds"], strict=True) if k == "bending"]
    return bending[:2], time.perf_counter() - start, s["fluid_nodes"]


def main() -> None:
    results = {level: run(level) for level in ("fine", "default", "coarse")}
    ref = results["fine"][0]
    print("Table 3.7: 5.99, 24.99 Hz")
    print(
        f"{'level':>8} {'fluid nodes':>12} {'f1 Hz':>7} {'f2 Hz':>7} {'err f1 %':>9} "
        f"{'err f2 %':>9} {'wall s':>7}"
    )
    for level, (f, t, n) in results.items():
        print(
            f"{level:>8} {n:12d} {f[0]:7.3f} {f[1]:7.3f} {100 * (f[0] / ref[0] - 1):9.3f} "
            f"{100 * (f[1] / ref[1] - 1):9.3f} {t:7.1f}"
        )


if __name__ == "__main__":
    main()
