"""Convergence of the implicit coupling iterations within a time window.

One small object per measure, as preCICE ``src/cplscheme/impl/*ConvergenceMeasure.hpp``; each
compares the input ``x^k`` of an iteration ("old") with its output ``x~^k = H(x^k)`` ("new") in
the 2-norm over all entries of one field:

* :class:`AbsoluteMeasure`:          ``||x~ - x|| < tol``
* :class:`RelativeMeasure`:          ``||x~ - x|| < tol ||x~||``
* :class:`ResidualRelativeMeasure`:  ``||x~ - x|| < tol ||x~^0 - x^0||`` (first iteration of
  the window; so it never holds in that first iteration)

:class:`ConvergenceCriteria` combines measures per field (all must hold, or one marked
``suffices``, as in preCICE), enforces minimum and maximum iteration counts and raises
:class:`CouplingDivergenceError` on non-finite data or on a residual that grows beyond
``divergence_factor`` times the window's first one.
Iterations are counted from 1 (the first solve of a window).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray


class ConvergenceSettingsError(ValueError):
    """A convergence setting (tolerance, iteration bound) has an unusable value."""


class CouplingDivergenceError(RuntimeError):
    """The coupling iterations diverged; names the field, the window and the iteration."""

    def __init__(self, reason: str, *, field: str, window: int, iteration: int) -> None:
        super().__init__(
            f"coupling diverged: field {field!r}, window {window}, iteration {iteration}: {reason}"
        )
        self.field, self.window, self.iteration = field, window, iteration


def _check_tolerance(name: str, value: float, *, at_most_one: bool) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and value > 0
    ok = ok and math.isfinite(value) and (value <= 1.0 or not at_most_one)
    if not ok:
        bounds = "(0, 1]" if at_most_one else "(0, inf)"
        raise ConvergenceSettingsError(f"{name} tolerance must be in {bounds}, got {value!r}")


class ConvergenceMeasure(ABC):
    """``measure(old, new)`` returns ``||new - old|| < tolerance * reference``.

    ``suffices=True`` (preCICE's attribute): this measure alone is enough for convergence,
    e.g. an absolute measure beside a relative one for a field that may be zero.
    """

    kind = "measure"

    def __init__(self, *, tolerance: float, suffices: bool = False) -> None:
        self.tolerance, self.suffices = tolerance, suffices
        self.reset_window()

    def reset_window(self) -> None:
        """Start a new series of iterations (preCICE ``newMeasurementSeries``)."""
        self.norm_diff = math.nan
        self.reference = math.nan
        self.converged = False

    def measure(self, old: NDArray[np.float64], new: NDArray[np.float64]) -> bool:
        diff = np.asarray(new, dtype=float) - np.asarray(old, dtype=float)
        self.norm_diff = float(np.linalg.norm(diff))
        self.reference = self._reference(np.asarray(new, dtype=float))
        self.converged = self.norm_diff < self.tolerance * self.reference
        return self.converged

    @abstractmethod
    def _reference(self, new: NDArray[np.float64]) -> float:
        """The norm the difference is compared against (times the tolerance)."""

    @property
    def value(self) -> float:
        """The normalized residual compared with the tolerance (inf for a zero reference)."""
        return self.norm_diff / self.reference if self.reference else math.inf

    def log_line(self) -> str:
        return (
            f"{self.kind}: ||x~ - x|| = {self.norm_diff:.3e}, normalized {self.value:.3e}, "
            f"limit {self.tolerance:.3e}, converged {'yes' if self.converged else 'no'}"
        )


class AbsoluteMeasure(ConvergenceMeasure):
    """``||x~ - x|| < tol`` (tol in the field's units)."""

    kind = "absolute"

    def __init__(self, *, tolerance: float, suffices: bool = False) -> None:
        _check_tolerance("absolute", tolerance, at_most_one=False)
        super().__init__(tolerance=tolerance, suffices=suffices)

    def _reference(self, new: NDArray[np.float64]) -> float:
        return 1.0


class RelativeMeasure(ConvergenceMeasure):
    """``||x~ - x|| < tol ||x~||``."""

    kind = "relative"

    def __init__(self, *, tolerance: float, suffices: bool = False) -> None:
        _check_tolerance("relative", tolerance, at_most_one=True)
        super().__init__(tolerance=tolerance, suffices=suffices)

    def _reference(self, new: NDArray[np.float64]) -> float:
        return float(np.linalg.norm(new))


class ScaledRelativeMeasure(RelativeMeasure):
    """``||x~ - x|| < tol max(||x~||, s)`` with a scale ``s`` the caller sets before each check:
    when the exchanged variable is a corrected force (added-mass schemes: the fluid force plus
    the model's added-mass force) it is small next to the fluid force it stands for, and the
    tolerance refers to that fluid force."""

    kind = "relative-to-scale"

    def __init__(self, *, tolerance: float, suffices: bool = False) -> None:
        super().__init__(tolerance=tolerance, suffices=suffices)
        self.scale = 0.0

    def _reference(self, new: NDArray[np.float64]) -> float:
        return max(float(np.linalg.norm(new)), self.scale)


class ResidualRelativeMeasure(ConvergenceMeasure):
    """``||x~ - x|| < tol * ||x~ - x||`` of the window's first iteration."""

    kind = "residual-relative"

    def __init__(self, *, tolerance: float, suffices: bool = False) -> None:
        _check_tolerance("residual-relative", tolerance, at_most_one=True)
        super().__init__(tolerance=tolerance, suffices=suffices)

    def reset_window(self) -> None:
        super().reset_window()
        self._first: float | None = None

    def _reference(self, new: NDArray[np.float64]) -> float:
        if self._first is None:
            self._first = self.norm_diff
        return self._first


class WindowStatus(StrEnum):
    ITERATE = "iterate"
    CONVERGED = "converged"
    MAX_ITERATIONS = "max-iterations"  # accepted unconverged, as preCICE does

    @property
    def done(self) -> bool:
        return self is not WindowStatus.ITERATE


class ConvergenceCriteria:
    """Per-field measures, iteration bounds and divergence detection for one window at a time.

    With no measures every window is done after ``min_iterations`` (explicit coupling: use
    ``max_iterations=1``); non-finite data are still reported.
    """

    def __init__(
        self,
        measures: Mapping[str, Sequence[ConvergenceMeasure]],
        *,
        min_iterations: int = 1,
        max_iterations: int = 100,
        divergence_factor: float = 1e6,
    ) -> None:
        _check_iterations(min_iterations, max_iterations)
        if not (isinstance(divergence_factor, int | float) and divergence_factor > 1):
            raise ConvergenceSettingsError(
                f"divergence_factor must be > 1, got {divergence_factor!r}"
            )
        self.measures = {name: list(ms) for name, ms in measures.items()}
        self.min_iterations, self._max_iterations = min_iterations, max_iterations
        self.divergence_factor = float(divergence_factor)
        self.new_window(0)  # sets max_iterations, the bound of the current window

    def new_window(self, window: int, max_iterations: int | None = None) -> None:
        """Reset for window ``window`` (its number is only used in messages); ``max_iterations``
        overrides the bound for this window (1: an explicit window of an implicit run)."""
        if max_iterations is not None:
            _check_iterations(self.min_iterations, max_iterations)
        self.max_iterations = self._max_iterations if max_iterations is None else max_iterations
        self.window, self.iteration = window, 0
        self.residuals: dict[str, float] = {}  # ||x~ - x|| per field, last iteration
        self._first: dict[str, float] = {}
        for ms in self.measures.values():
            for m in ms:
                m.reset_window()

    def check(
        self, old: Mapping[str, NDArray[np.float64]], new: Mapping[str, NDArray[np.float64]]
    ) -> WindowStatus:
        """Measure the iteration ``old = x^k -> new = x~^k``; raise if it diverged."""
        self.iteration += 1
        for field in self.measures:
            if field not in old or field not in new:
                raise KeyError(f"convergence is measured on {field!r}, which was not passed")
        for field in (f for f in new if f in old):
            self._check_divergence(field, np.asarray(old[field]), np.asarray(new[field]))
        results = [
            (m.measure(old[field], new[field]), m.suffices)
            for field, ms in self.measures.items()
            for m in ms
        ]
        converged = all(ok for ok, _ in results) or any(ok and suf for ok, suf in results)
        if converged and self.iteration >= self.min_iterations:
            return WindowStatus.CONVERGED
        if self.iteration >= self.max_iterations:
            return WindowStatus.MAX_ITERATIONS
        return WindowStatus.ITERATE

    def _check_divergence(
        self, field: str, old: NDArray[np.float64], new: NDArray[np.float64]
    ) -> None:
        for label, values in (("output x~", new), ("input x", old)):
            if not np.all(np.isfinite(values)):
                raise self._diverged(f"non-finite values (nan/inf) in {label}", field)
        norm = float(np.linalg.norm(new.astype(float) - old))
        first = self._first.setdefault(field, norm)
        self.residuals[field] = norm
        if first > 0.0 and norm > self.divergence_factor * first:
            raise self._diverged(
                f"residual ||x~ - x|| = {norm:.3e} grew beyond {self.divergence_factor:.0e} "
                f"times the window's first residual {first:.3e}",
                field,
            )

    def _diverged(self, reason: str, field: str) -> CouplingDivergenceError:
        return CouplingDivergenceError(
            reason, field=field, window=self.window, iteration=self.iteration
        )

    def log_lines(self) -> list[str]:
        head = f"window {self.window} iteration {self.iteration}"
        return [f"{head} {name}: {m.log_line()}" for name, ms in self.measures.items() for m in ms]


def _check_iterations(min_iterations: int, max_iterations: int) -> None:
    for name, value in (("min_iterations", min_iterations), ("max_iterations", max_iterations)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConvergenceSettingsError(f"{name} must be an integer >= 1, got {value!r}")
    if max_iterations < min_iterations:
        raise ConvergenceSettingsError(
            f"max_iterations ({max_iterations}) must be >= min_iterations ({min_iterations})"
        )
