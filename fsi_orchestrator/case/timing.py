"""The time windows a case asks for: one rule for the run loop, the fluid adapters and the
lead-in."""

from __future__ import annotations

from .schema import Case


def case_schedule(case: Case) -> tuple[float, int]:
    """(window size in s, number of windows) from ``[time]``: step_s/end_time_s when given,
    else periods x steps_per_period of the driving frequency."""
    t = case.time
    if t.step_s is not None and t.end_time_s is not None:
        return t.step_s, max(1, round(t.end_time_s / t.step_s))
    dt = 1.0 / (case.actuation.frequency_hz * t.steps_per_period)
    return dt, max(1, round(t.periods * t.steps_per_period))


def windows_per_period(case: Case) -> int:
    """Coupling windows in one period of the drive."""
    if case.time.step_s is not None:
        return max(1, round(1.0 / (case.actuation.frequency_hz * case.time.step_s)))
    return case.time.steps_per_period
