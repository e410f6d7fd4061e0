"""A generated case being run: time folders, interface motion in, loads out.

The mesh moves with ``velocityLaplacian`` (motion.py says why), so the plate's *velocity* is
what OpenFOAM reads: ``timeVaryingMappedFixedValue`` files
``constant/boundaryData/<patch>/<time>/pointMotionU`` (one value per reference interface point,
mapped by nearest reference point, so serial and decomposed runs read the same files; the second
plate patch's folder is a link to the first's). Window k, from t_{k-1} to t_k, moves the plate
at the constant velocity v_k = (u_k - u_{k-1}) / dt, so it reaches the window-end displacement
u_k exactly, however many fluid steps the window takes.

That reader scans the sample folders once, at start-up, interpolates between the two that
bracket its time, and when it moves on it keeps the later one without reading it again. Hence
three samples per window: t_{k-1} + 2 eps, t_k and t_k + eps, all v_k. The steps inside the
window bracket [t_{k-1} + 2 eps, t_k]; the step ending at t_k brackets [t_k, t_k + eps] and keeps
t_k + eps, whose value v_k is final by then; the next window's steps read t_k + 2 eps and
t_{k+1} fresh, and the driver writes them before that window starts. A persistent run creates
every planned folder at start-up with a placeholder overwritten before it is first read. Time
folders of the case are the restart files; whatever a restart no longer needs is deleted.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from foamlib import FoamFieldFile, FoamFile
from numpy.typing import NDArray

from . import runner
from .casefiles import (
    HANDSHAKE_FO,
    MOTION_FIELD,
    SAMPLE_FO,
    FlowSettings,
    handshake_function,
    window_controls,
)
from .foamio import update_dict
from .interface import FluidInterface
from .loads import SurfaceLoads, read_loads

FIELD = MOTION_FIELD
SAMPLE_SHIFT = 1e-6  # eps / window length; far above time round-off, far below a fluid step


def sample_name(t: float) -> str:
    """Folder name of a displacement sample: exact (round-trip) decimal of the time."""
    return repr(float(t))


def numeric_dirs(folder: Path) -> list[tuple[float, str]]:
    """Sub-folders whose names are numbers (time folders), sorted by value."""
    found = []
    if folder.is_dir():
        for entry in os.scandir(folder):
            try:
                found.append((float(entry.name), entry.name))
            except ValueError:
                continue
    return sorted(found)


_UNSET = object()


@dataclass
class FoamRun:
    path: Path
    interface: FluidInterface
    settings: FlowSettings
    processes: int = 1
    # controlDict entries as last written by this object: an implicit window re-solved five
    # times rewrote the same controlDict five times, 60 ms each through foamlib's parser
    _controls: dict = field(default_factory=dict, repr=False)

    @property
    def rho(self) -> float:
        return self.settings.rho_kg_m3

    # ------------------------------------------------------------------ samples
    @property
    def boundary_data(self) -> Path:
        return self.path / "constant" / "boundaryData"

    def _sample_root(self) -> Path:
        return self.boundary_data / self.interface.patches[0].name

    def init_samples(self) -> None:
        """Fresh boundaryData: reference points, and links for the other body patches."""
        if self.boundary_data.exists():
            shutil.rmtree(self.boundary_data)
        root = self._sample_root()
        root.mkdir(parents=True)
        _write_list(root / "points", self.interface.points0)
        _write_list(root / "zeros", np.zeros_like(self.interface.points0))
        for patch in self.interface.patches[1:]:
            (self.boundary_data / patch.name).symlink_to(root.name)

    def _write(self, when: float, values: NDArray | None) -> None:
        folder = self._sample_root() / sample_name(when)
        folder.mkdir(exist_ok=True)
        if values is None:  # placeholder (persistent run)
            _replace_link(folder / FIELD, Path("..") / "zeros")
            return
        tmp = folder / f".{FIELD}.tmp"
        _write_list(tmp, values)
        os.replace(tmp, folder / FIELD)  # atomic: a reader sees the old or the new file

    def _link(self, when: float, to: float) -> None:
        folder = self._sample_root() / sample_name(when)
        folder.mkdir(exist_ok=True)
        _replace_link(folder / FIELD, Path("..") / sample_name(to) / FIELD)

    def write_start(self, t0: float, dt: float) -> None:
        """At rest before the first window (a start-up reads a sample at or before t0)."""
        for when in (t0, t0 + SAMPLE_SHIFT * dt):
            self._write(when, np.zeros_like(self.interface.points0))

    def write_window(self, t0: float, t1: float, velocity: NDArray | None) -> None:
        """The three samples of the window (t0, t1] (module docstring); None: placeholders.
        The file is written once, at t1 (the sample kept for a restart from t1), and linked."""
        eps = SAMPLE_SHIFT * (t1 - t0)
        self._write(t1, velocity)
        for when in (t0 + 2 * eps, t1 + eps):
            self._link(when, t1)

    def remove_samples(
        self, dt: float, before: float | None = None, after: float | None = None
    ) -> None:
        """Delete the samples of the windows that end before ``before`` or start at or after
        ``after`` (keeping those that end exactly there); both None: all."""
        eps = SAMPLE_SHIFT * dt
        for value, name in numeric_dirs(self._sample_root()):
            old = before is not None and value < before - 0.5 * eps
            new = after is not None and value > after + 1.5 * eps
            if old or new or (before is None and after is None):
                shutil.rmtree(self._sample_root() / name)

    # ------------------------------------------------------------------ time folders
    def data_roots(self) -> list[Path]:
        if self.processes == 1:
            return [self.path]
        return sorted(self.path.glob("processor[0-9]*"))

    def times(self) -> list[tuple[float, str]]:
        return numeric_dirs(self.data_roots()[0])

    def time_folder(self, t: float, dt: float) -> str:
        """Name of the time folder at ``t`` (OpenFOAM rounds names to timePrecision digits)."""
        return _nearest(self.times(), t, dt, self.data_roots()[0])

    def remove_times(self, keep_names: set[str], after: float | None = None) -> None:
        for root in self.data_roots():
            for value, name in numeric_dirs(root):
                if name in keep_names or (after is not None and value <= after):
                    continue
                shutil.rmtree(root / name, ignore_errors=True)

    def reset_body_bc(self, time_name: str) -> None:
        """Drop the nonuniform ``value`` OpenFOAM wrote for the body patches (a restart with it
        reads stale sizes in parallel); the sample files give the value anyway."""
        for root in self.data_roots():
            with FoamFieldFile(root / time_name / FIELD) as f:
                for patch in self.interface.patches:
                    if patch.name in f.boundary_field:
                        entry: Any = f.boundary_field[patch.name]  # the patch's sub-dictionary
                        entry["value"] = [0.0, 0.0, 0.0]

    def set_window(
        self, start: str, end: float, dt: float, write_every: int = 1, handshake: str | None = None
    ) -> None:
        """controlDict for a launch from time folder ``start`` to ``end`` in windows of ``dt``."""
        controls = window_controls(
            self.settings, start=float(start), end=end, dt=dt, write_every=write_every
        )
        if handshake is not None:
            controls["functions"][HANDSHAKE_FO] = handshake_function(handshake)
            # one fluid step per window, so that the handshake after every step marks the
            # window ends (systemCall's adjustableRunTime control fired at Courant sub-steps
            # too, measured)
            controls["adjustTimeStep"] = False
        self.set_controls(**controls)

    def set_controls(self, **entries: object) -> None:
        """Update controlDict entries; those already written with the same value are skipped."""
        changed = {k: v for k, v in entries.items() if self._controls.get(k, _UNSET) != v}
        if changed:
            update_dict(self.path / "system" / "controlDict", changed)
            self._controls.update(changed)

    def command(self, unprivileged: bool = False) -> runner.Command:
        return runner.Command(
            app="pimpleFoam", case=self.path, processes=self.processes, unprivileged=unprivileged
        )

    # ------------------------------------------------------------------ loads
    def loads(self, t0: float, t1: float, u0: NDArray, u1: NDArray) -> SurfaceLoads:
        """Loads of the window (t0, t1]: the time average over its fluid steps (exact impulse
        of the velocity change at the window start; the end value when one step), on the
        window-end geometry. The plate moves linearly from ``u0`` to ``u1``."""
        root = self.path / "postProcessing" / SAMPLE_FO
        dt = t1 - t0
        end = _nearest(numeric_dirs(root), t1, dt, root)
        steps = [
            (value, name)
            for value, name in numeric_dirs(root)
            if t0 + 1e-6 * dt < value and (value < t1 - 1e-6 * dt or name == end)
        ]
        times = np.array([t0] + [value for value, _ in steps])
        weights = np.diff(times) / (times[-1] - times[0])
        samples = [
            read_loads(self.path, name, self.interface, u0 + (v - t0) / dt * (u1 - u0), self.rho)
            for v, name in steps
        ]
        last = samples[-1]
        return replace(
            last,
            pressure_pa=sum(w * s.pressure_pa for w, s in zip(weights, samples, strict=True)),
            face_forces=sum(w * s.face_forces for w, s in zip(weights, samples, strict=True)),
        )

    def remove_load_samples(self, keep_names: set[str], after: float | None = None) -> None:
        """Delete the sampled loads except ``keep_names`` (or, given ``after``, only those
        later than it: a repeated window's process may name the same time differently in its
        last digit, and the stale folder must not be read)."""
        root = self.path / "postProcessing" / SAMPLE_FO
        for value, name in numeric_dirs(root):
            if name in keep_names or (after is not None and value <= after):
                continue
            shutil.rmtree(root / name, ignore_errors=True)


def _nearest(found: list[tuple[float, str]], t: float, dt: float, where: Path) -> str:
    if found:
        value, name = min(found, key=lambda item: abs(item[0] - t))
        if abs(value - t) <= 1e-6 * dt:
            return name
    raise FileNotFoundError(
        f"{where}: no time folder at t = {t:.12g} s (found {[n for _, n in found][-5:]}); "
        f"did the solver run? See the log.pimpleFoam there."
    )


def _replace_link(path: Path, target: Path) -> None:
    tmp = path.with_name(f".{path.name}.link")
    if tmp.is_symlink():
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, path)


def _write_list(path: Path, values: NDArray) -> None:
    """A bare OpenFOAM list (what timeVaryingMappedFixedValue reads), full precision."""
    path.write_bytes(FoamFile.dumps(np.asarray(values, dtype=float), ensure_header=False))
