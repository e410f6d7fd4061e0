"""Flow-field slices: pressure, velocity and vorticity on planes through the tank.

Sampled from a finished window's time folder by OpenFOAM's own ``postProcess`` with the
``vorticity`` and ``surfaces`` (``cuttingPlane``) function objects of ``system/flowSlices``;
v1912 writes each plane as VTK XML polydata (``.vtp``) with point data p, U and vorticity, on
the moved mesh of that time. Two planes: ``midheight``, horizontal through the plate's centre
height, shows the wake's vortices in plan view (their axis is vertical: vorticity's y
component), and ``wake``, across the tank a little behind the tail, their cross-section.
A launch reads the mesh and two fields: 0.2 s at the coarse level, 0.4 s at the default
level (157k cells), against 4-12 s per coupled window.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from numpy.typing import NDArray

from . import runner
from .foamio import write_dict

SLICE_DICT = "flowSlices"
FIELDS = ("p", "U", "vorticity")
WAKE_GAP_M = 0.02  # the wake plane's distance behind the tail


@dataclass(frozen=True)
class Plane:
    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]


def fish_planes(points0: NDArray) -> tuple[Plane, ...]:
    """The two planes for a plate in x-y swinging along z (interface reference points)."""
    lo, hi = points0.min(axis=0), points0.max(axis=0)
    centre = 0.5 * (lo + hi)
    return (
        Plane("midheight", (float(centre[0]), float(centre[1]), 0.0), (0.0, 1.0, 0.0)),
        Plane("wake", (float(hi[0]) + WAKE_GAP_M, float(centre[1]), 0.0), (1.0, 0.0, 0.0)),
    )


def write_slice_dict(case: Path, planes: tuple[Plane, ...]) -> None:
    surfaces = {
        plane.name: {
            "type": "cuttingPlane",
            "planeType": "pointAndNormal",
            "pointAndNormalDict": {"point": list(plane.point), "normal": list(plane.normal)},
            "interpolate": True,
        }
        for plane in planes
    }
    write_dict(
        case / "system" / SLICE_DICT,
        {
            "functions": {
                "vorticity": {"type": "vorticity", "libs": ["libfieldFunctionObjects.so"]},
                SLICE_DICT: {
                    "type": "surfaces",
                    "libs": ["libsampling.so"],
                    "surfaceFormat": "vtk",
                    "interpolationScheme": "cellPoint",
                    "fields": list(FIELDS),
                    "surfaces": surfaces,
                },
            }
        },
    )


def sample_slices(
    case: Path, time_name: str, planes: tuple[Plane, ...], processes: int = 1
) -> dict[str, Path]:
    """Run the sampling on time folder ``time_name``; returns {plane name: .vtp file} (in the
    case's postProcessing folder: move them away, the next call may overwrite them)."""
    write_slice_dict(case, planes)
    # the previous call's folders, emptied by the caller
    shutil.rmtree(case / "postProcessing" / SLICE_DICT, ignore_errors=True)
    command = runner.Command(
        app="postProcess",
        case=case,
        args=("-dict", f"system/{SLICE_DICT}", "-fields", "(U p)", "-time", time_name),
        processes=processes,
        log_name=f"postProcess.{SLICE_DICT}",
    )
    runner.run(command, timeout_s=600)
    # postProcess also writes the vorticity field into the time folder: not a restart field
    for pattern in (f"{time_name}/vorticity", f"processor*/{time_name}/vorticity"):
        for path in case.glob(pattern):
            path.unlink()
    folder = case / "postProcessing" / SLICE_DICT / time_name
    found = {plane.name: folder / f"{plane.name}.vtp" for plane in planes}
    missing = [str(path) for path in found.values() if not path.is_file()]
    if missing:
        raise runner.OpenFoamRunError(
            f"postProcess wrote no slice {', '.join(missing)}; see {command.log}"
        )
    return found
