"""The per-unit-depth view of a one-cell-thick 2D fluid (turek_hron.fsi).

Hand-checkable: a fluid reporting nodal forces for a span of 0.01 m must hand the plane-strain
solid (which works per metre of depth) 100 times those forces, and change nothing else.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from fsi_orchestrator.participant import DISPLACEMENT, FORCE, InterfaceMesh, Participant, State
from turek_hron.fsi import PerUnitDepth
from turek_hron.run import FsiHistory


class SpanFluid:
    """A fake fluid: fixed nodal forces (N on its span), echoes the displacement read."""

    name = "fluid"

    def __init__(self) -> None:
        self.points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        self.force = np.array([[1.0, 2.0, 0.0], [3.0, -4.0, 0.0], [0.5, 0.0, 0.0]])
        self.displacement = np.zeros((3, 3))
        self.t = 0.0

    @property
    def time(self) -> float:
        return self.t

    def interface(self) -> InterfaceMesh:
        return InterfaceMesh(self.points.copy(), np.array([[0, 1, 2]]), "triangle")

    def read_data(self, data: Mapping[str, np.ndarray]) -> None:
        self.displacement = np.array(data[DISPLACEMENT])

    def solve(self, dt: float) -> None:
        self.t += dt

    def write_data(self) -> dict[str, np.ndarray]:
        return {FORCE: self.force.copy(), DISPLACEMENT: self.displacement.copy()}

    def store_checkpoint(self) -> None: ...

    def restore_checkpoint(self) -> None: ...

    def save_state(self) -> dict[str, np.ndarray | float | int]:
        return {"t": self.t}

    def load_state(self, state: State) -> None: ...

    def finalize(self) -> None: ...


def test_forces_are_divided_by_the_depth_and_nothing_else_changes():
    fluid = SpanFluid()
    view = PerUnitDepth(fluid, 0.01)
    assert isinstance(view, Participant)
    u = np.full((3, 3), 1e-3)
    view.read_data({DISPLACEMENT: u})
    view.solve(0.5)
    data = view.write_data()
    np.testing.assert_allclose(data[FORCE], 100.0 * fluid.force, rtol=1e-15)
    np.testing.assert_array_equal(data[DISPLACEMENT], u)
    assert view.time == 0.5
    np.testing.assert_array_equal(fluid.force[0], [1.0, 2.0, 0.0])  # the fluid's own untouched


def test_depth_must_be_positive():
    with pytest.raises(ValueError, match="depth_m"):
        PerUnitDepth(SpanFluid(), 0.0)


def test_fsi3_statistics_leave_out_the_growth_and_survive_a_saved_history(tmp_path):
    """benchmarks/turek_hron_fsi3.py: a history saved while running reads back unchanged, and
    mean, amplitude and frequency over the windows after ``settle`` are those of the periodic
    part (here a sine of the reference's uy: 1.48 +- 34.38 mm at 5.3 Hz) whatever came before."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from turek_hron_fsi3 import load, oscillation, save

    t = np.arange(1, 3001) * 1e-3
    periodic = 1.48e-3 + 34.38e-3 * np.sin(2 * np.pi * 5.3 * t)
    uy = np.where(t < 1.0, 3 * periodic - 0.02, periodic)  # larger swings before settling
    h = FsiHistory(cells=7, time_s=list(t), wall_s=12.5, fluid_solves=[3] * len(t))
    h.tip_m = [np.array([-2.69e-3, y]) for y in uy]
    h.drag_n_m, h.lift_n_m = list(457.3 + 0 * t), list(150 * np.sin(2 * np.pi * 5.3 * t))
    save(h, tmp_path / "history.npz")
    back = load(tmp_path / "history.npz")
    assert back.cells == 7 and back.wall_s == 12.5 and back.fluid_solves == h.fluid_solves
    for name, values in h.arrays().items():
        np.testing.assert_array_equal(back.arrays()[name], values)
    keep = t >= 1.0
    mean, amplitude, frequency = oscillation(t[keep], uy[keep])
    assert mean == pytest.approx(1.48e-3, abs=2e-6)
    assert amplitude == pytest.approx(34.38e-3, rel=2e-4)
    assert frequency == pytest.approx(5.3, rel=1e-4)
