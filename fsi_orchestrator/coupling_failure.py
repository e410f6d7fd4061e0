"""The coupling's failure handling: an iterate a solver failed on is retried closer to the last
good one, and a failure that persists, or a force that grows tenfold window after window, is
reported as what it almost always is here, a diverging coupling (with a hint on the cure). So
is a force that flips sign from window to window and grows: the added-mass instability of a
window that is not iterated (explicit-am at 17-19 Hz ran into it and on to a floating point
exception in the fluid)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .case.schema import CouplingScheme
from .convergence import CouplingDivergenceError
from .participant import ParticipantSetupError

MAX_RETRIES = 3  # halvings of an iterate a solver failed on
# a force that points against the last window's this many windows in a row, and grew by
# FLIP_GROWTH over them, is unstable (the start-up's ringing flips too, but decays by ~0.6 a
# window)
FLIP_WINDOWS = 5
FLIP_GROWTH = 2.0
Iterate = NDArray[np.float64]


class FailureHandling:
    """Retries and divergence detection of one coupling (scheme ``scheme``, iterating
    ``field``). ``norms``: the exchanged force's norm at the last window ends, ``turns`` the
    cosines between consecutive ones, ``last`` the last one (all checkpointed); ``retries``:
    the retried solves of the current window."""

    def __init__(self, scheme: CouplingScheme, field: str) -> None:
        self.scheme, self.field = scheme, field
        self.norms: list[float] = []
        self.turns: list[float] = []
        self.last: Iterate | None = None
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

    def check_growth(
        self, force: Iterate, window: int, iteration: int, *, iterated: bool = True
    ) -> None:
        """Window-to-window divergence (explicit schemes have no iterations to watch): the
        window-end force grew tenfold in each of three consecutive windows, or, in windows that
        are not iterated, flipped sign FLIP_WINDOWS times in a row while growing FLIP_GROWTH
        times."""
        norm = float(np.linalg.norm(force))
        if self.last is not None:
            scale = norm * float(np.linalg.norm(self.last))
            turn = float(np.vdot(force, self.last)) / scale if scale > 0 else 1.0
            self.turns = (self.turns + [turn])[-FLIP_WINDOWS:]
        self.last = np.array(force, dtype=float, copy=True)
        self.norms = (self.norms + [norm])[-(FLIP_WINDOWS + 1) :]
        n = self.norms[-4:]
        if len(n) == 4 and n[0] > 0 and all(b > 10 * a for a, b in zip(n, n[1:], strict=False)):
            raise CouplingDivergenceError(
                f"the interface force grew from {n[0]:.3g} to {n[-1]:.3g} N over three windows "
                f"{self.hint()}",
                field=self.field,
                window=window,
                iteration=iteration,
            )
        first = self.norms[0]
        if (
            not iterated
            and len(self.turns) == FLIP_WINDOWS
            and len(self.norms) == FLIP_WINDOWS + 1
            and all(t < 0 for t in self.turns)
            and first > 0
            and norm >= FLIP_GROWTH * first
        ):
            raise CouplingDivergenceError(
                f"the interface force flipped sign in each of the last {FLIP_WINDOWS} windows "
                f"and grew from {first:.3g} to {norm:.3g} N: one fluid solve per window is "
                f'unstable here (coupling.scheme = "{self.scheme}"); iterate the windows '
                '(coupling.scheme = "iqn-ils-am" with coupling.explicit_periods = 0 and '
                "coupling.explicit_until_periodic = false), or take fewer "
                "time.steps_per_period: longer windows steady one solve per window, shorter "
                "ones unsettle it",
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
