"""The per-unit-depth view of a one-cell-thick 2D fluid (fluid_adapter.openfoam.turek_fsi).

Hand-checkable: a fluid reporting nodal forces for a span of 0.01 m must hand the plane-strain
solid (which works per metre of depth) 100 times those forces, and change nothing else.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest

from fluid_adapter.openfoam.turek_fsi import PerUnitDepth
from fsi_orchestrator.participant import DISPLACEMENT, FORCE, InterfaceMesh, Participant, State


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
