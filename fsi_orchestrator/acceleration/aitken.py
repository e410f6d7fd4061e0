"""Aitken dynamic relaxation (Kuettler & Wall 2008; preCICE ``AitkenAcceleration``).

With the residual ``r^k = x~^k - x^k`` and the (scaled) difference ``dr = r^k - r^{k-1}``:

    omega_k = -omega_{k-1} * (r^{k-1} . dr) / (dr . dr)          (k >= 1 in the window)
    x^{k+1} = omega_k * x~^k + (1 - omega_k) * x^k

For a scalar linear map this is the secant method and hits the fixed point in one step.
The first iteration of each window restarts from the given factor, keeping the sign of the last
one and never a larger magnitude (preCICE's rule):

    omega_0 = sign(omega_last) * min(omega_initial, |omega_last|)

With several fields the dot products use the per-field weights of :class:`FieldScaling`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .base import (
    Acceleration,
    FieldScaling,
    ScalingSettings,
    State,
    apply_relaxation,
    check_relaxation,
    optional_array,
    restored_optional,
    restored_scalar,
)


@dataclass(frozen=True, kw_only=True)
class AitkenSettings(ScalingSettings):
    initial_relaxation: float

    def __post_init__(self) -> None:
        check_relaxation("initial_relaxation", self.initial_relaxation)
        super().__post_init__()


class AitkenRelaxation(Acceleration):
    """Relaxation factor updated from the last two residuals of the window."""

    name = "aitken"

    def __init__(self, settings: AitkenSettings) -> None:
        super().__init__()
        self.settings = settings
        self.omega = settings.initial_relaxation
        self._prev_r: NDArray[np.float64] | None = None

    def _on_initialize(self) -> None:
        self._scaling = FieldScaling(self.settings, self.layout)
        self._prev_r = None

    def _perform(self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]) -> NDArray[np.float64]:
        r = x_tilde - x
        self._scaling.update(r)
        self.omega = self._next_omega(r)
        self._prev_r = r
        return apply_relaxation(self.omega, x, x_tilde)

    def _next_omega(self, r: NDArray[np.float64]) -> float:
        if self._prev_r is None:
            return math.copysign(min(self.settings.initial_relaxation, abs(self.omega)), self.omega)
        w = self._scaling.weights
        dr, old = w * (r - self._prev_r), w * self._prev_r
        denominator = float(dr @ dr)
        if denominator == 0.0:
            return self.omega  # same residual twice: no new slope information
        return -self.omega * float(old @ dr) / denominator

    def _converged(
        self, x: NDArray[np.float64] | None, x_tilde: NDArray[np.float64] | None
    ) -> None:
        self._prev_r = None
        self._scaling.end_window()

    def save_state(self) -> State:
        return {
            "aitken_omega": np.asarray(self.omega),
            "aitken_prev_r": optional_array(self._prev_r),
            **self._scaling.save_state(),
        }

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        super().load_state(state)
        self.omega = restored_scalar(state, "aitken_omega")
        self._prev_r = restored_optional(state, "aitken_prev_r", self.layout.size)
        self._scaling.load_state(state)

    def log_line(self) -> str:
        return f"aitken: omega = {self.omega:.4g}"
