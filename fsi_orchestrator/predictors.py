"""Predictors: the first iterate of a window extrapolated from the last converged windows.

The values ``x_j`` converged at window ends ``t_j`` are extrapolated to the new window end
``t`` with the Lagrange polynomial through the last ``order + 1`` of them:

    x(t) = sum_j x_j prod_{i != j} (t - t_i) / (t_j - t_i)

For equal windows this is ``x_n`` (constant), ``2 x_n - x_{n-1}`` (linear) and
``3 x_n - 3 x_{n-1} + x_{n-2}`` (quadratic); exact for polynomials in time of that degree.
With a shorter history the order drops to what the history allows.
(preCICE's old second-order rule ``2.5 x_n - 2 x_{n-1} + 0.5 x_{n-2}`` is not exact for
quadratics; this module uses the Lagrange form.)

``periodic`` is for a periodically driven structure (period ``T``): once a period is recorded
the value one period back, x(t - T), is corrected by the change from period to period,
d(t) = x(t) - x(t - T), either as last seen (``d_n``) or extrapolated linearly
(``2 d_n - d_{n-1}``). Exact on a periodic orbit whatever its harmonics, where a polynomial in
time misses by ~(w dt)^(order+1): at 40 windows per period quadratic extrapolation misses the
coupled fish's nodal force by 1-4 %, the period rules by 0.15-0.5 % once the run is periodic
(docs/coupling.md). While the run is still settling onto its orbit the period rules can be
worse than a polynomial, so each window uses whichever of linear, quadratic and the two period
rules predicted the last window best.

An explicit scheme (one solve per window) feeds the prediction straight back into the next
window, and extrapolation amplifies what the solvers disagree on: with the CFD, linear
extrapolation of the exchanged force grows a window-to-window oscillation that holding the last
value does not (docs/coupling.md). The plain period rule, x_n + x_m - x_{m-1} (t_m = t - T),
copies the last period's window-to-window wobble into this window at twice its size: with the
CFD such bursts came back at the same phase every period and the periods wandered by 1-2 %.
Explicit schemes therefore choose between ``constant`` and ``period-smooth``, the period rule
with the last period's step filtered (``EXPLICIT_RULES``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

Values = dict[str, NDArray[np.float64]]


class Extrapolation(StrEnum):
    CONSTANT = "constant"
    LINEAR = "linear"
    QUADRATIC = "quadratic"
    PERIODIC = "periodic"

    @property
    def order(self) -> int:
        """Polynomial order (periodic: quadratic until a period is recorded)."""
        return min(list(Extrapolation).index(self), 2)


PERIODIC_RULES = ("linear", "quadratic", "period", "period-linear")
EXPLICIT_RULES = ("constant", "period-smooth")
ALL_RULES = ("constant", "linear", "quadratic", "period", "period-linear", "period-smooth")
_RULE_ORDER = {"constant": 0, "linear": 1, "quadratic": 2}
# period-smooth: the step x_m - x_{m-1} of the last period filtered by [-1, 4, 10, 4, -1] / 16
# (zero at the Nyquist frequency, flat to fourth order at low ones), as weights of x_{m+k}
SMOOTH_STEP_OFFSETS = (2, 1, 0, -1, -2, -3)
SMOOTH_STEP = tuple(c / 16 for c in (-1.0, 5.0, 6.0, -6.0, -5.0, 1.0))


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

    def __init__(
        self,
        extrapolation: Extrapolation | str,
        period: float = 0.0,
        rules: tuple[str, ...] = PERIODIC_RULES,
    ) -> None:
        """``rules``: what ``periodic`` chooses from (PERIODIC_RULES or EXPLICIT_RULES); until
        a period is recorded it uses the highest polynomial order among them."""
        choices = [e.value for e in Extrapolation]
        if extrapolation not in choices:
            raise ValueError(f"extrapolation must be one of {choices}, got {extrapolation!r}")
        self.extrapolation = Extrapolation(extrapolation)
        if self.extrapolation is Extrapolation.PERIODIC and not period > 0:
            raise ValueError(
                "the periodic predictor needs the driving period (actuation.frequency_hz > 0); "
                'use coupling.predictor = "quadratic" otherwise'
            )
        self.period = float(period)
        self.use_rules(rules)
        self._times: list[float] = []
        self._values: list[Values] = []
        # periodic: how far each of ALL_RULES missed the last recorded window (inf: not yet
        # available); all are scored so that a run can change its rules (explicit start-up)
        self.all_rule_errors = np.full(len(ALL_RULES), np.inf)

    def use_rules(self, rules: tuple[str, ...]) -> None:
        """What ``periodic`` chooses from from now on (the history is kept)."""
        unknown = set(rules) - set(ALL_RULES)
        if unknown:
            raise ValueError(f"unknown predictor rules {sorted(unknown)}; known: {ALL_RULES}")
        self.rules = tuple(rules)
        self._fallback = max((_RULE_ORDER[r] for r in self.rules if r in _RULE_ORDER), default=2)

    @property
    def rule_errors(self) -> NDArray[np.float64]:
        """How far each of ``rules`` missed the last recorded window."""
        return self.all_rule_errors[[ALL_RULES.index(r) for r in self.rules]]

    @property
    def has_history(self) -> bool:
        return bool(self._times)

    @property
    def rule(self) -> str:
        """The rule the next prediction uses."""
        if self.extrapolation is not Extrapolation.PERIODIC:
            return self.extrapolation.value
        if not np.isfinite(self.rule_errors).any():
            return next(r for r, k in _RULE_ORDER.items() if k == self._fallback)
        return self.rules[int(np.argmin(self.rule_errors))]

    def record(self, time: float, values: Mapping[str, NDArray[np.float64]]) -> None:
        """Store the converged values at the end ``time`` of a window (copies)."""
        if self._times and not time > self._times[-1]:
            raise ValueError(f"window end times must increase: got {time} after {self._times[-1]}")
        new = {k: np.array(v, dtype=float) for k, v in values.items()}
        if self.extrapolation is Extrapolation.PERIODIC and self._times:
            self.all_rule_errors = np.array(
                [_miss(rule(time), new) for rule in self._rules(ALL_RULES)]
            )
        self._times.append(float(time))
        self._values.append(new)
        keep = self.extrapolation.order + 1
        if self.extrapolation is Extrapolation.PERIODIC and len(self._times) > 1:
            # a period and three windows back
            span = self.period + 3.5 * (self._times[-1] - self._times[-2])
            keep = max(keep, sum(t >= self._times[-1] - span for t in self._times))
        self._times, self._values = self._times[-keep:], self._values[-keep:]

    def restart(self, time: float, values: Mapping[str, NDArray[np.float64]]) -> None:
        """Forget the history (it holds another variable) and start from ``values``."""
        self._times, self._values = [], []
        self.all_rule_errors = np.full(len(ALL_RULES), np.inf)
        self.record(time, values)

    def predict(self, time: float) -> Values:
        """First iterate for the window ending at ``time``."""
        if not self._times:
            raise RuntimeError("record() the initial values before asking for a prediction")
        if self.extrapolation is not Extrapolation.PERIODIC:
            return self._polynomial(time, self.extrapolation.order)
        rule = self.rule
        prediction = self._rules((rule,))[0](time) if rule in self.rules else None
        return prediction if prediction is not None else self._polynomial(time, self._fallback)

    # ------------------------------------------------------------------ rules
    def _polynomial(self, time: float, order: int) -> Values:
        times, values = self._times[-(order + 1) :], self._values[-(order + 1) :]
        weights = lagrange_weights(times, time)
        names = values[-1].keys()
        return {n: sum(w * v[n] for w, v in zip(weights, values, strict=True)) for n in names}

    def _rules(self, names: tuple[str, ...]) -> list[Callable[[float], Values | None]]:
        every = {
            "constant": lambda t: self._polynomial(t, 0),
            "linear": lambda t: self._polynomial(t, 1),
            "quadratic": lambda t: self._polynomial(t, 2),
            "period": lambda t: self._periodic(t, linear=False),
            "period-linear": lambda t: self._periodic(t, linear=True),
            "period-smooth": self._periodic_smooth,
        }
        return [every[r] for r in names]

    def _at(self, time: float) -> Values | None:
        """The recorded values at ``time`` (to a thousandth of a window), if any."""
        if len(self._times) < 2:
            return None
        tolerance = 1e-3 * (self._times[-1] - self._times[-2])
        j = int(np.argmin(np.abs(np.array(self._times) - time)))
        return self._values[j] if abs(self._times[j] - time) <= tolerance else None

    def _periodic(self, time: float, linear: bool) -> Values | None:
        """x(t - T) + d, d the period-to-period change at the last window (or its linear
        extrapolation from the last two); None until the history reaches back that far."""
        ends = self._times[-2:] if linear else self._times[-1:]
        looked_up = [self._at(t - self.period) for t in (time, *ends)]
        back = [b for b in looked_up if b is not None]
        if len(ends) < (2 if linear else 1) or len(back) < len(looked_up):
            return None
        recent = self._values[-len(ends) :]
        changes = [{n: v[n] - b[n] for n in v} for v, b in zip(recent, back[1:], strict=True)]
        weights = lagrange_weights(ends, time)
        return {
            n: back[0][n] + sum(w * d[n] for w, d in zip(weights, changes, strict=True))
            for n in back[0]
        }

    def _periodic_smooth(self, time: float) -> Values | None:
        """x_n plus the last period's step to this window, smoothed: the step of the last
        period filtered by [-1, 4, 10, 4, -1] / 16 (t_m = t - T),
        x_n + (-x_{m+2} + 5 x_{m+1} + 6 x_m - 6 x_{m-1} - 5 x_{m-2} + x_{m-3}) / 16.
        The plain period rule is x_n + x_m - x_{m-1}; the filter takes out the last period's
        window-to-window (Nyquist) part, which the plain rule feeds back at twice its size,
        and keeps 1 - (w dt)^4 / 16 of a harmonic's step (0.99996 at 40 windows per period,
        0.98 for the fifth harmonic)."""
        if len(self._times) < 2:
            return None
        dt = self._times[-1] - self._times[-2]
        back: list[Values] = []
        for k in SMOOTH_STEP_OFFSETS:
            value = self._at(time - self.period + k * dt)
            if value is None:
                return None
            back.append(value)
        prediction = {n: v.copy() for n, v in self._values[-1].items()}
        for c, b in zip(SMOOTH_STEP, back, strict=True):
            for n in prediction:
                prediction[n] += c * b[n]
        return prediction

    # ------------------------------------------------------------------ restart
    def save_state(self) -> dict[str, NDArray[np.float64]]:
        state: dict[str, NDArray[np.float64]] = {
            "predictor_times": np.array(self._times),
            "predictor_all_rule_errors": self.all_rule_errors.copy(),
        }
        for j, values in enumerate(self._values):
            state.update({f"predictor_{j}_{n}": v.copy() for n, v in values.items()})
        return state

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        self._times = [float(t) for t in np.asarray(state["predictor_times"]).ravel()]
        if "predictor_all_rule_errors" in state:
            # a checkpoint from before a rule was added scores the new rule from the next window
            saved = np.array(state["predictor_all_rule_errors"], dtype=float).ravel()
            self.all_rule_errors = np.full(len(ALL_RULES), np.inf)
            self.all_rule_errors[: len(saved)] = saved[: len(ALL_RULES)]
        self._values = []
        for j in range(len(self._times)):
            prefix = f"predictor_{j}_"
            self._values.append(
                {k[len(prefix) :]: np.array(v) for k, v in state.items() if k.startswith(prefix)}
            )


def _miss(prediction: Values | None, actual: Values) -> float:
    if prediction is None:
        return np.inf
    return float(np.sqrt(sum(np.sum((prediction[n] - actual[n]) ** 2) for n in actual)))
