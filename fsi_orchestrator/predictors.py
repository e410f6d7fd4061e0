"""Predictors: the first iterate of a window extrapolated from the last converged windows.

The values ``x_j`` converged at window ends ``t_j`` are extrapolated to the new window end
``t`` with the Lagrange polynomial through the last ``order + 1`` of them:

    x(t) = sum_j x_j prod_{i != j} (t - t_i) / (t_j - t_i)

For equal windows this is ``x_n`` (constant), ``2 x_n - x_{n-1}`` (linear) and
``3 x_n - 3 x_{n-1} + x_{n-2}`` (quadratic); exact for polynomials in time of that degree.
With a shorter history the order drops to what the history allows.
(preCICE's old second-order rule ``2.5 x_n - 2 x_{n-1} + 0.5 x_{n-2}`` is not exact for
quadratics; this module uses the Lagrange form.)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray


class Extrapolation(StrEnum):
    CONSTANT = "constant"
    LINEAR = "linear"
    QUADRATIC = "quadratic"

    @property
    def order(self) -> int:
        return list(Extrapolation).index(self)


def lagrange_weights(times: Sequence[float], t: float) -> NDArray[np.float64]:
    """Weights ``w_j`` with ``x(t) = sum_j w_j x_j`` for the polynomial through ``(t_j, x_j)``."""
    ts = np.asarray(times, dtype=float)
    weights = np.ones(len(ts))
    for j, tj in enumerate(ts):
        others = np.delete(ts, j)
        weights[j] = np.prod((t - others) / (tj - others))
    return weights


class Predictor:
    """Keeps the last converged window-end values and extrapolates the next window's start."""

    def __init__(self, extrapolation: Extrapolation | str) -> None:
        choices = [e.value for e in Extrapolation]
        if extrapolation not in choices:
            raise ValueError(f"extrapolation must be one of {choices}, got {extrapolation!r}")
        self.extrapolation = Extrapolation(extrapolation)
        self._times: list[float] = []
        self._values: list[dict[str, NDArray]] = []

    @property
    def has_history(self) -> bool:
        return bool(self._times)

    def record(self, time: float, values: Mapping[str, NDArray]) -> None:
        """Store the converged values at the end ``time`` of a window (copies)."""
        if self._times and not time > self._times[-1]:
            raise ValueError(f"window end times must increase: got {time} after {self._times[-1]}")
        self._times.append(float(time))
        self._values.append({k: np.array(v, dtype=float) for k, v in values.items()})
        keep = self.extrapolation.order + 1
        self._times, self._values = self._times[-keep:], self._values[-keep:]

    def predict(self, time: float) -> dict[str, NDArray[np.float64]]:
        """First iterate for the window ending at ``time``."""
        if not self._times:
            raise RuntimeError("record() the initial values before asking for a prediction")
        weights = lagrange_weights(self._times, time)
        names = self._values[-1].keys()
        return {n: sum(w * v[n] for w, v in zip(weights, self._values, strict=True)) for n in names}

    def save_state(self) -> dict[str, NDArray]:
        state: dict[str, NDArray] = {"predictor_times": np.array(self._times)}
        for j, values in enumerate(self._values):
            state.update({f"predictor_{j}_{n}": v.copy() for n, v in values.items()})
        return state

    def load_state(self, state: Mapping[str, NDArray]) -> None:
        self._times = [float(t) for t in np.asarray(state["predictor_times"]).ravel()]
        self._values = []
        for j in range(len(self._times)):
            prefix = f"predictor_{j}_"
            self._values.append(
                {k[len(prefix) :]: np.array(v) for k, v in state.items() if k.startswith(prefix)}
            )
