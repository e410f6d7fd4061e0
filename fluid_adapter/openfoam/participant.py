"""The OpenFOAM fluid as a coupling participant (fsi_orchestrator.participant.Participant).

Interface: the fish patches' points (both faces of the plate share them) and their faces (each
plate face appears twice, once per side). Reads point displacements (from the reference
configuration, interface point order); writes nodal forces (each face force split equally among
its points, so they sum to the total force), plus the face forces, face centres and face
pressures they came from. Checkpoints are time folders; going back to one ends a persistent
driver's process and goes on with one started there (drivers.py).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case.schema import TimeScheme
from fsi_orchestrator.participant import DISPLACEMENT, FORCE, InterfaceMesh, State

from .checkmesh import MeshQuality, folded_mesh
from .drivers import PersistentDriver, RelaunchDriver
from .errors import DivergenceError, DriverError, LeadInDivergenceError, MeshFoldedError
from .flow_start import START_UP_WINDOWS, FlowSource, place
from .foamrun import FoamRun
from .loads import SurfaceLoads
from .rest_mesh import DriftSchedule, reset_points
from .slices import Surface, sample_slices

FACE_FORCE = "face_force"  # (m, 3) N
FACE_CENTRES = "face_centres"  # (m, 3) m, moved mesh
FACE_PRESSURE = "face_pressure"  # (m,) Pa
# checkMesh of the moved mesh every this many windows (0.1 s on the coarse fish): a fold at the
# fin's edge leaves pimpleFoam running on inside-out cells for windows before it blows up
MESH_CHECK_WINDOWS = 10


class OpenFoamParticipant:
    name = "fluid"
    mesh_quality: MeshQuality | None = None  # checkMesh of the generated mesh

    def __init__(
        self,
        run: FoamRun,
        driver: RelaunchDriver | PersistentDriver,
        *,
        dt: float,
        n_windows: int,
        flow_surfaces: tuple[Surface, ...] = (),
        flow_from: FlowSource | None = None,
        drift_reset_windows: int = 0,
    ) -> None:
        """``flow_from``: an earlier run's flow to start from (start_displaced).
        ``drift_reset_windows``: put the moved mesh back on its path from rest after this many
        windows, and then as often as its drift needs (rest_mesh.py; 0: never)."""
        self.run, self.driver = run, driver
        self.drift = DriftSchedule(first=drift_reset_windows, longest=max(n_windows, 1))
        self.flow_from = flow_from
        self.flow_surfaces = flow_surfaces
        self.dt, self.n_windows = dt, n_windows
        n = len(run.interface.points0)
        self._displacement = np.zeros((n, 3))
        self._loads: SurfaceLoads | None = None
        self._checkpoint: tuple[NDArray, SurfaceLoads | None] | None = None
        self._mesh_checked_at = 0  # the last window start whose moved mesh was checked

    @property
    def mesh_resets(self) -> list[tuple[int, float]]:
        """The moved mesh's resets so far: (fluid window, largest point shift m)."""
        return list(self.drift.resets)

    @property
    def acceleration_stencil(self) -> tuple[float, ...]:
        """How pimpleFoam differentiates the window-end displacements u_k it is given, as
        a = sum_j c_j u_(n+1-j) / dt^2 (one fluid step per window): the plate's normal
        velocity is the mesh flux (``backward``: fvc::meshPhi = 3/2 phi_n - 1/2 phi_n-1, i.e.
        BDF2 of u) and the momentum ddt differentiates it once more (BDF2 of that; Euler:
        first differences twice). The added-mass schemes weigh M~ with it (docs/coupling.md)."""
        if self.run.settings.time_scheme is TimeScheme.EULER:
            return (1.0, -2.0, 1.0)
        return (2.25, -6.0, 5.5, -2.0, 0.25)  # (3/2, -2, 1/2) convolved with itself

    # --------------------------------------------------------------- protocol
    @property
    def time(self) -> float:
        return self.driver.time

    def interface(self) -> InterfaceMesh:
        return InterfaceMesh(
            points=self.run.interface.points0.copy(),
            cells=self.run.interface.faces.copy(),
            cell_type="quad",
        )

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        if DISPLACEMENT not in data:
            return
        u = np.asarray(data[DISPLACEMENT], dtype=float)
        expected = self.run.interface.points0.shape
        if u.shape != expected:
            raise ValueError(
                f"fluid '{DISPLACEMENT}' must have shape {expected} (interface points x 3), "
                f"got {u.shape}; map the solid's displacement onto fluid.interface() first"
            )
        self._displacement = u.copy()

    def solve(self, dt: float) -> None:
        self._undo_drift(dt)
        self._check_moved_mesh(dt)
        try:
            self._loads = self.driver.advance(self._displacement, dt)
        except DivergenceError as exc:
            folded = self._folded_mesh_now(dt)
            if folded is None:
                raise
            raise MeshFoldedError(
                f"pimpleFoam diverged in {self.run.path}: {folded}. A smaller drive or a "
                "stiffer design keeps the mesh whole; case folder kept"
            ) from exc

    def _folded_mesh_now(self, dt: float) -> str | None:
        """checkMesh's verdict on the window start's moved mesh (serial cases; None: whole)."""
        if self.run.processes != 1:
            return None
        try:
            name = self.run.time_folder(self.time, dt)
        except FileNotFoundError:  # nothing written at the window start: nothing to check
            return None
        return folded_mesh(self.run.path, name)

    def _undo_drift(self, dt: float) -> None:
        """At a window start the schedule names (its first solve only): the window start's
        points back on the path from rest; the loaded solvers hold the old ones, so they go."""
        window = int(round(self.time / dt))
        if not self.drift.due(window):
            return
        try:
            name = self.run.time_folder(self.time, dt)
        except FileNotFoundError:  # nothing written at the window start
            return
        self.driver.release()
        self.drift.record(window, reset_points(self.run, name, self.driver.displacement, dt))

    def _check_moved_mesh(self, dt: float) -> None:
        """Every MESH_CHECK_WINDOWS windows: stop on a folded mesh rather than pass on the
        forces of inside-out cells (the windows before are kept)."""
        window = int(round(self.time / dt))
        if window <= 0 or window % MESH_CHECK_WINDOWS or window == self._mesh_checked_at:
            return
        self._mesh_checked_at = window
        folded = self._folded_mesh_now(dt)
        if folded is not None:
            raise MeshFoldedError(
                f"{self.run.path}: {folded}; its flow is wrong, so the run stops here. A "
                "smaller drive or a stiffer design keeps the mesh whole"
            )

    @property
    def start_up_windows(self) -> int:
        """Windows a start_displaced case is off its force (flow_start.START_UP_WINDOWS)."""
        return START_UP_WINDOWS

    def start_displaced(self, displacement: NDArray) -> None:
        """Before the first window (optional in the protocol; the lead-in on a recorded
        orbit): the plate at ``displacement`` (interface points), the mesh moved with it, and
        the flow of ``flow_from`` mapped on (flow_start.py)."""
        u = np.asarray(displacement, dtype=float)
        if self.flow_from is None:
            raise DriverError(f"{self.run.path}: no earlier run's flow to start displaced with")
        if u.shape != self.run.interface.points0.shape or self.time != 0.0:
            raise DriverError("start_displaced needs a fresh case and interface displacements")
        place(self.run, u, self.dt, self.flow_from)
        self.driver.displacement = u.copy()
        self._displacement = u.copy()

    def follow(self, displacements: Sequence[NDArray], dt: float) -> list[NDArray]:
        """Prescribed motion (optional in the protocol; the coupling's lead-in): the next
        windows with these window-end displacements, one after the other; returns each
        window's nodal forces. One pimpleFoam launch runs them all (batch, no handshakes),
        saving a start-up per window (0.6 s at the default level) with the relaunch driver."""
        if not displacements:
            return []
        given = [np.asarray(u, dtype=float) for u in displacements]
        try:
            loads = self.driver.advance_prescribed(given, dt)
        except DivergenceError as exc:
            # the lead-in follows the fast model's orbit, undamped near a wet resonance: the
            # hinged thrust rig's at 3 Hz (27 mm) blew up here and ran from rest (13 mm)
            first, _, rest = str(exc).partition("\n")
            raise LeadInDivergenceError(
                f"{first} It diverged in the lead-in, where the liquid follows the fast "
                "model's periodic orbit before window 1: `--set time.start=rest` starts the "
                "run from rest with a voltage ramp instead\n" + rest
            ) from exc
        self._displacement, self._loads = given[-1].copy(), loads[-1]
        return [self.run.interface.nodal_forces(window.face_forces) for window in loads]

    def write_data(self) -> dict[str, NDArray]:
        loads = self._require_loads()
        return {
            DISPLACEMENT: self._displacement.copy(),
            FORCE: self.run.interface.nodal_forces(loads.face_forces),
            FACE_FORCE: loads.face_forces.copy(),
            FACE_CENTRES: loads.face_centres.copy(),
            FACE_PRESSURE: loads.pressure_pa.copy(),
        }

    def monitor(self) -> dict[str, NDArray | float]:
        """Integrated loads on the fish: force (N), moment about the nose (N m), thrust = -F_x."""
        loads = self._require_loads()
        return {"force_n": loads.force, "moment_nm": loads.moment, "thrust_n": loads.thrust}

    def flow_fields(self) -> dict[str, Path]:
        """Flow surfaces (p, U, vorticity) at the last window's end, sampled from its time
        folder (optional in the protocol): {series name: .vtp file}, to be moved away by the
        caller."""
        if not self.flow_surfaces:
            return {}
        time_name = self.run.time_folder(self.time, self.dt)
        found = sample_slices(self.run.path, time_name, self.flow_surfaces, self.run.processes)
        return {f"flow_{name}": path for name, path in found.items()}

    def store_checkpoint(self) -> None:
        self.driver.store()
        self._checkpoint = (self._displacement.copy(), self._loads)

    def restore_checkpoint(self) -> None:
        if self._checkpoint is None:
            raise DriverError("restore_checkpoint called before store_checkpoint")
        self.driver.restore()
        u, loads = self._checkpoint
        self._displacement, self._loads = u.copy(), loads

    def save_state(self) -> dict[str, NDArray | float | int]:
        self.driver.saved = self.time
        state: dict[str, NDArray | float | int] = {
            "t": self.time,
            "displacement": self.driver.displacement.copy(),
            "input_displacement": self._displacement.copy(),
            # the mesh resets' schedule: a resumed run keeps its pace and its record
            "drift_next_at": self.drift.next_at,
            "drift_resets": np.array(self.drift.resets, dtype=float).reshape(-1, 2),
        }
        if self._loads is not None:
            state.update(
                face_forces=self._loads.face_forces.copy(),
                face_centres=self._loads.face_centres.copy(),
                face_area_vectors=self._loads.face_area_vectors.copy(),
                face_pressure=self._loads.pressure_pa.copy(),
            )
        return state

    def load_state(self, state: State) -> None:
        t = float(state["t"])
        u = np.array(state["displacement"], dtype=float)
        if t > 0:
            try:
                self.run.time_folder(t, self.dt)
            except FileNotFoundError:  # the loop says it in one line: the run starts afresh
                raise ValueError(
                    f"{self.run.path} holds no flow at the checkpoint's t = {t:.6g} s: the fluid "
                    "folder was generated afresh (its settings changed) or lost its time folders"
                ) from None
        self.driver = self._driver_at(t, u)
        self._displacement = np.array(state["input_displacement"], dtype=float)
        if "drift_next_at" in state:  # (absent in a checkpoint from before the resets)
            self.drift.next_at = int(state["drift_next_at"])
            resets = np.asarray(state["drift_resets"], dtype=float).reshape(-1, 2)
            self.drift.resets = [(int(w), float(shift)) for w, shift in resets]
        self._loads = None
        if "face_forces" in state:
            self._loads = SurfaceLoads(
                time=t,
                face_centres=np.array(state["face_centres"], dtype=float),
                face_area_vectors=np.array(state["face_area_vectors"], dtype=float),
                pressure_pa=np.array(state["face_pressure"], dtype=float),
                face_forces=np.array(state["face_forces"], dtype=float),
            )

    def finalize(self) -> None:
        self.driver.close()

    # --------------------------------------------------------------- helpers
    def _require_loads(self) -> SurfaceLoads:
        if self._loads is None:
            raise DriverError("no fluid loads yet: call solve(dt) before write_data()/monitor()")
        return self._loads

    def _driver_at(self, t: float, u: NDArray) -> RelaunchDriver | PersistentDriver:
        """A driver continuing from the time folder at ``t`` (later folders are dropped)."""
        self.driver.close()
        self.run.remove_times({"0"}, after=t + 1e-6 * self.dt)
        self.run.remove_samples(self.dt, after=t)
        if isinstance(self.driver, PersistentDriver):
            done = round(t / self.dt)
            return PersistentDriver(
                self.run,
                self.dt,
                self.n_windows - done,
                t0=t,
                u0=u,
                prelaunch=self.driver.prelaunch,
            )
        driver = RelaunchDriver(self.run, self.dt, t0=t, u0=u, prelaunch=self.driver.prelaunch)
        driver.saved = t
        return driver
