"""Flow-field surfaces: pressure, velocity and vorticity on planes through the tank, on the
fish and on the wake's vortices.

Sampled from a finished window's time folder by OpenFOAM's own ``postProcess`` with the
``vorticity``, ``Q`` and ``surfaces`` function objects of ``system/flowSlices``; v1912 writes
each surface as VTK XML polydata (``.vtp``) with point data p, U and vorticity, on the moved
mesh of that time:

- ``midheight``, a plane horizontal through the plate's centre height, shows the wake's
  vortices in plan view (their axis is vertical: vorticity's y component);
- ``wake``, a plane across the tank a little behind the tail, their cross-section;
- ``body``, the fish's two faces (the deformed plate with its pressure);
- ``vortices``, the iso-surface of the Q-criterion Q = (|W|^2 - |S|^2) / 2 at a level in
  units of the drive's omega^2 (absent from a window where no Q reaches it).

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
DERIVED = ("vorticity", "Q")  # function objects' fields, written into the time folder
WAKE_GAP_M = 0.02  # the wake plane's distance behind the tail


@dataclass(frozen=True)
class Plane:
    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]

    def sampled(self) -> dict:
        return {
            "type": "cuttingPlane",
            "planeType": "pointAndNormal",
            "pointAndNormalDict": {"point": list(self.point), "normal": list(self.normal)},
            "interpolate": True,
        }


@dataclass(frozen=True)
class Patch:
    """The faces of mesh patches (the fish's, moved with it)."""

    name: str
    patches: tuple[str, ...]

    def sampled(self) -> dict:
        return {"type": "patch", "patches": list(self.patches), "interpolate": True}


@dataclass(frozen=True)
class IsoSurface:
    """Where a scalar field equals a value; OpenFOAM writes no file where it never does."""

    name: str
    field: str
    value: float

    def sampled(self) -> dict:
        # v1912 supports iso-surfaces only interpolated (triangles spanning cells)
        return {
            "type": "isoSurface",
            "isoField": self.field,
            "isoValue": self.value,
            "interpolate": True,
        }


Surface = Plane | Patch | IsoSurface


def fish_planes(points0: NDArray) -> tuple[Plane, ...]:
    """The two planes for a plate in x-y swinging along z (interface reference points)."""
    lo, hi = points0.min(axis=0), points0.max(axis=0)
    centre = 0.5 * (lo + hi)
    return (
        Plane("midheight", (float(centre[0]), float(centre[1]), 0.0), (0.0, 1.0, 0.0)),
        Plane("wake", (float(hi[0]) + WAKE_GAP_M, float(centre[1]), 0.0), (1.0, 0.0, 0.0)),
    )


def fish_surfaces(
    points0: NDArray, body_patches: tuple[str, ...], q_level_1_s2: float
) -> tuple[Surface, ...]:
    """The two planes, the fish's faces and (``q_level_1_s2`` > 0) the Q iso-surface."""
    vortices = (IsoSurface("vortices", "Q", q_level_1_s2),) if q_level_1_s2 > 0 else ()
    return (*fish_planes(points0), Patch("body", body_patches), *vortices)


def write_slice_dict(case: Path, surfaces: tuple[Surface, ...]) -> None:
    write_dict(
        case / "system" / SLICE_DICT,
        {
            "functions": {
                "vorticity": {"type": "vorticity", "libs": ["libfieldFunctionObjects.so"]},
                "Q": {"type": "Q", "libs": ["libfieldFunctionObjects.so"]},
                SLICE_DICT: {
                    "type": "surfaces",
                    "libs": ["libsampling.so"],
                    "surfaceFormat": "vtk",
                    "interpolationScheme": "cellPoint",
                    "fields": list(FIELDS),
                    "surfaces": {surface.name: surface.sampled() for surface in surfaces},
                },
            }
        },
    )


def sample_slices(
    case: Path, time_name: str, surfaces: tuple[Surface, ...], processes: int = 1
) -> dict[str, Path]:
    """Run the sampling on time folder ``time_name``; returns {surface name: .vtp file} (in the
    case's postProcessing folder: move them away, the next call may overwrite them)."""
    write_slice_dict(case, surfaces)
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
    # postProcess also writes the derived fields into the time folder: not restart fields
    for field in DERIVED:
        for pattern in (f"{time_name}/{field}", f"processor*/{time_name}/{field}"):
            for path in case.glob(pattern):
                path.unlink()
    folder = case / "postProcessing" / SLICE_DICT / time_name
    found = {surface.name: folder / f"{surface.name}.vtp" for surface in surfaces}
    found = {
        name: path
        for (name, path), surface in zip(found.items(), surfaces, strict=True)
        if path.is_file() or not isinstance(surface, IsoSurface)
    }
    missing = [str(path) for path in found.values() if not path.is_file()]
    if missing:
        raise runner.OpenFoamRunError(
            f"postProcess wrote no slice {', '.join(missing)}; see {command.log}"
        )
    return found
