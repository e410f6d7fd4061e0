"""The potential-flow liquid as a separate coupling participant (for stability studies of the
coupling schemes): it returns the pressure force -M_a a_z on the structure's interface nodes.

By default a_z is the structure's own acceleration, read from it. With a ``stencil`` the liquid
instead differentiates the window-end displacements it is given, as a CFD code does
(OpenFOAM's backward scheme: BDF2 of BDF2, OpenFoamParticipant.acceleration_stencil): the
stand-in for the CFD's discrete added mass in the stability harness."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.participant import (
    ACCELERATION,
    DISPLACEMENT,
    FORCE,
    PAST_DISPLACEMENT,
    InterfaceMesh,
    State,
)

from .model import AddedMass


class PotentialParticipant:
    name = "fluid"

    def __init__(
        self,
        added_mass: AddedMass,
        interface: InterfaceMesh,
        stencil: tuple[float, ...] | None = None,
    ) -> None:
        self.added_mass = added_mass
        self._interface = interface
        self._stencil = stencil
        n = len(interface.points)
        self._accel = np.zeros((n, 3))
        self._force = np.zeros_like(self._accel)
        self._time = 0.0
        self._saved = 0.0
        # stencil: the z displacements at the last window ends, most recent first
        self._u = np.zeros(n)
        self._past = np.zeros((len(stencil) - 1 if stencil else 0, n))
        self._saved_past = self._past.copy()

    @property
    def acceleration_stencil(self) -> tuple[float, ...] | None:
        return self._stencil

    @property
    def time(self) -> float:
        return self._time

    def interface(self) -> InterfaceMesh:
        return self._interface

    def initialize_history(self, data: Mapping[str, NDArray]) -> None:
        """Displacements before the first window (most recent first; the latest is t = 0)."""
        past = np.asarray(data[PAST_DISPLACEMENT], dtype=float)[..., 2]
        k = min(len(past), len(self._past))
        self._past[:k] = past[:k]

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        if self._stencil is None:
            self._accel = np.asarray(data[ACCELERATION], dtype=float).reshape(-1, 3)
        else:
            self._u = np.asarray(data[DISPLACEMENT], dtype=float).reshape(-1, 3)[:, 2].copy()

    def solve(self, dt: float) -> None:
        self._force = np.zeros((len(self._interface.points), 3))
        if self._stencil is None:
            self._force[:, 2] = self.added_mass.force(self._accel[:, 2])
        else:
            levels = np.vstack([self._u, self._past])
            a = np.asarray(self._stencil) @ levels / dt**2
            self._force[:, 2] = self.added_mass.force(a)
            self._past = levels[:-1].copy()
        self._time += dt

    def write_data(self) -> dict[str, NDArray]:
        return {FORCE: self._force.copy()}

    def monitor(self) -> dict[str, NDArray | float]:
        return {"force_n": self._force.sum(axis=0)}

    def store_checkpoint(self) -> None:
        self._saved = self._time
        self._saved_past = self._past.copy()

    def restore_checkpoint(self) -> None:
        self._time = self._saved
        self._past = self._saved_past.copy()

    def save_state(self) -> dict[str, NDArray | float | int]:
        return {"time": self._time, "past": self._past.copy(), "force": self._force.copy()}

    def load_state(self, state: State) -> None:
        self._time = float(state["time"])
        if "past" in state:
            self._past = np.array(state["past"], dtype=float)
        if "force" in state:  # older checkpoints: none (the force of the next solve on)
            self._force = np.array(state["force"], dtype=float)

    def finalize(self) -> None:
        pass
