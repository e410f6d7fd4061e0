"""Results written while the run goes: an HDF5 time series, restart checkpoints, VTU/PVD
(interface meshes, and files a solver writes such as flow slices).

``results.h5`` holds one row per time window for every recorded quantity (datasets grow and are
flushed each window, so a killed run keeps everything up to its last window). Checkpoints are
written to a temporary file and renamed, so a kill during the write leaves the previous one.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import shutil
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import meshio
import numpy as np

from .participant import InterfaceMesh

RESULTS_FILE = "results.h5"
CHECKPOINT_FILE = "checkpoint.h5"
# the root attribute holding the checksum of a checkpoint's data
CHECKSUM_ATTR = "sha256"


class OutputError(RuntimeError):
    """A results or checkpoint file that cannot be written (disk full, no permission).
    ``not_writable``: refused by its permissions or a read-only mount, not by a full disk."""

    def __init__(self, message: str, *, not_writable: bool = False) -> None:
        super().__init__(message)
        self.not_writable = not_writable


WRITE_FAULTS = (errno.ENOSPC, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.EROFS)


def is_write_fault(err: OSError) -> bool:
    """A write refused by the disk (full, quota, permission, read-only)."""
    return err.errno in WRITE_FAULTS or "No space left" in str(err)


def write_failure(
    path: Path, err: OSError, kept: str, then: str = "continue with --resume"
) -> OutputError:
    """One line for a failed write: the file, why, what was kept and what to do."""
    text = str(err)
    if err.errno in (errno.ENOSPC, errno.EDQUOT) or "No space left" in text:
        why, fix = "disk full", "free space"
    elif err.errno in (errno.EACCES, errno.EPERM, errno.EROFS) or "ermission" in text:
        why, fix = "not writable", "make it writable"
    else:
        why, fix = f"write failed ({err.strerror or text})", "check the disk"
    return OutputError(
        f"{path}: {why}; {kept}; {fix}, then {then}", not_writable=why == "not writable"
    )


def h5_write_error(err: Exception) -> OSError | None:
    """The OSError behind an h5py error, where HDF5 failed to write: h5py raises OSError or
    RuntimeError, the errno only in the text ("errno = 28")."""
    if isinstance(err, OSError) and (err.errno is not None or "No space left" in str(err)):
        return err
    found = re.search(r"errno = (\d+)", str(err))
    if found is None:
        return err if isinstance(err, OSError) else None
    code = int(found.group(1))
    return OSError(code, os.strerror(code))


# After a failed write, every h5py object freed reports the write again (a traceback and
# "Exception ignored in ... __dealloc__", dozens of lines): those are dropped, others go on.
def _drop_h5py_dealloc_errors(unraisable: sys.UnraisableHookArgs) -> None:
    if "h5py" not in repr(unraisable.object) and "h5py" not in repr(unraisable.err_msg):
        _ORIGINAL_HOOKS[0](unraisable)


def _drop_h5py_dealloc_tracebacks(
    kind: type[BaseException], value: BaseException, tb: TracebackType | None
) -> None:
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    if tb is None or "h5py" not in tb.tb_frame.f_code.co_filename:
        _ORIGINAL_HOOKS[1](kind, value, tb)


_ORIGINAL_HOOKS = (sys.unraisablehook, sys.excepthook)


def _quiet_hooks(on: bool) -> None:
    if on:
        sys.unraisablehook, sys.excepthook = (
            _drop_h5py_dealloc_errors,
            _drop_h5py_dealloc_tracebacks,
        )
    else:
        sys.unraisablehook, sys.excepthook = _ORIGINAL_HOOKS


@contextlib.contextmanager
def _quiet_h5py_failures() -> Iterator[None]:
    """Around a write: the objects of a failed one are freed inside (where HDF5 itself
    failed, _end_without_hdf5_teardown keeps the hooks quiet for good)."""
    _quiet_hooks(True)
    try:
        yield
    finally:
        _quiet_hooks(False)


def _end_without_hdf5_teardown() -> None:
    """HDF5 cannot close a file whose write failed, and its teardown at the process's exit
    then crashes (a segfault): after the error line, exit without it."""
    import atexit

    _quiet_hooks(True)

    def leave() -> None:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)

    atexit.register(leave)


def check_writable(
    directory: Path, names: tuple[str, ...] = (RESULTS_FILE, CHECKPOINT_FILE)
) -> None:
    """Refuse, before a run's set-up, a folder where its files cannot be written: a probe
    file is created (mkdir and the mode bits alone do not tell, e.g. for root on a
    read-only mount), the files already there are opened for writing, and a disk without
    room for a results file is refused."""
    targets = [directory / n for n in names if (directory / n).exists()]
    try:
        probe_write(directory)
        if (directory / "vtk").is_dir():  # an earlier run's VTU/PVD series
            probe_write(directory / "vtk")
        for path in targets:
            os.close(os.open(path, os.O_WRONLY | os.O_APPEND))
    except OSError as err:
        where = Path(err.filename) if err.filename else directory
        if where.name.startswith(".write-probe-"):  # the folder refused a new file
            where = where.parent
        raise write_failure(where, err, "nothing was run", then="run again") from None
    if shutil.disk_usage(directory).free < MIN_FREE_BYTES:
        full = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        raise write_failure(directory, full, "nothing was run", then="run again") from None


# the least free space a run starts with (a results file's first windows, a checkpoint)
MIN_FREE_BYTES = 1 << 20


def probe_write(directory: Path) -> None:
    """Create and remove a file in ``directory``: OSError where it refuses a new file."""
    probe = directory / f".write-probe-{os.getpid()}"
    try:
        with open(probe, "wb") as f:
            f.write(b"0")
    finally:
        probe.unlink(missing_ok=True)


def stored_rows(path: Path) -> int:
    """How many windows a results file holds (0: none, or no file)."""
    if not path.exists():
        return 0
    with h5py.File(path, "r", locking=False) as h5:
        return int(h5["time_s"].shape[0]) if "time_s" in h5 else 0


# units of the recorded quantities by name, then by the name's unit suffix; "1": a count,
# flag or ratio
UNITS = {
    "shell/newton_iterations": "1",
    "coupling/fluid_solves": "1",
    "coupling/converged": "1",
    "coupling/iterated": "1",
    "coupling/residual": "1",
    "coupling/predictor_miss": "1",
    "coupling/updated_miss": "1",
}
SUFFIX_UNITS = {"_m": "m", "_s": "s", "_n": "N", "_nm": "N m", "_pa": "Pa", "_v": "V", "_hz": "Hz"}
# what a dataset's name does not say
DESCRIPTIONS = {
    "shell/newton_iterations": "cumulative: the structure's Newton iterations from the run's "
    "start to the end of this window (a resumed run goes on counting); per window: the "
    "difference of consecutive rows",
    "wall_s": "wall time of this window",
}


def units_of(name: str) -> str:
    if name in UNITS:
        return UNITS[name]
    for suffix in sorted(SUFFIX_UNITS, key=len, reverse=True):
        if name.endswith(suffix):
            return SUFFIX_UNITS[suffix]
    return "1"


class ResultsFile:
    """Append-only table of per-window quantities, grouped by participant name."""

    def __init__(self, path: Path, resume_rows: int | None = None) -> None:
        self.path = path
        self._broken = False  # a write failed: HDF5 cannot close the file cleanly
        # without HDF5's file lock, so that the file can be read while the run goes (rows
        # are flushed window by window)
        if resume_rows is None or not path.exists():
            try:
                self.h5 = h5py.File(path, "w", locking=False)
            except OSError as err:
                path.unlink(missing_ok=True)  # no empty results file left behind
                raise write_failure(path, err, "nothing was run", then="run again") from None
            self.rows = 0
        else:
            self.h5 = h5py.File(path, "a", locking=False)
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
        try:
            for k, v in attrs.items():
                self.h5.attrs[k] = v
            self.h5.flush()
        except OSError as err:
            raise write_failure(self.path, err, "the results so far are kept") from None

    def append(self, values: Mapping[str, Any]) -> None:
        kept = f"the results up to window {self.rows} and the last checkpoint are kept"
        # refused while there is room, so that HDF5 never fails a write (it cannot recover)
        try:
            free = shutil.disk_usage(self.path.parent).free
        except OSError:
            free = None
        if free is not None and free < self._room_needed():
            err = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            raise write_failure(self.path, err, kept)
        try:
            with _quiet_h5py_failures():
                self._append(values)
        except (OSError, RuntimeError) as err:
            cause = h5_write_error(err)
            if cause is None:
                raise
            self._broken = True
            _end_without_hdf5_teardown()
            raise write_failure(self.path, cause, kept) from None

    def _room_needed(self) -> int:
        """A new chunk for every dataset, and the metadata's flush."""
        chunks = sum(
            int(np.prod(ds.chunks)) * int(ds.dtype.itemsize) for ds in self._datasets() if ds.chunks
        )
        return chunks + MIN_FREE_BYTES

    def _append(self, values: Mapping[str, Any]) -> None:
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
                self.h5[name].attrs["units"] = units_of(name)
                if name in DESCRIPTIONS:
                    self.h5[name].attrs["description"] = DESCRIPTIONS[name]
            ds = self.h5[name]
            ds.resize(self.rows + 1, axis=0)
            ds[self.rows] = arr
        self.rows += 1
        self.h5.flush()

    def column(self, name: str) -> np.ndarray | None:
        """The rows written so far of one quantity (None: not recorded)."""
        return self.h5[name][: self.rows] if name in self.h5 else None

    def close(self) -> None:
        try:
            self.h5.close()
        except (OSError, RuntimeError):  # after a failed write: that error is the one to report
            if not self._broken:
                raise


def write_checkpoint(
    path: Path,
    loop_state: Mapping[str, Any],
    participants: Mapping[str, Mapping[str, Any]],
    attributes: Mapping[str, Any] | None = None,
) -> None:
    """Written to a temporary file in the same folder and renamed over the previous one,
    so a failed write (a kill, a full disk) leaves that one. ``attributes``: e.g. the
    identity of the case; a checksum of the data is added."""
    tmp = path.with_suffix(".tmp")
    needed = path.stat().st_size if path.exists() else 0  # the last one's size
    try:
        if shutil.disk_usage(path.parent).free < needed:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        with _quiet_h5py_failures(), h5py.File(tmp, "w", locking=False) as h5:
            for k, v in loop_state.items():
                _put(h5, k, v)
            for name, state in participants.items():
                group = h5.create_group(f"participants/{name}")
                for k, v in state.items():
                    _put(group, k, v)
            for k, v in (attributes or {}).items():
                h5.attrs[k] = v
            h5.attrs[CHECKSUM_ATTR] = checksum(h5)
        os.replace(tmp, path)
    except (OSError, RuntimeError) as err:
        cause = h5_write_error(err)
        if cause is None:
            raise
        if not isinstance(err, OSError) or err is not cause:  # HDF5 itself failed to write
            _end_without_hdf5_teardown()
        tmp.unlink(missing_ok=True)
        if path.exists():
            kept, then = (
                "the previous checkpoint and the results are kept",
                "continue with --resume",
            )
        else:
            kept, then = "the results are kept (no checkpoint yet)", "run again with --overwrite"
        raise write_failure(path, cause, kept, then) from None


def checksum(h5: h5py.Group) -> str:
    """SHA-256 over every dataset's name, dtype, shape and bytes, in name order."""
    digest = hashlib.sha256()
    found: list[tuple[str, h5py.Dataset]] = []
    h5.visititems(lambda n, obj: found.append((n, obj)) if isinstance(obj, h5py.Dataset) else None)
    for name, ds in sorted(found, key=lambda item: item[0]):
        data = np.ascontiguousarray(ds[()])
        digest.update(f"{name}|{data.dtype.str}|{data.shape}|".encode())
        digest.update(data.tobytes())
    return digest.hexdigest()


def _put(group: h5py.Group, key: str, value: Any) -> None:
    if isinstance(value, Mapping):
        sub = group.create_group(key)
        for k, v in value.items():
            _put(sub, k, v)
    else:
        group.create_dataset(key, data=np.asarray(value))


class CorruptFile(ValueError):
    """A file that h5py reads but whose content is not what was written."""


def read_checkpoint(
    path: Path,
) -> tuple[dict[str, Any], dict[str, dict[str, Any]], dict[str, Any]]:
    """(loop state, participants' states, root attributes). Raises OSError, KeyError or
    ValueError (CorruptFile) where the file is not what write_checkpoint wrote: its checksum
    differs, or a participant's state is not finite (the coupling's may hold NaN: "none")."""

    def load(group: h5py.Group) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in group.items():
            out[k] = load(v) if isinstance(v, h5py.Group) else v[()]
        return out

    with h5py.File(path, "r", locking=False) as h5:
        attrs = {k: v.decode() if isinstance(v, bytes) else v for k, v in h5.attrs.items()}
        stored = attrs.get(CHECKSUM_ATTR)
        if stored is not None and stored != checksum(h5):
            raise CorruptFile("its checksum does not match its data")
        everything = load(h5)
    participants = everything.pop("participants", {})
    _check_finite(participants)
    return everything, participants, attrs


def _check_finite(tree: Mapping[str, Any], where: str = "") -> None:
    for k, v in tree.items():
        if isinstance(v, Mapping):
            _check_finite(v, f"{where}{k}/")
            continue
        arr = np.asarray(v)
        if arr.dtype.kind in "fc" and not np.isfinite(arr).all():
            raise CorruptFile(f"{where}{k} holds numbers that are not finite")


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
