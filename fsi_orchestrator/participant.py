"""The contract between the coupling loop and the solvers.

Modelled on preCICE's ``Participant`` (read data, solve a window, write data, checkpoint
queries): the loop drives any solver that implements this protocol and never imports a solver's
libraries. What crosses the boundary: numpy arrays on an :class:`InterfaceMesh`.

A window goes ``read_data -> solve(dt) -> write_data``. Implicit coupling stores a checkpoint at
the start of the window and restores it before solving the window again with new data.

Optional capabilities are Protocols of their own, checked with ``isinstance``:
:class:`InitializesData`, :class:`Monitored`, :class:`WritesFlowFields`, and on a fluid
:class:`HasAccelerationStencil` (used by the added-mass schemes) and :class:`FollowsMotion`
(the lead-in); on a structure :class:`OnPeriodicOrbit` (the periodic start) and
:class:`TakesAddedMass` (the added-mass schemes' preconditioning).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

# Names of exchanged fields (all on interface points, global frame, SI units).
DISPLACEMENT = "displacement"  # (n, 3) m, from the reference configuration
VELOCITY = "velocity"  # (n, 3) m/s
ACCELERATION = "acceleration"  # (n, 3) m/s^2
FORCE = "force"  # (n, 3) N, nodal forces (conservative: they sum to the total force)
PRESSURE = "pressure"  # (n,) Pa, net follower pressure (+z face minus -z face sign convention)
# (k, n, 3) m: the interface displacements a fluid was moved through at the k window ends
# before the first window, most recent first (initial data after a fluid-only lead-in)
PAST_DISPLACEMENT = "past_displacement"

State = Mapping[str, NDArray[Any] | float | int]


class ParticipantSetupError(RuntimeError):
    """A solver cannot do what it was asked whatever the iterate (a missing program, a request
    its set-up does not allow): the coupling passes it on as it is, without retrying the window
    or calling it a divergence."""


class ParticipantStopped(KeyboardInterrupt):
    """A participant's solver was stopped from outside (SIGTERM, SIGINT or SIGHUP: a
    scheduler's time limit or scancel signals every process of the job, the solver too). Not
    a failure of the run: it ends as an interruption does, with what it has checkpointed."""


@dataclass(frozen=True)
class InterfaceMesh:
    """Reference geometry of a participant's coupling interface."""

    points: NDArray[np.float64]  # (n, 3)
    cells: NDArray[np.int64]  # (m, k) indices into points
    cell_type: str  # meshio name: "quad9", "quad", "triangle", ...

    def __post_init__(self) -> None:
        assert self.points.ndim == 2 and self.points.shape[1] == 3
        assert self.cells.ndim == 2 and self.cells.max(initial=-1) < len(self.points)


@runtime_checkable
class Participant(Protocol):
    """A solver the coupling loop can drive."""

    name: str

    @property
    def time(self) -> float:
        """End time of the last solved (or restored) window."""
        ...

    def interface(self) -> InterfaceMesh: ...

    def read_data(self, data: Mapping[str, NDArray[np.float64]]) -> None:
        """Receive the other side's data for the next ``solve`` (e.g. ``{"force": f}``)."""
        ...

    def solve(self, dt: float) -> None:
        """Solve the window [time, time + dt] with the data read; afterwards time += dt."""
        ...

    def write_data(self) -> dict[str, NDArray[np.float64]]:
        """The window-end values this participant sends (e.g. displacement, velocity)."""
        ...

    def store_checkpoint(self) -> None:
        """Copy the current state aside; later changes of the live state must not touch it."""
        ...

    def restore_checkpoint(self) -> None:
        """Return to the stored state (time included) so the window can be solved again."""
        ...

    def save_state(self) -> dict[str, NDArray[Any] | float | int]:
        """Everything needed to continue a killed run bit-for-bit (written to checkpoint files)."""
        ...

    def load_state(self, state: State) -> None: ...

    def finalize(self) -> None: ...


@runtime_checkable
class InitializesData(Protocol):
    """Takes the exchanged values at the initial time (e.g. the fluid's force after a lead-in)."""

    def initialize_data(self, data: Mapping[str, NDArray[Any]]) -> None: ...


@runtime_checkable
class Monitored(Protocol):
    """Scalars and small arrays per window, for results.h5."""

    def monitor(self) -> Mapping[str, NDArray[Any] | float]: ...


@runtime_checkable
class WritesFlowFields(Protocol):
    """Writes files such as flow slices for the PVD series: {series name: path}."""

    def flow_fields(self) -> Mapping[str, Path]: ...


@runtime_checkable
class HasAccelerationStencil(Protocol):
    """A fluid that differentiates the window-end displacements it is given as
    a = sum_j c_j u_(n+1-j) / dt^2 (None: it does not say)."""

    @property
    def acceleration_stencil(self) -> tuple[float, ...] | None: ...


@runtime_checkable
class FollowsMotion(Protocol):
    """A fluid that runs prescribed windows in one go, returning each one's nodal forces."""

    def follow(
        self, displacements: Sequence[NDArray[np.float64]], dt: float
    ) -> list[NDArray[np.float64]]: ...


@runtime_checkable
class StartsDisplaced(Protocol):
    """A fluid that can start with its interface displaced and a flow it was given, instead of
    flat and at rest; its forces in the first ``start_up_windows`` windows are off."""

    @property
    def start_up_windows(self) -> int: ...

    def start_displaced(self, displacement: NDArray[np.float64]) -> None: ...


@runtime_checkable
class OnPeriodicOrbit(Protocol):
    """A structure started on a periodic orbit: its interface motion u(t) with all harmonics
    (None: not on one)."""

    def orbit_motion(self) -> Callable[[float], NDArray[np.float64]] | None: ...


@dataclass(frozen=True, kw_only=True)
class AddedMassPreconditioning:
    """How a structure takes the preconditioning added mass of the *-am coupling schemes.

    ``added_mass_z`` (M~, n x n on the interface nodes' normal accelerations, already scaled by
    coupling.added_mass_scale) joins the structure's inertia and stands for part of the exchanged
    force g = f + M~ a, so the structure weights it in time like that force. ``stencil``: how the
    fluid differentiates the displacements it is given (:class:`HasAccelerationStencil`), with
    which the structure forms the acceleration M~ multiplies, so that g holds the fluid's own;
    None: the structure's own acceleration."""

    added_mass_z: NDArray[np.float64]
    stencil: tuple[float, ...] | None = None


@runtime_checkable
class TakesAddedMass(Protocol):
    """A structure that carries the coupling's preconditioning added mass (None: none, the plain
    schemes)."""

    def take_added_mass(self, preconditioning: AddedMassPreconditioning | None) -> None: ...
