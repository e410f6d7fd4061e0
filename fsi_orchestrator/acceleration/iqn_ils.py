"""IQN-ILS: interface quasi-Newton with an inverse Jacobian from a least-squares model.

Design note
-----------
Degroote, Bathe & Vierendeels 2009, "Performance of a new partitioned procedure versus a
monolithic procedure in fluid-structure interaction", Comput. Struct. 87; preCICE
``IQNILSAcceleration``. Fixed-point problem ``x = H(x)``, residual ``R(x) = H(x) - x``,
``r^k = R(x^k)``. The secant pairs of :mod:`.quasi_newton` hold

    V = [dr ...]     (residual differences),   W = [dx~ ...]   (output differences),

and the corresponding input differences are ``dX = W - V``. The newest residual is written as
a combination of the stored ones,

    c = argmin_c || P (V c + r^k) ||_2,   i.e.   R c = -Q^T P r^k   with   P V = Q R,

(``P`` the diagonal field weights; the QR is the filtered one), and the step is

    x^{k+1} = x~^k + W c              (plain IQN-ILS)

For an affine ``H`` with ``n`` unknowns the columns reach ``n`` after ``n`` iterations, the
least-squares model is then the exact inverse Jacobian and ``x^{n+1}`` is the fixed point.

Initial inverse-Jacobian approximation ``H0``
---------------------------------------------
Write Newton's step for ``R`` as ``dx = -J^{-1} r`` with ``J = R'(x) = H'(x) - I``. The
least-squares model is the multi-secant inverse Jacobian closest to a prior ``G0`` that maps
``V`` to ``dX`` (generalized Broyden, type II; Haelterman et al. 2016; Fang & Saad 2009):

    J^{-1} ~ G = G0 + (dX - G0 V) (V^T V)^{-1} V^T

Take ``H0 = -G0``, the map from a residual to the step one would take without history
(``H0 = (I - H')^{-1}`` is the exact one: then ``x + H0(r)`` is the fixed point of an affine
map). With ``c = -(V^T V)^{-1} V^T r`` as above,

    dx = -G r = H0(r) + (dX + H0(V)) c = H0(r) + (W - V + H0(V)) c,

    x^{k+1} = x~^k + [H0(r) - r + (W - V + H0(V)) c].

``H0 = identity`` gives back plain IQN-ILS (``dX + V = W``), which is the default; the step
without any columns is then the relaxation ``omega_0 r``, with ``H0`` given it is ``H0(r)``.
Written as ``dx = H0(r) + (W' - H0(V')) alpha`` (the generalized-Broyden form), ``W' = dX`` is
the input-difference matrix, ``V' = -V`` holds the differences of ``x - x~`` and
``alpha = c = argmin ||V' alpha - r||``; note that there ``W'`` is not preCICE's ``W``.

``H0`` acts on the flat vector of :class:`~.base.FieldLayout` (fields concatenated in layout
order, unscaled) and must be linear; it is applied to each column of V in every update, so it
should be cheap (e.g. a factorized added-mass operator).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from .base import AccelerationStateError
from .quasi_newton import BaseQNAcceleration, QuasiNewtonSettings

InverseJacobian = Callable[[NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True, kw_only=True)
class IQNILSSettings(QuasiNewtonSettings):
    """IQN-ILS needs nothing beyond the common quasi-Newton settings."""


class IQNILSAcceleration(BaseQNAcceleration):
    """Least-squares quasi-Newton update, optionally around an initial inverse Jacobian."""

    name = "iqn-ils"

    def __init__(self, settings: IQNILSSettings, h0: InverseJacobian | None = None) -> None:
        super().__init__(settings)
        self.h0 = h0

    def _initial_step(
        self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        if self.h0 is None:
            return super()._initial_step(x, x_tilde)
        return x + self._apply_h0(x_tilde - x)

    def _compute_qn_update(
        self, r: NDArray[np.float64], q: NDArray[np.float64], rf: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        c: NDArray[np.float64] = solve_triangular(rf, -(q.T @ (self._scaling.weights * r)))
        if self.h0 is None:
            return self._w @ c
        h0_v = np.column_stack([self._apply_h0(col) for col in self._v.T])
        return self._apply_h0(r) - r + (self._w - self._v + h0_v) @ c

    def _apply_h0(self, vector: NDArray[np.float64]) -> NDArray[np.float64]:
        assert self.h0 is not None
        out = np.asarray(self.h0(vector.copy()), dtype=float)
        if out.shape != vector.shape:
            raise AccelerationStateError(
                f"H0 must map a vector of shape {vector.shape} to the same shape, got {out.shape}"
            )
        return out
