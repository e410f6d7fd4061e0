"""Time-delayed feedback toward the periodic state (Pyragas 1992, Phys. Lett. A 170, 421).

    f = -g M (v(t) - v(t - T))

with T the drive's period, M the structure's inertia (with the liquid's added mass where the
model carries it) and g a rate (1/s). On a T-periodic motion the force is exactly zero, so the
periodic state is the one without it; away from it the force damps whatever does not repeat
from period to period. A free motion at frequency f_m gets the damping ratio
g (1 - cos(2 pi f_m T)) / (4 pi f_m) (small g): the most at f_m = (k + 1/2) / T, none at the
drive's harmonics. The coupled start-up's slow beat (docs/coupling.md, "Periodic state") is
such a motion.

A fish whose two actuators get the same waveform in opposite senses is symmetric in space and
time: its periodic motion mirrored through the plate's plane is the motion half a period later,
v(t) = S v(t - T/2) with S the mirror (u_z, theta_1, theta_2 change sign). ``mirror`` adds the
force -g M (v(t) - S v(t - T/2)) (half-period delayed feedback: Nakajima and Ueda 1998, Phys.
Rev. E 58, 1757). It is zero on that orbit too, and it damps a free lateral motion at f_m with
g (1 + cos(pi f_m T)) / (4 pi f_m): the most at the drive's even harmonics (a mode near twice the
drive, a drifting mean position), where the period's own term damps nothing.

The velocities one period back are the structure's accepted window starts, recorded by the
participant. A run started on a periodic orbit takes the period before t = 0 from that orbit;
a start from rest has no reference, and no force, until a period (the mirrored term: half a
period) has been recorded, none of it inside a ramp. A window retried in sub-steps (a failed
Newton) uses the window end's references in each of them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from .shell import ShellModel


class PeriodicFeedback:
    """A damping part (``force``, ``linear`` like solvers.RayleighDamping) whose reference
    velocity is set per step by the participant (``prepare``)."""

    amplitude_dependent = False

    def __init__(
        self,
        gain_per_s: float,
        steps_per_period: int,
        first_step: int = 0,
        mirror: NDArray | None = None,
    ) -> None:
        """``first_step``: the earliest step a reference may come from (a ramped drive's ramp
        is no period to come back to). ``mirror``: the signs of S per unknown, for the
        half-period term (needs an even steps_per_period)."""
        if not (np.isfinite(gain_per_s) and gain_per_s >= 0):
            raise ValueError(f"the feedback gain must be finite and >= 0, got {gain_per_s!r}")
        if steps_per_period < 1:
            raise ValueError(f"steps_per_period must be >= 1, got {steps_per_period!r}")
        if mirror is not None and steps_per_period % 2:
            raise ValueError(
                f"the mirrored term needs an even steps_per_period, got {steps_per_period}"
            )
        self.gain = float(gain_per_s)
        self.steps_per_period = int(steps_per_period)
        self.first_step = int(first_step)
        self.mirror = None if mirror is None else np.asarray(mirror, dtype=float)
        # the step being solved's references for its end: v(t - T), and S v(t - T/2)
        self.references: list[NDArray] = []
        self._history: dict[int, NDArray] = {}  # step index -> velocity at its start

    def seed(self, velocity_at_step: Callable[[int], NDArray], first: int = 0) -> None:
        """Take the period before step ``first`` from a periodic orbit (the run's start
        orbit): step k -> the velocity at the start of step k, for the N steps before
        ``first``. Kept in the checkpoint like recorded steps. The reference is then the one
        for the start state, one period before ``first`` (its damping force)."""
        self.forget()
        for k in range(first - self.steps_per_period, first):
            self._history[k] = np.array(velocity_at_step(k), dtype=float)
        self.references = self._references_for(first)

    def prepare(self, step: int, v_start: NDArray) -> None:
        """Before solving step ``step`` (from t_step to t_step+1): record the velocity at its
        start (a repeated solve of the same step records the same state) and take the
        references for its end: one period back and, with ``mirror``, the mirror image half a
        period back (each left out where it was not recorded or seeded, or lies in a ramp)."""
        self._history[step] = v_start.copy()
        for old in [k for k in self._history if k < step - self.steps_per_period]:
            del self._history[old]
        self.references = self._references_for(step + 1)

    def _references_for(self, step: int) -> list[NDArray]:
        """The recorded references for the state at the start of ``step``, none from a ramp:
        v one period back and, with ``mirror``, S v half a period back."""
        terms: list[tuple[int, NDArray | None]] = [(self.steps_per_period, None)]
        if self.mirror is not None:
            terms.append((self.steps_per_period // 2, self.mirror))
        out = []
        for delay, sign in terms:
            back = step - delay
            v = None if 0 <= back < self.first_step else self._history.get(back)
            if v is not None:
                out.append(v if sign is None else sign * v)
        return out

    def history(self) -> tuple[NDArray, NDArray]:
        """(step indices, velocities at their starts) recorded so far, for a checkpoint."""
        steps = sorted(self._history)
        if not steps:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 0))
        return np.array(steps, dtype=np.int64), np.array([self._history[k] for k in steps])

    def restore(self, steps: NDArray, velocities: NDArray) -> None:
        """Take back a checkpoint's history(), so a resumed run feeds back as the original."""
        self.forget()
        pairs = zip(steps, velocities, strict=True)
        self._history = {int(k): np.array(v, dtype=float) for k, v in pairs}

    def forget(self) -> None:
        """Drop the history (a resumed or restarted run records a period again)."""
        self._history.clear()
        self.references = []

    def force(self, model: ShellModel, x: NDArray, v: NDArray) -> tuple[NDArray, sp.spmatrix]:
        if not self.references or self.gain == 0:
            return np.zeros_like(v), sp.csr_matrix((v.size, v.size))
        C = self.gain * model.inertia
        return C @ (len(self.references) * v - sum(self.references)), len(self.references) * C

    def linear(self, model: ShellModel, orbit=None) -> sp.spmatrix:
        """Zero: a periodic response does not feel it."""
        return sp.csr_matrix((model.ndof, model.ndof))


def mirror_signs(model: ShellModel) -> NDArray:
    """S per unknown: the mirror through the plate's plane flips u_z and the rotation vector
    (u_x, u_y, u_z, theta_1, theta_2 -> u_x, u_y, -u_z, -theta_1, -theta_2)."""
    return np.tile([1.0, 1.0, -1.0, -1.0, -1.0], model.n_nodes)


def mirror_asymmetry(model: ShellModel, volts: NDArray, seed: int = 0) -> float:
    """How far the shell is from mirror symmetry with its actuators swapped: the largest
    relative difference of S r(x, V) and r(S x, swap V) for the drive alone (x = 0) and for a
    random state of small rotations without it, and of S M S and M (0 for a laminate and
    masses symmetric about its mid-plane with its two actuators alike)."""
    S = mirror_signs(model)
    x = 1e-3 * np.random.default_rng(seed).standard_normal(model.ndof) * model.free_dofs
    volts = np.asarray(volts, dtype=float)
    out = 0.0
    for state, v in ((np.zeros(model.ndof), volts), (x, np.zeros(2))):
        r = model.internal(state, v, tangent=False)[0][model.free_dofs]
        r_mirror = model.internal(S * state, v[::-1], tangent=False)[0][model.free_dofs]
        size = np.linalg.norm(r)
        if size > 0:
            out = max(out, float(np.linalg.norm(S[model.free_dofs] * r - r_mirror) / size))
    M = model.inertia  # with the liquid's added mass where the model carries it
    if M.nnz:
        mirrored = sp.diags(S) @ M @ sp.diags(S) - M
        out = max(out, float(abs(mirrored).max() / abs(M).max()))
    return out
