"""checkMesh, read: cell count and quality figures, and its failures as one clear error."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import runner
from .errors import MeshQualityError, OpenFoamRunError
from .foamio import read_faces, read_points

_NUM = r"([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)"
_NUMBERS = {
    "cells": rf"^\s*cells:\s+{_NUM}",
    "points": rf"^\s*points:\s+{_NUM}",
    "max_non_orthogonality_deg": rf"Mesh non-orthogonality Max:\s+{_NUM}",
    "mean_non_orthogonality_deg": rf"Mesh non-orthogonality Max:\s+\S+\s+average:\s+{_NUM}",
    "max_skewness": rf"Max skewness = {_NUM}",
    "min_volume_m3": rf"(?:Min volume =|Minimum negative volume:) {_NUM}",
    "max_aspect_ratio": rf"Max aspect ratio(?: =|:) {_NUM}",
}


@dataclass(frozen=True, kw_only=True)
class MeshQuality:
    time: str
    cells: int
    points: int
    max_non_orthogonality_deg: float
    mean_non_orthogonality_deg: float
    max_skewness: float
    min_volume_m3: float
    max_aspect_ratio: float
    failed_checks: int

    @property
    def ok(self) -> bool:
        return self.failed_checks == 0

    def line(self) -> str:
        ortho = self.max_non_orthogonality_deg, self.mean_non_orthogonality_deg
        return (
            f"t={self.time}: {self.cells} cells, non-orthogonality max {ortho[0]:.1f} deg "
            f"(mean {ortho[1]:.1f}), skewness max {self.max_skewness:.2f}, "
            f"aspect ratio max {self.max_aspect_ratio:.1f}"
        )


def parse(text: str, time: str = "constant", counts: tuple[int, int] | None = None) -> MeshQuality:
    """Figures of a checkMesh report; ``counts`` (cells, points) for reports without them."""
    values: dict[str, float] = {}
    if counts is not None:
        values["cells"], values["points"] = counts
    for key, pattern in _NUMBERS.items():
        found = re.findall(pattern, text, flags=re.MULTILINE)
        if not found and key in values:
            continue
        if not found:
            raise MeshQualityError(f"checkMesh output has no '{key}' figure; is the log complete?")
        values[key] = float(found[-1])
    failed = re.search(r"Failed (\d+) mesh checks", text)
    return MeshQuality(
        time=time,
        cells=int(values.pop("cells")),
        points=int(values.pop("points")),
        failed_checks=int(failed.group(1)) if failed else 0,
        **values,
    )


def parse_steps(log_text: str, counts: tuple[int, int] = (0, 0)) -> list[MeshQuality]:
    """The per-step mesh checks of a ``moveDynamicMesh`` log (one block per ``Time =``)."""
    blocks = re.split(r"^Time = (\S+)\s*$", log_text, flags=re.MULTILINE)
    return [
        parse(block, time, counts)
        for time, block in zip(blocks[1::2], blocks[2::2], strict=True)
        if "Mesh non-orthogonality" in block
    ]


def check_mesh(case: Path, time: str | None = None, *, strict: bool = True) -> MeshQuality:
    """Run checkMesh (on the mesh of ``time`` if given); raise if a check fails."""
    args = ("-time", time) if time is not None else ("-constant",)
    log_name = f"checkMesh.{time}" if time is not None else None
    try:
        log = runner.utility("checkMesh", case, *args, log_name=log_name)
    except OpenFoamRunError as exc:
        raise MeshQualityError(f"checkMesh could not read the mesh of {case}: {exc}") from exc
    quality = parse(log.read_text(), time or "constant")
    if strict and not quality.ok:
        failures = "\n".join(line for line in log.read_text().splitlines() if "***" in line)
        raise MeshQualityError(
            f"checkMesh found {quality.failed_checks} failed check(s) in {case} "
            f"(mesh of {quality.time}; see {log}):\n{failures}\n{quality.line()}\n"
            "Fix: use a finer fluid.mesh_level, a smaller motion amplitude, or a larger tank."
        )
    return quality


# checkMesh's face sets of a folded (not just a poor) mesh
_FOLDED_SETS = ("wrongOrientedFaces", "zeroAreaFaces", "concaveFaces")


def folded_mesh(case: Path, name: str) -> str | None:
    """Why the moved mesh of time folder ``name`` cannot go on, from checkMesh: None when it
    passes (or holds no moved mesh). Names the failed checks and where the folded faces lie
    (their centres' bounding box, mm)."""
    if not (case / name / "polyMesh" / "points").is_file():
        return None
    try:
        quality = check_mesh(case, name, strict=False)
    except MeshQualityError:
        return None
    sets = case / name / "polyMesh" / "sets"
    labels: list[int] = []
    for set_name in _FOLDED_SETS:
        if not quality.ok and (sets / set_name).is_file():
            labels += _set_labels(sets / set_name)
    if not labels and quality.min_volume_m3 > 0:
        return None  # poor (skewed, non-orthogonal) but whole
    where = ""
    if labels:
        points = read_points(case / name / "polyMesh" / "points")
        offsets, flat = read_faces(case / "constant" / "polyMesh" / "faces")
        centres = np.array([points[flat[offsets[i] : offsets[i + 1]]].mean(axis=0) for i in labels])
        low, high = 1e3 * centres.min(axis=0), 1e3 * centres.max(axis=0)
        box = ", ".join(
            f"{axis} {a:.0f}" if abs(b - a) < 0.5 else f"{axis} {a:.0f}..{b:.0f}"
            for axis, a, b in zip("xyz", low, high, strict=True)
        )
        where = f": {len(labels)} faces inside out at {box} mm"
    return (
        f"the moved mesh of t={name} is folded{where} (min cell volume "
        f"{quality.min_volume_m3:.3g} m3, log.checkMesh.{name}): the plate moved further than "
        "the mesh motion follows"
    )


def _set_labels(path: Path) -> list[int]:
    """Labels of an OpenFOAM set file: after its FoamFile header, a count and a list."""
    body = path.read_text().split("}", 1)[-1]
    found = re.search(r"(\d+)\s*\(([^)]*)\)", body)
    return [int(v) for v in found.group(2).split()] if found else []
