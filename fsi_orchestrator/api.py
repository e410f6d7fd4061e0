"""The Python API: load a case, run it, read its results; what ``fsi-run`` does, for scripts.

>>> import fsi_orchestrator as fsi
>>> case = fsi.load_case("cases/fish_vacuum_3Hz", overrides=["time.periods=1"])
>>> results = fsi.run(case, "/tmp/run")                     # doctest: +SKIP
>>> results.summary["tip_amplitude_m"], results.time_s[-1]  # doctest: +SKIP

``summary`` holds the keys ``fsi-run --json`` prints; :class:`Results` reads the time series
of ``results.h5``. Bad input raises :class:`CaseError` with the one line the commands print.

The orchestrator builds no solver: the application layer that composes the adapters (fishfsi's
``fishfsi.cli.root``) registers itself as the entry point ``fsi_orchestrator.composition``, and
``load_case`` and ``run`` look it up, so that no import runs from here up to it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol

import h5py
import numpy as np
from numpy.typing import NDArray

from .case import Case, CaseError
from .case.loader import load_case as _read_case

__all__ = ["Case", "CaseError", "Results", "load_case", "run"]

COMPOSITION_GROUP = "fsi_orchestrator.composition"


class CompositionRoot(Protocol):
    """What the API needs of the application layer (the entry point's object)."""

    def check_plausible(self, case: Case) -> None: ...

    def execute(
        self,
        case: Case,
        output: Path,
        resume: bool,
        overwrite: bool,
        show_progress: bool,
        overrides: Sequence[str] = (),
    ) -> dict[str, Any]: ...


@cache
def composition_root() -> CompositionRoot:
    """The installed application layer, found through its entry point (fishfsi's, in this
    project); one line naming the group when none is installed."""
    found = sorted(entry_points(group=COMPOSITION_GROUP), key=lambda ep: ep.name)
    if not found:
        raise RuntimeError(
            f"fsi_orchestrator: no composition root installed (entry point group "
            f"{COMPOSITION_GROUP!r}); install the application package: pip install -e ."
        )
    if len(found) > 1:
        names = ", ".join(f"{ep.name} = {ep.value}" for ep in found)
        raise RuntimeError(f"fsi_orchestrator: several composition roots installed: {names}")
    root: CompositionRoot = found[0].load()
    return root


def load_case(path: str | Path, overrides: Iterable[str] = ()) -> Case:
    """The validated case in ``path`` (a folder with ``case.toml``, or the file), with
    ``section.key=value`` overrides (``--set``); refused like the commands refuse it."""
    case = _read_case(path, list(overrides), allow_empty=False)
    composition_root().check_plausible(case)  # the composition root knows the plate's sizes
    return case


@dataclass(frozen=True)
class Results:
    """A finished run: its summary (``fsi-run --json``'s keys) and, for a dynamic run, the
    ``results.h5`` it wrote (one row per time window)."""

    summary: dict[str, Any]
    path: Path | None = None
    _cache: dict[str, NDArray[np.float64]] = field(default_factory=dict, repr=False, compare=False)

    def series(self, name: str) -> NDArray[np.float64]:
        """A dataset of results.h5 by name, e.g. ``shell/tip_displacement_m`` (windows x 3)."""
        if self.path is None:
            raise KeyError(
                f"{name}: a {self.summary.get('kind', 'static or modal')} run has no series"
            )
        if name not in self._cache:
            with h5py.File(self.path, "r", locking=False) as h5:
                if name not in h5:
                    raise KeyError(f"{self.path}: no dataset {name!r} (see names())")
                self._cache[name] = np.asarray(h5[name][()])
        return self._cache[name]

    def names(self) -> list[str]:
        """Every dataset in results.h5."""
        if self.path is None:
            return []
        found: list[str] = []
        with h5py.File(self.path, "r", locking=False) as h5:
            h5.visititems(lambda n, obj: found.append(n) if isinstance(obj, h5py.Dataset) else None)
        return found

    @property
    def attributes(self) -> dict[str, Any]:
        """What made the file: the resolved case, overrides, version, fluid model, units."""
        if self.path is None:
            return {}
        with h5py.File(self.path, "r", locking=False) as h5:
            return dict(h5.attrs)

    @property
    def time_s(self) -> NDArray[np.float64]:
        """End time of each window (s)."""
        return self.series("time_s")[:, 0]

    @property
    def tip_displacement_m(self) -> NDArray[np.float64]:
        """Tail-tip displacement (x, y, z) at the end of each window (m); z is the swing."""
        return self.series("shell/tip_displacement_m")

    @property
    def thrust_n(self) -> NDArray[np.float64] | None:
        """The fluid's thrust per window (N, OpenFOAM), or None where the fluid reports none."""
        try:
            return self.series("fluid/thrust_n")[:, 0]
        except KeyError:
            return None


def run(
    case: Case,
    output: str | Path | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = False,
    overrides: Iterable[str] = (),
) -> Results:
    """Run ``case`` as ``fsi-run`` does (into ``output``, default ``CASE/output``).
    ``overrides``: the ``--set`` lines the case was loaded with, recorded in results.h5."""
    folder = Path(output) if output is not None else case.directory / "output"
    summary = composition_root().execute(  # the composition root builds the participants
        case, folder, resume, overwrite, progress, list(overrides)
    )
    path = summary.get("results")
    return Results(summary=summary, path=Path(path) if path else None)
