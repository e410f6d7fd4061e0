"""Constant under-relaxation, the stand-in for ANSYS MFX's relaxation of exchanged data.

    x^{k+1} = omega * x~^k + (1 - omega) * x^k,   0 < omega <= 1

(preCICE ``ConstantRelaxationAcceleration``). For a linear map ``H(x) = A x + b`` it converges
iff every eigenvalue ``lambda`` of ``A`` satisfies ``|1 - omega (1 - lambda)| < 1``; with a
strong added-mass effect (``lambda`` far below -1) that forces ``omega`` near ``1 / |lambda|``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .base import Acceleration, apply_relaxation, check_relaxation


@dataclass(frozen=True, kw_only=True)
class ConstantSettings:
    relaxation: float

    def __post_init__(self) -> None:
        check_relaxation("relaxation", self.relaxation)


class ConstantRelaxation(Acceleration):
    """Fixed relaxation factor in every iteration; it keeps no state."""

    name = "constant"

    def __init__(self, settings: ConstantSettings) -> None:
        super().__init__()
        self.settings = settings

    def _perform(self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]) -> NDArray[np.float64]:
        return apply_relaxation(self.settings.relaxation, x, x_tilde)

    def log_line(self) -> str:
        return f"constant relaxation: omega = {self.settings.relaxation:.4g}"
