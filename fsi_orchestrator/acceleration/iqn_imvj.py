"""IQN-IMVJ: interface quasi-Newton with a multi-vector inverse-Jacobian memory.

Lindner, Mehl, Scheufele & Uekermann (2015), after Bogaers et al. (2014). Within a window this
is IQN-ILS around an initial inverse Jacobian H0 (see iqn_ils.py): the step is

    dx = H0 r + (W - V + H0 V) c,   c = argmin || P (V c + r) ||,

i.e. dx = J r with J = H0 - (W - V + H0 V) R^-1 Q^T P (P V = Q R). At the end of a window J
becomes the next window's H0, so everything learned in all past windows is kept in one dense
n x n matrix instead of a few reused columns: for a map whose Jacobian changes little from
window to window (a nearly linear structure in a liquid) later windows converge in one or two
iterations. n is 3 x the structure's interface nodes (~1.5e3 for the fish), so J is small.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from .base import State, restored
from .iqn_ils import IQNILSAcceleration, IQNILSSettings
from .quasi_newton import qr2_filter

JACOBIAN_FILTER_EPS = 1e-10


class IQNIMVJAcceleration(IQNILSAcceleration):
    name = "iqn-imvj"

    def __init__(self, settings: IQNILSSettings) -> None:
        super().__init__(settings, h0=lambda r: self._jacobian @ r)
        self._jacobian = np.zeros((0, 0))

    def _on_initialize(self) -> None:
        super()._on_initialize()
        # the first window's steps: relaxation omega_0 r where no secant has been seen
        self._jacobian = self.settings.initial_relaxation * np.eye(self.layout.size)

    def _converged(
        self, x: NDArray[np.float64] | None, x_tilde: NDArray[np.float64] | None
    ) -> None:
        if x is not None and x_tilde is not None:
            self._add_secant(x_tilde - x, x_tilde)
        self._update_jacobian()
        self._prev_r = self._prev_xt = None
        self._v, self._w = self._v[:, :0], self._w[:, :0]
        self._window_cols = [0]
        self._scaling.end_window()

    def _update_jacobian(self) -> None:
        """J <- J - (W - V + J V) R^-1 Q^T P with all the window's columns: only exactly
        dependent ones are dropped here (the window's filter may have dropped more, which would
        leave J blind in those directions)."""
        if self.n_columns == 0:
            return
        weights = self._scaling.weights
        q, rf, kept = qr2_filter(weights[:, None] * self._v, JACOBIAN_FILTER_EPS)
        if not kept:
            return
        v, w = self._v[:, kept], self._w[:, kept]
        correction = (w - v + self._jacobian @ v) @ solve_triangular(rf, q.T)
        self._jacobian = self._jacobian - correction * weights[None, :]

    def warm_start(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        """Start from the Jacobian another run learned (its saved state): for a map that
        changes little between runs (the same structure at another drive) the first windows
        need not learn it again. Only the Jacobian is taken."""
        self._jacobian = restored(state, "imvj_jacobian", self._jacobian.shape)

    def save_state(self) -> State:
        return {**super().save_state(), "imvj_jacobian": self._jacobian.copy()}

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        super().load_state(state)
        self._jacobian = restored(state, "imvj_jacobian", self._jacobian.shape)
