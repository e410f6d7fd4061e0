"""A CFD that starts displaced, with the flow of an earlier run (``time.start_from``).

A run started on another run's periodic orbit starts its structure in that run's last state.
Its liquid would start at rest around a flat plate and need periods of prescribed motion to
build the flow up (docs/coupling.md). Instead the mesh is moved to the structure's start shape
(``moveDynamicMesh``, no flow), and the earlier run's flow at its last time folder is mapped
onto it (``mapFields -consistent``: the same tank at any mesh level). Both become time 0. The
mesh motion integrates the plate's velocity, so a mesh that followed the plate for periods lies
a little off the one moved there at once (docs/coupling.md). Either case may be decomposed:
the mesh then moves on the target's ranks and mapFields reads and writes processor folders.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from . import runner
from .casefiles import MOTION_FIELD
from .fishmesh import TankGeometry
from .foamio import read_points
from .foamrun import FoamRun, numeric_dirs
from .rest_mesh import move_from_rest

# fields of the mesh motion: this run's own (cellMotionU is a volume field mapFields would map)
MOTION_FIELDS = frozenset({MOTION_FIELD, "cellMotionU"})
# windows a CFD started this way is off its force before it repeats the source's last period
# (coarse fish, 3 Hz: within 0.1 % of the swing from window 4 on at 40 windows per period;
# 2 % in window 4 and 0.3 % from window 5 on at 20)
START_UP_WINDOWS = 4
RECORD = "start_flow.json"  # in the case folder: the flow it started with (a resume's answer)


@dataclass(frozen=True)
class FlowSource:
    """An earlier run's OpenFOAM case and the time folder its checkpoint ended at (in its
    processor folders where ``decomposed``)."""

    case: Path
    time_name: str
    decomposed: bool = False


def flow_source(case: Path, t: float, tank: TankGeometry) -> FlowSource | str:
    """The OpenFOAM case folder ``case`` (serial or decomposed) at time ``t`` in ``tank``, or
    why it cannot be one."""
    if not (case / "system" / "controlDict").is_file():
        return f"{case} holds no OpenFOAM case"
    try:
        points = read_points(case / "constant" / "polyMesh" / "points")
    except Exception as exc:  # noqa: BLE001  (foamlib's parse errors have no common base)
        return f"{case}: its mesh cannot be read ({exc})"
    half = np.array([0.0, tank.depth / 2, tank.width / 2])
    walls = np.array([[tank.x_front, 0, 0] - half, [tank.x_back, 0, 0] + half])
    if not np.allclose([points.min(axis=0), points.max(axis=0)], walls, rtol=0, atol=1e-6):
        return f"{case} is another tank"
    for root, decomposed in ((case, False), (case / "processor0", True)):
        found = [(abs(value - t), name) for value, name in numeric_dirs(root)]
        near = min(found, default=(np.inf, ""))
        if near[0] <= 1e-6 * max(1.0, abs(t)) and (root / near[1] / "U").is_file():
            return FlowSource(case, near[1], decomposed)
    return f"{case} has no time folder at t = {t:.12g} s, where its checkpoint ended"


def recorded_flow(run_path: Path) -> FlowSource | None:
    """The flow a case folder started with (place's record), None: it started at rest."""
    try:
        record = json.loads((run_path / RECORD).read_text())
        return FlowSource(
            Path(record["case"]), str(record["time_name"]), bool(record.get("decomposed"))
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None


def place(run: FoamRun, displacement: NDArray, dt: float, source: FlowSource) -> None:
    """Time 0 of ``run`` (a fresh case, serial or decomposed) with its plate at
    ``displacement`` (interface points), the mesh moved with it, and the flow of ``source``
    mapped on. pimpleFoam starts from it with a first-order time step: its first windows'
    forces zig-zag about the source's (START_UP_WINDOWS)."""
    moved = move_from_rest(run, displacement, dt, "the start's plate shape")
    for root in run.data_roots():  # the moved mesh is time 0's
        (root / "0" / "polyMesh").mkdir(exist_ok=True)
        shutil.copyfile(root / moved / "polyMesh" / "points", root / "0" / "polyMesh" / "points")
    run.remove_times({"0"})
    run.remove_samples(dt)
    run.write_start(0.0, dt)  # the samples of a fresh case
    _map_flow(run, source)
    record = {
        "case": str(source.case),
        "time_name": source.time_name,
        "decomposed": source.decomposed,
    }
    (run.path / RECORD).write_text(json.dumps(record) + "\n")


def _map_flow(run: FoamRun, source: FlowSource) -> None:
    """The source's flow fields onto time 0 (on its moved mesh): only the fields time 0 already
    has, less the mesh motion's; mapFields writes every field it finds (old times too). It
    runs serially and reads or writes processor folders itself (-parallelSource/-Target)."""
    zeros = [root / "0" for root in run.data_roots()]
    before = {p.name for p in zeros[0].iterdir() if p.is_file()}
    args = [str(source.case), "-sourceTime", source.time_name, "-consistent"]
    args += ["-parallelSource"] if source.decomposed else []
    args += ["-parallelTarget"] if run.processes > 1 else []
    with tempfile.TemporaryDirectory(dir=run.path) as keep:
        kept = [Path(keep) / str(rank) for rank in range(len(zeros))]
        for zero, folder in zip(zeros, kept, strict=True):
            folder.mkdir()
            for name in before & MOTION_FIELDS:
                shutil.copy2(zero / name, folder / name)
        runner.utility("mapFields", run.path, *args)
        for zero, folder in zip(zeros, kept, strict=True):
            for path in zero.iterdir():
                if path.is_file() and path.name not in before:
                    path.unlink()
            for name in before & MOTION_FIELDS:
                shutil.copy2(folder / name, zero / name)
