"""The moved mesh put back on its path from rest: velocityLaplacian's drift undone.

``velocityLaplacian`` integrates the plate's velocity on the current mesh, so a closed loop of
plate shapes does not bring the inner points back. At the default level, a first-mode swing of
31 mm of tail moves them 0.85 mm further every period. After eight periods they are 8 mm off and
checkMesh fails; a coupled 1 Hz run folded its cells in period 6. The plate's own points are
exact: each window ends on its displacement.

``reset_points`` replaces a time folder's points with those of the undeformed mesh moved to the
plate's current shape in RAMP_WINDOWS steps (``moveDynamicMesh`` in a scratch copy of the case;
a displaced start moves its own mesh the same way, flow_start.py). The plate and the walls keep
their points; the inner points jump back by the drift, and the flow fields stay with their
cells. ``DriftSchedule`` says when: after the first period, then as often as the fastest drift
measured needs to stay under DRIFT_LIMIT_M, but at most once a period.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .drivers import run_mesh_motion
from .errors import MeshFoldedError
from .foamio import read_points
from .foamrun import FoamRun

# steps of a move from rest (one would do: the motion solver is linear in the plate's
# velocity; a few keep each step's cells near their last shape)
RAMP_WINDOWS = 4
# drift allowed between resets: an eighth of the drift at which checkMesh first failed (8 mm,
# default level, 31 mm of tail, the module docstring)
DRIFT_LIMIT_M = 1e-3
SAMPLES = "boundaryData"  # constant/<this>: the scratch run writes its own


def move_from_rest(run: FoamRun, displacement: NDArray, dt: float, what: str) -> str:
    """Move ``run``'s mesh (at rest at time 0) to the plate ``displacement`` in RAMP_WINDOWS
    steps, mesh alone; returns the moved time folder's name. ``what`` names the shape in the
    error a fold raises."""
    end = RAMP_WINDOWS * dt
    checks = run_mesh_motion(run, lambda t: displacement * (t / end), dt, RAMP_WINDOWS)
    if checks and checks[-1].min_volume_m3 <= 0:  # inside-out cells (poor ones run)
        raise MeshFoldedError(
            f"{run.path}: {what} folds this mesh even moved there from rest (min cell volume "
            f"{checks[-1].min_volume_m3:.3g} m3, log.moveDynamicMesh); a smaller drive or a "
            "stiffer design keeps the mesh whole"
        )
    return run.time_folder(end, dt)


def reset_points(run: FoamRun, time_name: str, displacement: NDArray, dt: float) -> float:
    """Replace the points of time folder ``time_name`` (every rank's) with those of the mesh
    moved from rest to the plate ``displacement``; returns the largest point shift (m)."""
    with tempfile.TemporaryDirectory(dir=run.path, prefix="rest.") as scratch:
        rest = FoamRun(
            _scratch_case(run, Path(scratch)), run.interface, run.settings, run.processes
        )
        rest.init_samples()
        what = f"the plate's shape at fluid time {time_name} s"
        moved = move_from_rest(rest, displacement, dt, what)
        shift = 0.0
        for root, rest_root in zip(run.data_roots(), rest.data_roots(), strict=True):
            target = root / time_name / "polyMesh" / "points"
            source = rest_root / moved / "polyMesh" / "points"
            old, new = read_points(target), read_points(source)
            shift = max(shift, float(np.linalg.norm(new - old, axis=1).max(initial=0.0)))
            _replace(source, target)
    return shift


def _scratch_case(run: FoamRun, folder: Path) -> Path:
    """The case at rest: system/, and constant/ and 0/ of every rank, without the samples
    or a displaced start's time-0 points. Decomposed, the root's constant/ gives the
    dictionaries only (the ranks have their own meshes)."""
    shutil.copytree(run.path / "system", folder / "system")
    for root in run.data_roots():
        into = folder / root.relative_to(run.path)
        shutil.copytree(root / "constant", into / "constant", ignore=_top(SAMPLES))
        shutil.copytree(root / "0", into / "0", ignore=shutil.ignore_patterns("polyMesh"))
    if run.processes > 1:
        shutil.copytree(
            run.path / "constant", folder / "constant", ignore=_top(SAMPLES, "polyMesh")
        )
    return folder


def _top(*names: str):
    """Ignore ``names`` directly inside constant/ only (constant/polyMesh/... is kept)."""

    def ignore(directory: str, entries: list[str]) -> set[str]:
        return set(names) & set(entries) if Path(directory).name == "constant" else set()

    return ignore


def _replace(source: Path, target: Path) -> None:
    """Copy ``source`` over ``target`` atomically, keeping the target's owner (a persistent
    solver runs as nobody on its folder)."""
    info = target.stat()
    tmp = target.with_name(f".{target.name}.rest")
    shutil.copyfile(source, tmp)
    os.chmod(tmp, info.st_mode & 0o777)
    if hasattr(os, "chown") and os.geteuid() == 0:
        os.chown(tmp, info.st_uid, info.st_gid)
    os.replace(tmp, target)


@dataclass
class DriftSchedule:
    """When to reset: ``first`` windows after the start, then as often as the fastest drift
    measured so far allows under DRIFT_LIMIT_M, but at most every ``first`` windows (a
    period) and at least every ``longest``. The fastest, not the last: a reset repeated on a
    folder already reset (a resumed run) measures no drift."""

    first: int
    longest: int
    next_at: int = 0
    resets: list[tuple[int, float]] = field(default_factory=list)  # (window, shift m)

    def __post_init__(self) -> None:
        self.next_at = self.next_at or self.first

    def due(self, window: int) -> bool:
        return self.first > 0 and window >= self.next_at

    def record(self, window: int, shift_m: float) -> None:
        self.resets.append((window, shift_m))
        starts = [0] + [w for w, _ in self.resets[:-1]]
        rate = max(s / max(w - w0, 1) for (w, s), w0 in zip(self.resets, starts, strict=True))
        allowed = self.longest if rate <= 0 else math.floor(DRIFT_LIMIT_M / rate)
        self.next_at = window + min(max(allowed, self.first), self.longest)
