"""The periodic state estimated from a run's period-to-period sequence, with its uncertainty.

A start-up relaxes to the periodic state as the damped free modes decay: the per-period
figures (tail amplitude, mean thrust) approach their limit with a contracting difference,
often alternating, as the beat with the wet first mode crosses its mean. Where the last two
differences contract (``|r| < 1``), the geometric (Aitken) limit is the estimate; otherwise the
mean of the last two periods, which brackets an alternating sequence's limit. The uncertainty
is the larger of the last period's change and the extrapolation's own step: a start-up's
sequence is not exactly geometric.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

# a contraction faster than this is taken at face value (|r| close to 1 extrapolates wildly)
MAX_RATIO = 0.8


@dataclass(frozen=True)
class PeriodicEstimate:
    value: float  # the estimated periodic value
    uncertainty: float  # absolute; inf with one period only
    periods: int  # how many complete periods it was estimated from

    def is_periodic(self, tolerance: float) -> bool:
        """Known to ``tolerance`` relative to the value."""
        return self.periods >= 2 and self.uncertainty <= tolerance * abs(self.value)


def estimate(values: Sequence[float]) -> PeriodicEstimate | None:
    """The periodic limit of a per-period sequence (oldest first); None when empty."""
    x = [float(v) for v in values]
    if not x:
        return None
    if len(x) == 1 or not all(math.isfinite(v) for v in x[-3:]):
        return PeriodicEstimate(x[-1], math.inf, len(x))
    last = x[-1] - x[-2]
    if len(x) >= 3:
        before = x[-2] - x[-3]
        ratio = last / before if before else 0.0
        if abs(ratio) <= MAX_RATIO:
            step = last * ratio / (1.0 - ratio)
            return PeriodicEstimate(x[-1] + step, max(abs(step), abs(last)), len(x))
    # two periods say nothing of the contraction: twice the change
    spread = abs(last) if len(x) >= 3 else 2.0 * abs(last)
    return PeriodicEstimate(0.5 * (x[-1] + x[-2]), spread, len(x))


def summary_fields(
    per_period: dict[str, tuple[Sequence[float], str]], tolerance: float
) -> dict[str, object]:
    """``--json`` fields: for each figure ``name`` with its per-period values and unit,
    ``<name>_periodic_<unit>`` and ``<name>_periodic_uncertainty_<unit>``; ``periodic`` is
    whether every figure is known to ``tolerance``."""
    fields: dict[str, object] = {}
    known = []
    for name, (values, unit) in per_period.items():
        found = estimate(values)
        if found is None:
            continue
        fields[f"{name}_periodic_{unit}"] = found.value
        fields[f"{name}_periodic_uncertainty_{unit}"] = found.uncertainty
        known.append(found.is_periodic(tolerance))
    fields["periodic"] = bool(known) and all(known)
    return fields
