"""Results written while the run goes: an HDF5 time series, restart checkpoints, VTU/PVD
(interface meshes, and files a solver writes such as flow slices).

``results.h5`` holds one row per time window for every recorded quantity (datasets grow and are
flushed each window, so a killed run keeps everything up to its last window). Checkpoints are
written to a temporary file and renamed, so a kill during the write leaves the previous one.
"""

from __future__ import annotations

import os
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import meshio
import numpy as np

from .participant import InterfaceMesh

RESULTS_FILE = "results.h5"
CHECKPOINT_FILE = "checkpoint.h5"


def stored_rows(path: Path) -> int:
    """How many windows a results file holds (0: none, or no file)."""
    if not path.exists():
        return 0
    with h5py.File(path, "r") as h5:
        return int(h5["time_s"].shape[0]) if "time_s" in h5 else 0


class ResultsFile:
    """Append-only table of per-window quantities, grouped by participant name."""

    def __init__(self, path: Path, resume_rows: int | None = None) -> None:
        self.path = path
        if resume_rows is None or not path.exists():
            self.h5 = h5py.File(path, "w")
            self.rows = 0
        else:
            self.h5 = h5py.File(path, "a")
            self.rows = resume_rows
            self._truncate(resume_rows)

    def _datasets(self) -> list[h5py.Dataset]:
        found: list[h5py.Dataset] = []
        self.h5.visititems(
            lambda _, obj: found.append(obj) if isinstance(obj, h5py.Dataset) else None
        )
        return found

    def _truncate(self, rows: int) -> None:
        for ds in self._datasets():
            if ds.maxshape[0] is None:
                ds.resize(min(rows, ds.shape[0]), axis=0)

    def set_attributes(self, attrs: Mapping[str, Any]) -> None:
        for k, v in attrs.items():
            self.h5.attrs[k] = v

    def append(self, values: Mapping[str, Any]) -> None:
        for name, value in values.items():
            arr = np.atleast_1d(np.asarray(value, dtype=float))
            if name not in self.h5:
                self.h5.create_dataset(
                    name,
                    shape=(0, *arr.shape),
                    maxshape=(None, *arr.shape),
                    dtype="f8",
                    chunks=(64, *arr.shape),
                )
            ds = self.h5[name]
            ds.resize(self.rows + 1, axis=0)
            ds[self.rows] = arr
        self.rows += 1
        self.h5.flush()

    def column(self, name: str) -> np.ndarray | None:
        """The rows written so far of one quantity (None: not recorded)."""
        return self.h5[name][: self.rows] if name in self.h5 else None

    def close(self) -> None:
        self.h5.close()


def write_checkpoint(
    path: Path, loop_state: Mapping[str, Any], participants: Mapping[str, Mapping[str, Any]]
) -> None:
    tmp = path.with_suffix(".tmp")
    with h5py.File(tmp, "w") as h5:
        for k, v in loop_state.items():
            _put(h5, k, v)
        for name, state in participants.items():
            group = h5.create_group(f"participants/{name}")
            for k, v in state.items():
                _put(group, k, v)
    os.replace(tmp, path)


def _put(group: h5py.Group, key: str, value: Any) -> None:
    if isinstance(value, Mapping):
        sub = group.create_group(key)
        for k, v in value.items():
            _put(sub, k, v)
    else:
        group.create_dataset(key, data=np.asarray(value))


def read_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
    def load(group: h5py.Group) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in group.items():
            out[k] = load(v) if isinstance(v, h5py.Group) else v[()]
        return out

    with h5py.File(path, "r") as h5:
        everything = load(h5)
    participants = everything.pop("participants", {})
    return everything, participants


class PvdSeries:
    """A PVD collection ParaView opens as a time series; on resume (``keep_until``) the
    entries up to that time are kept and later ones dropped."""

    def __init__(self, directory: Path, name: str, keep_until: float | None = None) -> None:
        self.directory, self.name = directory, name
        directory.mkdir(parents=True, exist_ok=True)
        self.entries: list[tuple[float, str]] = []
        pvd = self.pvd_path
        if keep_until is not None and pvd.exists():
            for ds in ET.parse(pvd).getroot().iter("DataSet"):
                t = float(ds.get("timestep", "0"))
                if t <= keep_until * (1 + 1e-12) + 1e-15:
                    self.entries.append((t, ds.get("file", "")))

    @property
    def pvd_path(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    def add_file(self, index: int, time: float, source: Path) -> Path:
        """Move a file written elsewhere (e.g. by a solver) into the series as window ``index``."""
        target = self.directory / f"{self.name}_{index:06d}{source.suffix}"
        shutil.move(source, target)
        self.entries.append((time, target.name))
        self._write_pvd()
        return target

    def _write_pvd(self) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for t, f in self.entries:
            ET.SubElement(coll, "DataSet", timestep=f"{t:.10g}", part="0", file=f)
        tmp = self.pvd_path.with_suffix(".tmp")
        ET.ElementTree(root).write(tmp, xml_declaration=True)
        os.replace(tmp, self.pvd_path)


class VtkSeries(PvdSeries):
    """One VTU of an interface mesh per written window, collected in a PVD."""

    def __init__(
        self, directory: Path, name: str, mesh: InterfaceMesh, keep_until: float | None = None
    ) -> None:
        super().__init__(directory, name, keep_until)
        self.mesh = mesh

    def write(
        self,
        index: int,
        time: float,
        displacement: np.ndarray,
        point_data: Mapping[str, np.ndarray],
    ) -> None:
        fname = f"{self.name}_{index:06d}.vtu"
        points = self.mesh.points + displacement
        n_points, n_cells = len(self.mesh.points), len(self.mesh.cells)
        arrays = {k: np.asarray(v) for k, v in point_data.items()}
        meshio.write(
            self.directory / fname,
            meshio.Mesh(
                points,
                [(self.mesh.cell_type, self.mesh.cells)],
                point_data={k: v for k, v in arrays.items() if len(v) == n_points},
                cell_data={k: [v] for k, v in arrays.items() if len(v) == n_cells != n_points},
            ),
        )
        self.entries.append((time, fname))
        self._write_pvd()
