"""Small foamlib helpers: write a whole dictionary file at once, read a patch's geometry.

foamlib edits an existing file in a context manager; a new file is created empty first. The
mesh files (points, faces, boundary) are read with foamlib too, ASCII or binary.

foamlib (1.7) writes any list of 3, 6 or 9 numbers as a uniform vector or tensor, also in a
scalar field: a processor patch with 3 faces of the plate got ``value uniform (a b c)`` and
pimpleFoam stopped ("expected scalar value, found '('"; 4 MPI ranks, default level).
``write_dict`` rewrites such entries of scalar field files as the lists they are.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from foamlib import FoamFieldFile, FoamFile
from numpy.typing import NDArray


def write_dict(path: Path, entries: Mapping[str, Any], *, field: bool = False) -> None:
    """(Re)write ``path`` with exactly ``entries`` (FoamFile header added by foamlib; a
    ``"FoamFile": {"class": ...}`` entry only sets the class, e.g. pointVectorField)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("")
    # foamlib keys a headless file's content by None
    body: dict[str | None, Any] = {key: value for key, value in entries.items()}
    header = body.pop("FoamFile", {})
    cls = FoamFieldFile if field else FoamFile
    with cls(path) as f:
        f.update(body)
        if "class" in header:
            f.class_ = header["class"]
    if field and "Scalar" in str(header.get("class", "")):
        path.write_text(_scalar_lists(path.read_text()))


# "uniform (" cannot start a scalar field's value: it is foamlib's reading of a 3/6/9-list
_UNIFORM_TUPLE = re.compile(r"\buniform \(([^()]*)\)")


def _scalar_lists(text: str) -> str:
    def as_list(match: re.Match[str]) -> str:
        values = match.group(1).split()
        return f"nonuniform List<scalar> {len(values)}({' '.join(values)})"

    return _UNIFORM_TUPLE.sub(as_list, text)


def update_dict(path: Path, entries: Mapping[str, Any]) -> None:
    """Change ``entries`` in place. foamlib (1.7.10) leaves a few blank lines behind the header
    on each update: a coupled run's controlDict grew to 9,000 lines over 4 periods, re-parsed
    by every update and launch; runs of blank lines are collapsed here."""
    body: dict[str | None, Any] = {key: value for key, value in entries.items()}
    with FoamFile(path) as f:
        f.update(body)
    text = path.read_text()
    compact = _BLANK_RUNS.sub("\n\n", text)
    if compact != text:
        path.write_text(compact)


_BLANK_RUNS = re.compile(r"\n(?:[ \t]*\n){2,}")


def read_points(path: Path) -> NDArray[np.float64]:
    return np.asarray(FoamFile(path)[None], dtype=float).reshape(-1, 3)


def read_faces(path: Path) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``polyMesh/faces`` as (offsets, labels): face i is labels[offsets[i]:offsets[i + 1]]
    (the layout of a binary faceCompactList; an ASCII faceList is converted to it)."""
    data: Any = FoamFile(path)[None]  # a faceCompactList (offsets, labels) or a faceList
    if isinstance(data, tuple) and len(data) == 2:
        return np.asarray(data[0], dtype=np.int64), np.asarray(data[1], dtype=np.int64)
    sizes = np.array([len(f) for f in data], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    return offsets, np.concatenate([np.asarray(f, dtype=np.int64) for f in data])


def read_boundary(path: Path) -> dict[str, dict]:
    """``constant/polyMesh/boundary`` as {patch: {type, nFaces, startFace, ...}}."""
    entries: Any = FoamFile(path)[None]  # [(name, {type, nFaces, ...}), ...]
    return {name: dict(d) for name, d in entries}
