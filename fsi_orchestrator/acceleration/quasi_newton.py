"""Bookkeeping shared by the quasi-Newton schemes (preCICE ``BaseQNAcceleration``).

Design note
-----------
Residual ``r^k = x~^k - x^k``. Every iteration after the first of a window adds one secant
pair as the newest (leftmost) column of two difference matrices

    V = [r^k - r^{k-1}, r^{k-1} - r^{k-2}, ...]          (residual differences)
    W = [x~^k - x~^{k-1}, x~^{k-1} - x~^{k-2}, ...]      (output differences)

Columns are never formed across a window boundary. What this class owns:

* **Reuse**: at the end of a window its columns are kept, together with those of earlier
  windows, as long as they belong to the last ``reuse_windows`` windows; the oldest window's
  columns go first. With ``reuse_windows = 0`` every window starts without columns.
* **Column limit**: at most ``min(max_columns, n)`` columns (``n`` the number of unknowns);
  the oldest column is dropped to make room.
* **Filtering** (Haelterman et al. 2016, "Improving the performance of the partitioned QN-ILS
  procedure for FSI problems: filtering", Comput. Struct. 171): before each update the scaled
  ``P V`` is factorized, ``P V = Q R``, and nearly dependent columns are deleted from V and W
  for good:

  - ``QR2`` (default): from the newest column on, column ``v`` is deleted when its part
    orthogonal to the columns kept before it is small, ``||v_perp|| <= eps ||v||``. The newest
    column is never deleted unless it is zero.
  - ``QR1``: delete the newest column with ``|R_ii| < eps ||R||_F``.

  Both delete one column at a time and refactorize (``numpy.linalg.qr``) until none fails.
  - ``none``: only exactly dependent columns are deleted.

* **First step**: without columns (first window, or no reuse) the step is the constant
  relaxation ``x^{k+1} = x^k + omega_0 r^k``.

A subclass only supplies :meth:`BaseQNAcceleration._compute_qn_update` (the update added to
``x~^k`` given ``Q, R``), as preCICE's ``computeQNUpdate``.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from .base import (
    Acceleration,
    AccelerationSettingsError,
    AccelerationStateError,
    FieldScaling,
    ScalingSettings,
    State,
    apply_relaxation,
    check_relaxation,
    optional_array,
    restored_optional,
    restored_scalar,
)


class QRFilter(StrEnum):
    QR1 = "QR1"
    QR2 = "QR2"
    NONE = "none"


@dataclass(frozen=True, kw_only=True)
class QuasiNewtonSettings(ScalingSettings):
    """Settings common to the quasi-Newton schemes (preCICE names in brackets).

    ``initial_relaxation`` [initial-relaxation]: omega of the steps taken without columns;
    ``reuse_windows`` [time-windows-reused]; ``max_columns`` [max-used-iterations];
    ``filter`` and ``filter_eps`` [filter type, limit].
    """

    initial_relaxation: float
    reuse_windows: int = 8
    max_columns: int = 100
    filter: QRFilter = QRFilter.QR2
    filter_eps: float = 1e-2

    def __post_init__(self) -> None:
        check_relaxation("initial_relaxation", self.initial_relaxation)
        _check_int("reuse_windows", self.reuse_windows, minimum=0)
        _check_int("max_columns", self.max_columns, minimum=1)
        choices = [f.value for f in QRFilter]
        if self.filter not in choices:
            raise AccelerationSettingsError(f"filter must be one of {choices}, got {self.filter!r}")
        object.__setattr__(self, "filter", QRFilter(self.filter))
        eps = self.filter_eps
        if isinstance(eps, bool) or not (isinstance(eps, int | float) and 0.0 < eps < 1.0):
            raise AccelerationSettingsError(f"filter_eps must be in (0, 1), got {eps!r}")
        super().__post_init__()


def _check_int(name: str, value: int, *, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise AccelerationSettingsError(f"{name} must be an integer >= {minimum}, got {value!r}")


def _saved(state: Mapping[str, NDArray[np.float64]], key: str) -> NDArray[np.float64]:
    if key not in state:
        raise AccelerationStateError(f"saved accelerator state lacks {key!r}")
    return np.array(state[key], dtype=float)  # a copy


def qr2_filter(
    v: NDArray[np.float64], eps: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int]]:
    """QR2 filter: ``v[:, kept] = Q R``, columns taken from the left.

    A column is kept when its part orthogonal to the columns kept before it is not small,
    ``|R_ii| > eps ||v_i||`` (``eps = 0``: only exactly dependent columns are skipped).
    """
    return _qr_filter(v, lambda diag, cols, _: diag <= eps * np.linalg.norm(cols, axis=0))


def qr1_filter(
    v: NDArray[np.float64], eps: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int]]:
    """QR1 filter: ``v[:, kept] = Q R`` with every ``|R_ii| >= eps ||R||_F``."""
    return _qr_filter(v, lambda diag, _, r: (diag < eps * np.linalg.norm(r)) | (diag == 0.0))


Rejects = Callable[
    [NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]
]


def _qr_filter(
    v: NDArray[np.float64], rejects: Rejects
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int]]:
    """Householder QR; delete the leftmost rejected column and refactorize until none is.

    Deleting only the leftmost one per pass makes the QR2 test of a later column refer to the
    columns kept before it, as in the column-by-column Gram-Schmidt of preCICE.
    """
    kept = list(range(v.shape[1]))
    while kept:
        q, r = np.linalg.qr(v[:, kept])
        bad = np.flatnonzero(rejects(np.abs(np.diag(r)), v[:, kept], r))
        if bad.size == 0:
            return q, r, kept
        del kept[int(bad[0])]
    return np.zeros((v.shape[0], 0)), np.zeros((0, 0)), kept


class BaseQNAcceleration(Acceleration):
    """V/W history, reuse of past windows, column limit and QR filtering."""

    def __init__(self, settings: QuasiNewtonSettings) -> None:
        super().__init__()
        self.settings = settings
        self.deleted_columns = 0  # removed by the filter, whole run
        self.dropped_columns = 0  # removed for the column limit or the reuse horizon
        self._reset_history(0)

    def _reset_history(self, n: int) -> None:
        self._v, self._w = np.zeros((n, 0)), np.zeros((n, 0))
        self._window_cols = [0]  # columns per window, current window first
        self._prev_r: NDArray[np.float64] | None = None
        self._prev_xt: NDArray[np.float64] | None = None

    def _on_initialize(self) -> None:
        self._reset_history(self.layout.size)
        self._scaling = FieldScaling(self.settings, self.layout)

    @property
    def n_columns(self) -> int:
        return self._v.shape[1]

    @property
    def matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Copies of ``(V, W)``, newest column first (for inspection and tests)."""
        return self._v.copy(), self._w.copy()

    def _perform(self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]) -> NDArray[np.float64]:
        r = x_tilde - x
        self._scaling.update(r)
        self._add_secant(r, x_tilde)
        q, rf = self._filtered_qr()
        if self.n_columns == 0:
            return self._initial_step(x, x_tilde)
        return x_tilde + self._compute_qn_update(r, q, rf)

    def _initial_step(
        self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        return apply_relaxation(self.settings.initial_relaxation, x, x_tilde)

    @abstractmethod
    def _compute_qn_update(
        self, r: NDArray[np.float64], q: NDArray[np.float64], rf: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """``x^{k+1} - x~^k`` from the residual and the QR factors of the scaled ``P V``."""

    def _add_secant(self, r: NDArray[np.float64], x_tilde: NDArray[np.float64]) -> None:
        if self._prev_r is not None and self._prev_xt is not None:
            if self.n_columns >= min(self.settings.max_columns, self.layout.size):
                self._remove_column(self.n_columns - 1)
                self.dropped_columns += 1
            self._v = np.column_stack([r - self._prev_r, self._v])
            self._w = np.column_stack([x_tilde - self._prev_xt, self._w])
            self._window_cols[0] += 1
        self._prev_r, self._prev_xt = r, x_tilde

    def _filtered_qr(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """QR of the scaled ``P V`` after deleting the columns the filter rejects."""
        scaled = self._scaling.weights[:, None] * self._v
        if self.settings.filter is QRFilter.QR1:
            q, rf, kept = qr1_filter(scaled, self.settings.filter_eps)
        else:
            eps = self.settings.filter_eps if self.settings.filter is QRFilter.QR2 else 0.0
            q, rf, kept = qr2_filter(scaled, eps)
        for j in sorted(set(range(self.n_columns)) - set(kept), reverse=True):
            self._remove_column(j)
            self.deleted_columns += 1
        return q, rf

    def _remove_column(self, j: int) -> None:
        self._v, self._w = np.delete(self._v, j, axis=1), np.delete(self._w, j, axis=1)
        window = int(np.searchsorted(np.cumsum(self._window_cols), j, side="right"))
        self._window_cols[window] -= 1
        if self._window_cols[window] == 0 and window > 0:
            del self._window_cols[window]

    def _converged(
        self, x: NDArray[np.float64] | None, x_tilde: NDArray[np.float64] | None
    ) -> None:
        if x is not None and x_tilde is not None:
            self._add_secant(x_tilde - x, x_tilde)
        self._prev_r = self._prev_xt = None
        if self._window_cols[0] == 0:
            del self._window_cols[0]
        reuse = self.settings.reuse_windows
        keep = sum(self._window_cols[:reuse])  # the oldest columns are the rightmost
        self.dropped_columns += self.n_columns - keep
        self._v, self._w = self._v[:, :keep].copy(), self._w[:, :keep].copy()
        self._window_cols = [0, *self._window_cols[:reuse]]
        self._scaling.end_window()

    def save_state(self) -> State:
        return {
            "qn_v": self._v.copy(),
            "qn_w": self._w.copy(),
            "qn_window_cols": np.array(self._window_cols, dtype=np.int64),
            "qn_prev_r": optional_array(self._prev_r),
            "qn_prev_xt": optional_array(self._prev_xt),
            "qn_deleted_columns": np.asarray(self.deleted_columns),
            "qn_dropped_columns": np.asarray(self.dropped_columns),
            **self._scaling.save_state(),
        }

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        super().load_state(state)
        n = self.layout.size
        v, w, saved_cols = (_saved(state, k) for k in ("qn_v", "qn_w", "qn_window_cols"))
        cols = [int(c) for c in saved_cols.ravel()]
        if v.ndim != 2 or v.shape[0] != n or v.shape != w.shape or sum(cols) != v.shape[1]:
            raise AccelerationStateError(
                f"saved V {v.shape}, W {w.shape} and window columns {cols} do not agree "
                f"with {n} unknowns"
            )
        self._v, self._w, self._window_cols = v, w, cols or [0]
        self._prev_r = restored_optional(state, "qn_prev_r", n)
        self._prev_xt = restored_optional(state, "qn_prev_xt", n)
        self.deleted_columns = int(restored_scalar(state, "qn_deleted_columns"))
        self.dropped_columns = int(restored_scalar(state, "qn_dropped_columns"))
        self._scaling.load_state(state)

    def log_line(self) -> str:
        windows = sum(1 for c in self._window_cols if c > 0)
        return (
            f"{self.name}: {self.n_columns} columns from {windows} windows, "
            f"filter deleted {self.deleted_columns}, dropped {self.dropped_columns} (whole run)"
        )
