"""The potential-flow liquid as a separate coupling participant (for stability studies of the
coupling schemes): it reads the structure's interface accelerations and returns the pressure
force -M_a a_z. Stateless between windows, so checkpoints are trivial."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.participant import ACCELERATION, FORCE, InterfaceMesh, State

from .model import AddedMass


class PotentialParticipant:
    name = "fluid"

    def __init__(self, added_mass: AddedMass, interface: InterfaceMesh) -> None:
        self.added_mass = added_mass
        self._interface = interface
        self._accel = np.zeros((len(interface.points), 3))
        self._force = np.zeros_like(self._accel)
        self._time = 0.0
        self._saved = 0.0

    @property
    def time(self) -> float:
        return self._time

    def interface(self) -> InterfaceMesh:
        return self._interface

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        self._accel = np.asarray(data[ACCELERATION], dtype=float).reshape(-1, 3)

    def solve(self, dt: float) -> None:
        self._force = np.zeros_like(self._accel)
        self._force[:, 2] = self.added_mass.force(self._accel[:, 2])
        self._time += dt

    def write_data(self) -> dict[str, NDArray]:
        return {FORCE: self._force.copy()}

    def monitor(self) -> dict[str, NDArray | float]:
        return {"force_n": self._force.sum(axis=0)}

    def store_checkpoint(self) -> None:
        self._saved = self._time

    def restore_checkpoint(self) -> None:
        self._time = self._saved

    def save_state(self) -> dict[str, NDArray | float | int]:
        return {"time": self._time}

    def load_state(self, state: State) -> None:
        self._time = float(state["time"])

    def finalize(self) -> None:
        pass
