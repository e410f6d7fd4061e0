"""The coupling's failure handling: an iterate a solver failed on is retried closer to the last
good one, and a failure that persists, or a force that grows tenfold window after window, is
reported as what it almost always is here, a diverging coupling (with a hint on the cure)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .case.schema import CouplingScheme
from .convergence import CouplingDivergenceError
from .participant import ParticipantSetupError

MAX_RETRIES = 3  # halvings of an iterate a solver failed on
Iterate = NDArray[np.float64]


class FailureHandling:
    """Retries and divergence detection of one coupling (scheme ``scheme``, iterating
    ``field``). ``norms``: the exchanged force's norm at the last window ends (checkpointed);
    ``retries``: the retried solves of the current window."""

    def __init__(self, scheme: CouplingScheme, field: str) -> None:
        self.scheme, self.field = scheme, field
        self.norms: list[float] = []
        self.retries = 0

    def guarded(
        self,
        gauss_seidel: Callable[[Iterate], Iterate],
        x: Iterate,
        x_good: Iterate | None,
        restore: Callable[[], None],
        where: tuple[int, int],
    ) -> tuple[Iterate, Iterate]:
        """One Gauss-Seidel pass, returning (the iterate used, x~). A quasi-Newton step can
        overshoot so far that a solver fails on it (a CFD step at Courant 8): the iterate is
        then pulled halfway back toward the last accepted one, up to MAX_RETRIES times, from
        the window's checkpoints (``restore``). A solver that still fails is reported as a
        diverging coupling at ``where`` (window, iteration)."""
        for attempt in range(MAX_RETRIES + 1):
            try:
                return x, gauss_seidel(x)
            except (RuntimeError, FloatingPointError) as err:
                if isinstance(err, CouplingDivergenceError | ParticipantSetupError):
                    raise
                if x_good is None or attempt == MAX_RETRIES:
                    raise CouplingDivergenceError(
                        f"a solver failed ({err}) {self.hint()}",
                        field=self.field,
                        window=where[0],
                        iteration=where[1],
                    ) from err
                self.retries += 1
                x = x_good + 0.5 * (x - x_good)
                restore()
        raise AssertionError("unreachable")

    def check_growth(self, norm: float, window: int, iteration: int) -> None:
        """Window-to-window divergence (explicit schemes have no iterations to watch): the
        force grew tenfold in each of three consecutive windows."""
        self.norms = (self.norms + [norm])[-4:]
        n = self.norms
        if len(n) == 4 and n[0] > 0 and all(b > 10 * a for a, b in zip(n, n[1:], strict=False)):
            raise CouplingDivergenceError(
                f"the interface force grew from {n[0]:.3g} to {n[-1]:.3g} N over three windows "
                f"{self.hint()}",
                field=self.field,
                window=window,
                iteration=iteration,
            )

    def hint(self) -> str:
        return f'(coupling.scheme = "{self.scheme}"). The liquid is far denser than ' + (
            "the plate: a smaller coupling.relaxation or a shorter time step may help."
            if self.scheme.uses_added_mass
            else 'the plate: use "iqn-ils-am" or "explicit-am", or a smaller coupling.relaxation.'
        )
