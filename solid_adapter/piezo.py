"""Actuator voltage signals (seed Sec. 3.6, Figs. 3.33-3.37).

Each MFC swings between its [min, max]; the right actuator is driven in anti-phase ("opposite
sense") to the left one, so equal ranges bend the plate symmetrically and unequal ranges (e.g.
left -500..1500 V, right -500..500 V) make it swing more to one side (turning).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import Waveform


@dataclass(frozen=True, kw_only=True)
class DriveSignal:
    frequency_hz: float
    waveform: Waveform
    left_volts: tuple[float, float]
    right_volts: tuple[float, float]
    ramp_periods: float = 0.0
    # share of the mean voltage's induced strain the laminate holds in the periodic state
    # (actuation.mean_strain_transfer): the rest is taken up by creep of the bond and matrix
    mean_transfer: float = 1.0

    @classmethod
    def from_case(cls, case: Case) -> DriveSignal:
        a = case.actuation
        return cls(
            frequency_hz=a.frequency_hz,
            waveform=a.waveform,
            left_volts=(a.left_volts[0], a.left_volts[1]),  # two entries (the loader checks)
            right_volts=(a.right_volts[0], a.right_volts[1]),
            ramp_periods=a.ramp_periods,
            mean_transfer=a.mean_strain_transfer,
        )

    @property
    def mean(self) -> NDArray:
        """[V_left, V_right] of the mean the laminate holds (mean_transfer of the drive's)."""
        return self.mean_transfer * np.array([sum(self.left_volts) / 2, sum(self.right_volts) / 2])

    def shape(self, t: float) -> float:
        """Unit waveform in [-1, 1]: sin(2 pi f t) or its sign."""
        if self.waveform is Waveform.SINE:
            return float(np.sin(2 * np.pi * self.frequency_hz * t))
        phase = round(self.frequency_hz * t, 9) % 1.0  # exact half periods despite round-off
        return 1.0 if phase < 0.5 else -1.0

    def volts(self, t: float) -> NDArray:
        """[V_left, V_right] at time t."""
        w = self.shape(t)
        ramp = 1.0
        if self.ramp_periods > 0:
            ramp = min(1.0, t * self.frequency_hz / self.ramp_periods)
        out = []
        for (lo, hi), sign, mid in zip(
            (self.left_volts, self.right_volts), (1.0, -1.0), self.mean, strict=True
        ):
            out.append(ramp * (mid + sign * (hi - lo) / 2 * w))
        return np.array(out)

    @property
    def period_s(self) -> float:
        return 1.0 / self.frequency_hz
