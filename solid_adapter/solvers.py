"""Static (load stepping + Newton), dynamic (generalized-alpha / Newmark + Newton) and modal
analyses of a :class:`~solid_adapter.shell.ShellModel`.

Generalized-alpha (Chung & Hulbert 1993) in its "generalized trapezoidal" nonlinear form:

    M a_{n+1-am} + C v_{n+1-af} + (1-af) f_int(x_{n+1}) + af f_int(x_n) = f_{n+1-af}

with Newmark updates for v, a and the parameters from rho_inf. rho_inf = 1 is the trapezoidal
rule (no numerical damping, energy conserving for linear systems).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from .shell import NDOF, Damping, MixedNewtonInternal, ShellModel, StrainRate

LoadFn = Callable[[float, NDArray, bool], tuple[NDArray, sp.spmatrix | None]]
VoltFn = Callable[[float], NDArray]


# A scaled Newton increment (plate lengths, radians) below this is round-off: a plate at rest
# in equilibrium (a square wave before its first switch) has a first increment of that size, and
# a tolerance relative to it could never be met
ROUND_OFF_INCREMENT = 1e-12


class SolverError(RuntimeError):
    """The structural solve failed (no convergence, NaN); the message says where and why."""


class NewtonNotConverged(SolverError):
    """Newton's iterations ran out before the increments met the tolerance (not a singular
    tangent, not NaN): the callers tell it by its type, not by its words."""


@dataclass(frozen=True)
class NewtonSettings:
    tolerance: float = 1e-8
    max_iterations: int = 30
    # dynamic steps: start from the last factorized tangent of an earlier step of the same size
    # (modified Newton) while it contracts, see KeptTangent
    reuse_tangent: bool = False


def dof_scale(model: ShellModel) -> NDArray:
    """Per-DOF scale making translations (in plate lengths) and rotations (rad) comparable."""
    s = np.ones((model.n_nodes, NDOF))
    s[:, :3] = 1.0 / model.layout.length_m
    return s.ravel()


def solve_linear(
    K: sp.spmatrix, r: NDArray, free: NDArray, rank_one: tuple[NDArray, NDArray] | None = None
) -> NDArray:
    """Solve (K + u w^T) dx = r on the free DOFs (Sherman-Morrison for the optional u w^T)."""
    return factorized(K, free, rank_one)(r)


def factorized(
    K: sp.spmatrix, free: NDArray, rank_one: tuple[NDArray, NDArray] | None = None
) -> Callable[[NDArray], NDArray]:
    """dx = (K + u w^T)^-1 r on the free DOFs (zero on the others), factored once."""
    lu = factorize(sp.csc_matrix(K[free][:, free]))
    if rank_one is not None:
        u, w = rank_one[0][free], rank_one[1][free]
        z = lu.solve(u)
        denominator = 1.0 + w @ z

    def solve(r: NDArray) -> NDArray:
        dx = np.zeros_like(r)
        y = lu.solve(r[free])
        if rank_one is not None:
            y = y - z * (w @ y) / denominator
        dx[free] = y
        return dx

    return solve


def factorize(A: sp.csc_matrix) -> spla.SuperLU:
    """Sparse LU of a tangent. Its pattern is symmetric and its diagonal strong (the inertia
    c_a M dominates in dynamics; K is positive definite on the free DOFs in statics), so
    SuperLU's symmetric mode - minimum degree on A^T + A, pivots on the diagonal - applies.
    With the dense fluid added-mass block of the coupled fish (2080 DOFs) it factors in
    0.018 s with 0.37 M entries instead of 0.12 s and 1.5 M with the default column ordering
    and partial pivoting (benchmarks/shell_coupled_solve.py). A vanishing or tiny pivot falls
    back to partial pivoting."""
    try:
        lu = spla.splu(
            A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )
        b = A @ np.ones(A.shape[0])
        y = lu.solve(b)
        if np.all(np.isfinite(y)) and np.linalg.norm(A @ y - b) <= 1e-6 * np.linalg.norm(b):
            return lu
    except RuntimeError:  # exactly singular pivot
        pass
    return spla.splu(A)


# residual(x, tangent) -> (r, K) or (r, K, (u, w)) with the tangent K + u w^T
# Line search only when the full step makes things far worse: an energy-directional criterion
# (|g(1)| < 0.5 |g(0)|) cuts the good first step of thin plates, whose membrane energy spikes.
LINE_SEARCH_RATIO = 1e6
ResidualFn = Callable[[NDArray, bool], tuple]
# Modified Newton (a tangent kept over several iterations) while every increment is at most
# this fraction of the one before: the error left after a converged increment is then at most
# a third of it
KEPT_TANGENT_RATE = 0.25
# full Newton keeps its tangent once an increment is this fraction of the solve's first: the
# thin plate's membrane-bending coupling changes the tangent a lot over the larger steps
KEEP_AFTER = 1e-3


@dataclass
class KeptTangent:
    """The last factorized tangent of an integrator's steps of one size ``dt``.

    A coupled window solves the structure 2-4 times with loads that differ by the coupling
    residual, each re-solve starting from the previous answer: the dynamic tangent (inertia
    over dt^2 plus the dense fluid added mass, then the stiffness) hardly changes, yet a full
    Newton iteration assembles and factors it anew (18 + 15 ms on the clamped fish, where a
    residual alone costs 4 ms). ``newton`` takes such a warm start's first iterations with
    this tangent, residuals only, and factors anew as soon as an increment shrinks less than
    KEPT_TANGENT_RATE.
    """

    dt: float = math.nan
    solve: Callable[[NDArray], NDArray] | None = None

    def for_step(self, dt: float) -> KeptTangent:
        if dt != self.dt:
            self.dt, self.solve = dt, None
        return self

    def forget(self) -> None:
        """Restart checkpoints call this, so that a resumed run iterates as the original."""
        self.dt, self.solve = math.nan, None


def newton(
    residual: ResidualFn,
    x0: NDArray,
    model: ShellModel,
    settings: NewtonSettings,
    where: str,
    reference: float = 0.0,
    free: NDArray | None = None,
    kept: KeptTangent | None = None,
    warm: bool = False,
) -> tuple[NDArray, int]:
    """Solve residual(x) = 0 on the free DOFs (``free``, default the model's).

    Converged when the scaled increment falls below tolerance times the larger of the first
    increment of this solve and ``reference`` (the scaled size of the motion the start x0
    already holds, so that a good start is not punished with a stricter test); residual norms
    stall near 1e-8 because of the membrane/bending stiffness ratio, see the notes. A secant
    line search on g(s) = dx . r(x + s dx) tames the first iterates of thin plates at large
    rotation, whose membrane energy makes plain Newton overshoot.

    With ``kept`` (modified Newton, see KeptTangent): a ``warm`` start (x0 near the answer)
    begins with the kept tangent; once an increment of full Newton is KEEP_AFTER of the
    solve's first it keeps the tangent it factored last; a kept tangent whose increment
    shrinks less than KEPT_TANGENT_RATE-fold (or is not finite) is replaced by a fresh one at
    the current iterate (or at the one before, if the increment grew).
    """
    iteration = _NewtonIteration(
        residual, model, settings, where, reference, model.free_dofs if free is None else free, kept
    )
    return iteration.run(x0, kept.solve if (kept is not None and warm) else None)


@dataclass
class _NewtonIteration:
    """One Newton solve (see :func:`newton`): the iterate, the tangent it solves with (fresh:
    factored at this iterate; else a kept one) and the increments so far."""

    residual: ResidualFn
    model: ShellModel
    settings: NewtonSettings
    where: str
    reference: float
    free: NDArray
    kept: KeptTangent | None = None
    x: NDArray = field(default_factory=lambda: np.zeros(0))
    x_before: NDArray = field(default_factory=lambda: np.zeros(0))
    solve: Callable[[NDArray], NDArray] | None = None
    r: NDArray | None = None
    K: sp.spmatrix | None = None
    update: list = field(default_factory=list)
    first: float | None = None  # the solve's first (scaled) increment
    previous: float = math.inf  # the last full increment
    size: float = math.inf  # the last step taken

    def run(self, x0: NDArray, solve: Callable[[NDArray], NDArray] | None) -> tuple[NDArray, int]:
        """From x0, with the tangent ``solve`` if one is kept: (x, iterations)."""
        scale = dof_scale(self.model)
        self.x, self.x_before, self.solve = x0.copy(), x0.copy(), solve
        it = 0
        while it < self.settings.max_iterations:
            it += 1
            fresh = self._tangent(it)
            r = self.r
            assert r is not None and self.solve is not None
            dx = self.solve(-r) if np.all(np.isfinite(r)) else np.full_like(r, np.nan)
            if not np.all(np.isfinite(dx)) and fresh:
                raise SolverError(
                    f"shell: singular tangent {self.where} (Newton iteration {it}); is the "
                    "plate clamped (boundary.head)?"
                )
            full = float(np.max(np.abs(dx * scale))) if np.all(np.isfinite(dx)) else math.inf
            if not fresh and (not math.isfinite(full) or full > KEPT_TANGENT_RATE * self.previous):
                self._drop_kept_tangent(full)
                continue
            if self._converged(full, full if self.first is None else self.first):
                # converged on the full step, which the line search takes once the increments
                # are this small: the residual and tangent at x + dx would go unused (about a
                # quarter of a coupled re-solve's assembly)
                return self.x + dx, it
            self.x_before = self.x.copy()
            if not fresh:
                self._kept_step(dx, full)
            elif self._full_step(dx, full):
                return self.x, it
        raise self._not_converged()

    def _converged(self, increment: float, first: float) -> bool:
        limit = self.settings.tolerance * max(first, self.reference, 1e-300)
        return increment <= limit or increment < ROUND_OFF_INCREMENT

    def _tangent(self, it: int) -> bool:
        """The residual at x and a tangent to solve with: a fresh one at x (the line search's,
        if it made one) unless a kept one goes on. Returns whether it is fresh."""
        if self.solve is not None:
            self.r = self.residual(self.x, False)[0] if self.r is None else self.r
            return False
        if self.K is None or self.r is None:
            self.r, self.K, *self.update = self.residual(self.x, True)
        if not np.all(np.isfinite(self.r)):
            raise SolverError(f"shell: NaN in the residual {self.where} (Newton iteration {it})")
        self.solve = factorized(self.K, self.free, self.update[0] if self.update else None)
        if self.kept is not None:
            self.kept.solve = self.solve
        return True

    def _drop_kept_tangent(self, full: float) -> None:
        """The kept tangent contracts too slowly: factor afresh, at the iterate before if its
        last step made things worse."""
        if full >= self.previous:
            self.x = self.x_before.copy()
        self.solve, self.r, self.K = None, None, None

    def _kept_step(self, dx: NDArray, full: float) -> None:
        """A modified-Newton step: the full increment, the tangent kept."""
        self.x, self.r = self.x + dx, None
        self.first = full if self.first is None else self.first
        self.previous = full

    def _full_step(self, dx: NDArray, full: float) -> bool:
        """A line-searched step with the fresh tangent; returns whether it converged. Once an
        increment is KEEP_AFTER of the first, a kept tangent goes on with this one."""
        keep = self.kept is not None and self.first is not None and full <= KEEP_AFTER * self.first
        assert self.r is not None
        step, self.r, self.K, self.update = _line_search(
            self.residual, self.x, dx, self.r, tangent=not keep
        )
        self.x += step * dx
        self.size = step * full
        self.first = self.size if self.first is None else self.first
        if self._converged(self.size, self.first):
            return True
        self.previous = full
        if not keep or step != 1.0:
            self.solve = None
            if self.K is None:  # a kept tangent was planned, but the line search cut the step
                self.r = None
        return False

    def _not_converged(self) -> NewtonNotConverged:
        limit = self.settings.max_iterations
        cure = (
            "reduce the load step (more analysis.load_steps)"
            if self.where.startswith("in load step")
            else "reduce the time step (more time.steps_per_period, or a smaller time.step_s)"
        )
        if limit < NewtonSettings.max_iterations:  # the limit was lowered below the default
            cure = (
                f"allow more iterations (analysis.max_newton_iterations, default "
                f"{NewtonSettings.max_iterations}) or {cure}"
            )
        return NewtonNotConverged(
            f"shell: Newton did not converge {self.where} in {limit} "
            f"iteration{'s' if limit != 1 else ''} (last scaled increment "
            f"{min(self.size, self.previous):.2e}); {cure}"
        )


def _line_search(
    residual: ResidualFn,
    x: NDArray,
    dx: NDArray,
    r0: NDArray,
    ratio: float = LINE_SEARCH_RATIO,
    max_trials: int = 6,
    tangent: bool = True,
) -> tuple[float, NDArray, sp.spmatrix | None, list]:
    """(step, and the residual, tangent and rank-one update at x + step dx; no tangent
    without ``tangent``)."""
    g0 = float(dx @ r0)
    r1, K1, *update = residual(x + dx, tangent)
    g1 = float(dx @ r1)
    if not np.isfinite(g1) or g0 >= 0 or abs(g1) <= ratio * abs(g0):
        return 1.0, r1, K1, update
    s_prev, g_prev, s, g = 0.0, g0, 1.0, g1
    for _ in range(max_trials):
        s_new = s - g * (s - s_prev) / (g - g_prev) if g != g_prev else 0.5 * s
        s_new = float(np.clip(s_new, 0.1 * s, 2.0 * s if g < 0 else s))
        s_prev, g_prev, s = s, g, s_new
        r_s = residual(x + s * dx, False)[0]
        g = float(dx @ r_s)
        if np.isfinite(g) and abs(g) <= ratio * abs(g0):
            break
    r_s, K_s, *update = residual(x + s * dx, tangent)
    return s, r_s, K_s, update


# --------------------------------------------------------------------------- static


def static_free_dofs(model: ShellModel) -> NDArray:
    """The DOFs a static solve moves. A clamped plate: its free DOFs. A free plate (free-free,
    ``boundary.head = "free"``) has six rigid-body modes and a singular stiffness; a
    statically determinate support holds them - all DOFs of the node nearest the plate's
    first tenth on the centre line and u_y of a second centre-line node behind it. The
    piezo load is internal and self-equilibrated, so the support carries no reaction and
    the deformation is the free plate's (up to a rigid motion). A plate on a hinge turns
    freely about it: u_z of a centre-line node a tenth of the plate behind the hinge holds that
    turn (hinge_gauge_node), reaction-free alike, so a static shape is seen from the hinge."""
    length = model.layout.length_m
    if model.layout.pin_x_m is not None:
        free = model.free_dofs.copy()
        free[hinge_gauge_node(model) * NDOF + 2] = False
        return free
    if model.fixed_dofs.any() or model.support is not None:
        return model.free_dofs
    first = model.mesh.nearest_node(0.1 * length, 0.0)
    second = model.mesh.nearest_node(0.5 * length, 0.0)
    free = model.free_dofs.copy()
    free[first * NDOF : (first + 1) * NDOF] = False
    free[second * NDOF + 1] = False
    return free


def hinge_gauge_node(model: ShellModel) -> int:
    """The centre-line node whose u_z holds a hinged plate's free turn in a static solve: a
    tenth of the plate behind the hinge (ahead of it where the hinge is near the tail)."""
    length, pin = model.layout.length_m, model.layout.pin_x_m
    assert pin is not None
    x = pin + 0.1 * length if pin + 0.1 * length <= length else pin - 0.1 * length
    return model.mesh.nearest_node(x, 0.0)


def solve_static(
    model: ShellModel,
    loads: LoadFn,
    volts: VoltFn,
    steps: int,
    settings: NewtonSettings = NewtonSettings(),
    callback: Callable[[int, float, NDArray], None] | None = None,
) -> NDArray:
    """Load stepping on lambda = k/steps; ``loads(lam, x, tangent)`` and ``volts(lam)`` scale
    with lambda. A free plate is held by a statically determinate support
    (:func:`static_free_dofs`)."""
    free = static_free_dofs(model)
    x = model.zero_state()
    for k in range(1, steps + 1):
        lam = k / steps

        internal = MixedNewtonInternal(model)

        def residual(xx: NDArray, tangent: bool, lam: float = lam, internal=internal):
            r, K = internal(xx, volts(lam), tangent)
            f, Kf = loads(lam, xx, tangent)
            return r - f, (K - Kf) if (K is not None and Kf is not None) else K

        x, _ = newton(residual, x, model, settings, f"in load step {k}/{steps}", free=free)
        if callback is not None:
            callback(k, lam, x)
    return x


def relax_fast_dofs(
    model: ShellModel,
    x: NDArray,
    rates: list[NDArray],
    volts: NDArray,
    load,
    settings: NewtonSettings,
) -> tuple[NDArray, list[NDArray]]:
    """x and its rates (velocity, acceleration) with the fast DOFs - the in-plane translations
    (membrane) and the rotations (tiny rotary inertia, held by the shear) - in quasi-static
    equilibrium with the normal translations, which are held: x_fast solves r_fast(x) = 0 and
    each rate's fast part is -K_ff^-1 K_fs (rate)_slow, that relation's derivative. A state
    built by linear superposition lacks the in-plane shortening of a bent plate; its membrane
    and shear forces would otherwise kick the stiff in-plane modes and the massless rotations.
    A free plate's in-plane rigid motion is held where statics hold it (static_free_dofs)."""
    fast = np.ones((model.n_nodes, NDOF), dtype=bool)
    fast[:, 2] = False
    fast = fast.ravel() & static_free_dofs(model)
    slow = ~fast & model.free_dofs
    x = x.copy()
    first = None
    for _ in range(settings.max_iterations):
        r, K, _ = model.internal(x, volts)
        r = r - load(x)
        dx = np.zeros_like(x)
        dx[fast] = spla.spsolve(sp.csc_matrix(K[fast][:, fast]), -r[fast])
        x += dx
        size = np.max(np.abs(dx))
        first = size if first is None else first
        if size <= settings.tolerance * max(first, 1e-300) or size < ROUND_OFF_INCREMENT:
            break
    K = model.internal(x, volts)[1]
    lu = factorize(sp.csc_matrix(K[fast][:, fast]))
    projected = []
    for rate in rates:
        rate = rate.copy()
        rate[fast] = -lu.solve(K[fast][:, slow] @ rate[slow])
        projected.append(rate)
    return x, projected


# --------------------------------------------------------------------------- dynamic


@dataclass(frozen=True)
class DynamicState:
    t: float
    x: NDArray
    v: NDArray
    a: NDArray
    f_int: NDArray  # internal force at (x, volts(t))
    f_ext: NDArray  # external force at (t, x)
    f_damp: NDArray  # damping force at (x, v)
    # With a fluid-consistent added-mass stencil (AddedMassAsForce.stencil): the
    # displacements at the previous step ends, most recent first, and the acceleration the
    # stencil gave at t (None: the state's own a stands for it)
    past: tuple[NDArray, ...] = ()
    a_fluid: NDArray | None = None

    def copy(self) -> DynamicState:
        return replace(
            self,
            x=self.x.copy(),
            v=self.v.copy(),
            a=self.a.copy(),
            f_int=self.f_int.copy(),
            f_ext=self.f_ext.copy(),
            f_damp=self.f_damp.copy(),
            past=tuple(p.copy() for p in self.past),
            a_fluid=None if self.a_fluid is None else self.a_fluid.copy(),
        )

    @property
    def added_mass_acceleration(self) -> NDArray:
        """The acceleration the added mass is weighted with (see AddedMassAsForce)."""
        return self.a if self.a_fluid is None else self.a_fluid


@dataclass(frozen=True)
class AlphaParameters:
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def generalized_alpha(cls, rho_inf: float) -> AlphaParameters:
        am = (2 * rho_inf - 1) / (rho_inf + 1)
        af = rho_inf / (rho_inf + 1)
        return cls(am, af, 0.25 * (1 - am + af) ** 2, 0.5 - am + af)

    @classmethod
    def newmark(cls) -> AlphaParameters:
        return cls(0.0, 0.0, 0.25, 0.5)


def make_integrator(
    kind: str,
    model: ShellModel,
    rho_inf: float = 1.0,
    damping: RayleighDamping | None = None,
    settings: NewtonSettings = NewtonSettings(),
) -> TimeIntegrator:
    """``kind``: "generalized-alpha", "newmark" or "energy-conserving"."""
    if kind == "energy-conserving":
        return EnergyConservingIntegrator(model, damping, settings)
    params = (
        AlphaParameters.newmark()
        if kind == "newmark"
        else AlphaParameters.generalized_alpha(rho_inf)
    )
    return GeneralizedAlphaIntegrator(model, params, damping, settings)


@dataclass(frozen=True)
class RayleighDamping:
    """f_d = alpha M v + beta K_mat(x) v: mass-proportional plus stiffness-proportional damping
    with the material tangent of the current state (a Kelvin-Voigt strain-rate damping). The
    reference stiffness K0 would not do: under large rotation K0 v of a rigidly turning part is
    not zero (linear strains are not invariant to finite rotation), and the plate's bending
    swing would be damped like a strain rate."""

    alpha: float
    beta: float

    def force(self, model: ShellModel, x: NDArray, v: NDArray) -> tuple[NDArray, sp.spmatrix]:
        """Damping force and its derivative with respect to v."""
        C = self.alpha * model.inertia
        if self.beta:
            C = C + self.beta * model.material_stiffness(x)
        return C @ v, C

    amplitude_dependent = False

    def linear(self, model: ShellModel, orbit=None) -> sp.spmatrix:
        """alpha M + beta K0, for linear (harmonic, modal) analyses about the flat plate."""
        K0 = model.internal(model.zero_state(), np.zeros(2))[1]
        return self.alpha * model.inertia + self.beta * K0


@dataclass(frozen=True)
class CombinedDamping:
    """The sum of damping models (Rayleigh, a fast fluid's drag): force and linear summed."""

    parts: tuple

    @property
    def amplitude_dependent(self) -> bool:
        return any(p.amplitude_dependent for p in self.parts)

    def force(self, model: ShellModel, x: NDArray, v: NDArray) -> tuple[NDArray, sp.spmatrix]:
        forces, tangents = zip(*(p.force(model, x, v) for p in self.parts), strict=True)
        return sum(forces), sum(tangents)

    def linear(self, model: ShellModel, orbit=None) -> sp.spmatrix:
        return sum(p.linear(model, orbit) for p in self.parts)


def split_strain_rate(damping: Damping | None) -> tuple[float, Damping | None]:
    """(beta of the stiffness-proportional (Kelvin-Voigt) part, the rest of the damping): the
    generalized-alpha step takes beta's part into the stresses (StrainRate), the rest as a
    force of the velocity."""
    if isinstance(damping, RayleighDamping):
        return damping.beta, (RayleighDamping(damping.alpha, 0.0) if damping.alpha else None)
    if isinstance(damping, CombinedDamping):
        split = [split_strain_rate(p) for p in damping.parts]
        rest = tuple(r for _, r in split if r is not None)
        other = CombinedDamping(rest) if len(rest) > 1 else (rest[0] if rest else None)
        return sum(b for b, _ in split), other
    return 0.0, damping


@dataclass(frozen=True)
class AddedMassAsForce:
    """The model's added mass M~ stands for part of a partitioned coupling's exchanged force
    g = f + M~ a (the *-am schemes): generalized-alpha weights it at alpha_f like that force,
    with the acceleration a_fluid = sum_j c_j x_(n+1-j) / dt^2 the fluid forms from the same
    displacements (``stencil``, Participant.acceleration_stencil; None: the integrator's own a).
    """

    stencil: tuple[float, ...] | None = None


class TimeIntegrator:
    """One implicit step at a time; the caller owns the state (so checkpoints are trivial).
    ``added_mass_as_force``: how the model's added mass enters (None: as inertia)."""

    def __init__(
        self,
        model: ShellModel,
        damping: RayleighDamping | None = None,
        settings: NewtonSettings = NewtonSettings(),
    ) -> None:
        self.model, self.damping, self.settings = model, damping, settings
        self.newton_iterations = 0
        self.kept_tangent = KeptTangent()  # used with settings.reuse_tangent
        self.added_mass_as_force: AddedMassAsForce | None = None

    def initial_state(
        self,
        t0: float,
        loads: LoadFn,
        volts: VoltFn,
        x0: NDArray | None = None,
        v0: NDArray | None = None,
        a0: NDArray | None = None,
        relax: bool = True,
        previous: tuple[NDArray, float] | None = None,
    ) -> DynamicState:
        """At rest in static equilibrium under the loads and voltages of t0 (the seed starts
        from zero; a voltage offset switched on at t = 0 would only add a start-up transient),
        unless x0 / v0 are given, with the acceleration from the equation of motion. With a0
        too (a linear periodic start), the fast DOFs of (x0, v0, a0) are first brought into
        quasi-static balance with the normal displacements (see relax_fast_dofs), unless
        ``relax`` is False: (x0, v0, a0) is a state this integrator reached (time.start_from),
        and ``previous`` = (the displacements one step before it, that step's length) gives
        the damping force that step ended with (start_damping_force)."""
        m = self.model
        if a0 is not None and not relax:
            assert x0 is not None and v0 is not None
            x, v = x0.copy(), v0.copy()
            f_int = m.internal(x, volts(t0), tangent=False)[0]
            f_ext = loads(t0, x, False)[0]
            f_damp = self.start_damping_force(x, v, volts(t0), previous)
            return DynamicState(t0, x, v, a0.copy(), f_int, f_ext, f_damp)
        if x0 is None:

            def load_fn(lam: float, x: NDArray, tangent: bool):
                f, K = loads(t0, x, tangent)
                return lam * f, (lam * K if K is not None else None)

            x0 = solve_static(m, load_fn, lambda lam: lam * volts(t0), 4, self.settings)
        x = x0.copy()
        v = np.zeros(m.ndof) if v0 is None else v0.copy()
        if a0 is not None:
            x, (v, a) = relax_fast_dofs(
                m, x, [v, a0], volts(t0), lambda xx: loads(t0, xx, False)[0], self.settings
            )
            f_int = m.internal(x, volts(t0), tangent=False)[0]
            f_ext = loads(t0, x, False)[0]
            return DynamicState(t0, x, v, a, f_int, f_ext, self._damping_force(x, v))
        f_int = m.internal(x, volts(t0), tangent=False)[0]
        f_ext, _ = loads(t0, x, False)
        f_damp = self._damping_force(x, v)
        a = np.zeros(m.ndof)
        free = m.free_dofs
        rhs = f_ext - f_int - f_damp
        a[free] = spla.spsolve(sp.csc_matrix(m.inertia[free][:, free]), rhs[free])
        return DynamicState(t0, x, v, a, f_int, f_ext, f_damp)

    def _damping_force(self, x: NDArray, v: NDArray) -> NDArray:
        if self.damping is None:
            return np.zeros_like(v)
        return self.damping.force(self.model, x, v)[0]

    def start_damping_force(
        self, x: NDArray, v: NDArray, V: NDArray, previous: tuple[NDArray, float] | None
    ) -> NDArray:
        """The damping force of a step that ended at (x, v) under the voltages V and started
        at ``previous`` = (displacements, step length); None: its value at (x, v)."""
        return self._damping_force(x, v)

    max_halvings = 4  # a window whose Newton fails is retried as 2, 4, ... 16 sub-steps

    def step(
        self,
        s: DynamicState,
        dt: float,
        loads: LoadFn,
        volts: VoltFn,
        depth: int = 0,
        guess: NDArray | None = None,
    ) -> DynamicState:
        """Advance by dt; if Newton fails, retry the same interval with halved sub-steps.
        ``guess``: a start for Newton at s.t + dt (a coupling iteration's previous answer)."""
        try:
            return self._step(s, dt, loads, volts, guess, stencil=depth == 0)
        except SolverError:
            if depth >= self.max_halvings:
                raise
            half = self.step(s, dt / 2, loads, volts, depth + 1)  # no guess: it was for dt
            end = self.step(half, dt / 2, loads, volts, depth + 1)
            if depth > 0:
                return end
            # sub-steps weigh the added mass with their own a (the stencil is for dt); the
            # window-level history goes on
            return replace(end, past=(s.x, *s.past)[: len(s.past)], a_fluid=None)

    def _step(
        self,
        s: DynamicState,
        dt: float,
        loads: LoadFn,
        volts: VoltFn,
        guess: NDArray | None,
        stencil: bool = True,
    ) -> DynamicState:
        raise NotImplementedError

    def kinetic_energy(self, s: DynamicState) -> float:
        return 0.5 * float(s.v @ (self.model.inertia @ s.v))


class GeneralizedAlphaIntegrator(TimeIntegrator):
    def __init__(
        self,
        model: ShellModel,
        params: AlphaParameters,
        damping: sp.spmatrix | None = None,
        settings: NewtonSettings = NewtonSettings(),
    ) -> None:
        super().__init__(model, damping, settings)
        self.p = params

    def _step(
        self,
        s: DynamicState,
        dt: float,
        loads: LoadFn,
        volts: VoltFn,
        guess: NDArray | None,
        stencil: bool = True,
    ) -> DynamicState:
        m, t1 = self.model, s.t + dt
        V1 = volts(t1)
        added = self._added_mass_term(s, dt, stencil)
        rate, other = self._strain_rate(s.x, dt)
        residual = self._residual(s, dt, loads, V1, added, rate, other)
        # start: the caller's guess, else x (a constant-acceleration start x + dt v + dt^2/2 a
        # took 6-7 Newton iterations instead of 4-5 on the coupled fish: the fast DOFs' a is
        # not smooth)
        x_pred = guess.copy() if guess is not None else s.x.copy()
        x_pred[m.fixed_dofs] = s.x[m.fixed_dofs]
        reference = float(np.max(np.abs((x_pred - s.x) * dof_scale(m))))
        kept = self.kept_tangent.for_step(dt) if self.settings.reuse_tangent else None
        x1, its = newton(
            residual,
            x_pred,
            m,
            self.settings,
            f"at t = {t1:.6g} s",
            reference,
            kept=kept,
            warm=guess is not None,
        )
        self.newton_iterations += its
        v1, a1 = self._kinematics(s, dt, x1)
        f_int = m.internal(x1, V1, tangent=False)[0]
        f_ext, _ = loads(t1, x1, False)
        f_damp = self._end_damping(x1, v1, V1, f_int, rate, other)
        state = DynamicState(t1, x1, v1, a1, f_int, f_ext, f_damp)
        return replace(state, past=s.past) if added is None else added.carried(state, s)

    def _strain_rate(
        self, x_before: NDArray, dt: float
    ) -> tuple[StrainRate | None, Damping | None]:
        """The Kelvin-Voigt damping of a step from x_before as stresses (see StrainRate), and
        the rest."""
        beta, other = split_strain_rate(self.damping)
        return (StrainRate(beta / dt, x_before) if beta else None), other

    def _end_damping(
        self,
        x: NDArray,
        v: NDArray,
        V: NDArray,
        f_int: NDArray,
        rate: StrainRate | None,
        other: Damping | None,
    ) -> NDArray:
        """A step's damping force at its end (x, v): the rest's, and the internal force with
        the strain rate's stresses less ``f_int``, the one without them."""
        m = self.model
        f = np.zeros_like(x) if other is None else other.force(m, x, v)[0]
        if rate is not None:
            f = f + (m.internal(x, V, False, rate=rate)[0] - f_int)
        return f

    def start_damping_force(
        self, x: NDArray, v: NDArray, V: NDArray, previous: tuple[NDArray, float] | None
    ) -> NDArray:
        """As a step computes it: the Kelvin-Voigt part is the strain rate over the step, not
        beta K v at its end. The first step weighs the start's damping force at alpha_f, so the
        end-point value kicked a started run (the beam in liquid swung 4.2 times as far)."""
        if previous is None:
            return self._damping_force(x, v)
        rate, other = self._strain_rate(*previous)
        # (the internal force only where the strain rate needs it)
        f_int = self.model.internal(x, V, False)[0] if rate is not None else np.zeros_like(x)
        return self._end_damping(x, v, V, f_int, rate, other)

    def _kinematics(self, s: DynamicState, dt: float, x1: NDArray) -> tuple[NDArray, NDArray]:
        """Newmark's (v1, a1) at x1."""
        p = self.p
        a1 = (x1 - s.x - dt * s.v) / (p.beta * dt * dt) - (1 - 2 * p.beta) / (2 * p.beta) * s.a
        v1 = s.v + dt * ((1 - p.gamma) * s.a + p.gamma * a1)
        return v1, a1

    def _added_mass_term(
        self, s: DynamicState, dt: float, stencil: bool
    ) -> _AddedMassAtAlphaF | _AddedMassOnStencil | None:
        """How the model's added mass enters beyond its inertia (None: it does not).
        Partitioned added-mass schemes: the coupling passes g = f + M~ a_k and the structure
        carries M~ in its inertia. Inertia is weighted at alpha_m, the force at alpha_f, so the
        two M~ terms would leave (alpha_f - alpha_m) M~ (a_k - a_k-1) behind - with M~ ~50
        plate masses a spurious term that made converged coupled runs oscillate and grow.
        Weighting M~ at alpha_f too makes the converged windows exactly M_s a + K u = f. ...
        and weighting it with the acceleration the fluid computes from the same displacements
        (a_fluid = c0 x1 + known; the step's own ``stencil``, not a sub-step's) keeps
        g = f + M~ a_fluid free of the difference between the two discrete accelerations,
        which explicit-am fed back window to window (a period-3 instability,
        docs/coupling.md)."""
        as_force, added = self.added_mass_as_force, self.model.added_mass
        if as_force is None or added is None:
            return None
        if as_force.stencil is None or not stencil:
            return _AddedMassAtAlphaF(added, self.p, s.a)
        coeffs = as_force.stencil
        past = _padded_past(s, len(coeffs) - 2, dt)
        known = sum(c * xk for c, xk in zip(coeffs[1:], (s.x, *past), strict=True)) / dt**2
        return _AddedMassOnStencil(
            added, self.p, s.a, coeffs[0] / dt**2, known, s.added_mass_acceleration, past
        )

    def _residual(
        self,
        s: DynamicState,
        dt: float,
        loads: LoadFn,
        V1: NDArray,
        added: _AddedMassAtAlphaF | _AddedMassOnStencil | None,
        rate: StrainRate | None,
        other: Damping | None,
    ) -> ResidualFn:
        """The generalized-alpha balance at x1 and its tangent; ``rate`` and ``other``: the
        step's damping (see _strain_rate)."""
        p, m, t1 = self.p, self.model, s.t + dt
        internal = MixedNewtonInternal(m, rate)
        c_a = (1 - p.alpha_m) / (p.beta * dt * dt)
        c_v = (1 - p.alpha_f) * p.gamma / (p.beta * dt)

        def residual(x1: NDArray, tangent: bool):
            v1, a1 = self._kinematics(s, dt, x1)
            f_int, K = internal(x1, V1, tangent)  # with the strain-rate damping, if any
            f_ext, Kf = loads(t1, x1, tangent)
            r = m.inertia @ ((1 - p.alpha_m) * a1 + p.alpha_m * s.a)
            if added is not None:
                r += added.force(x1, a1)
            r += (1 - p.alpha_f) * (f_int - f_ext) + p.alpha_f * (s.f_int - s.f_ext)
            if self.damping is not None:
                r += p.alpha_f * s.f_damp
            C = None
            if other is not None:
                f_d, C = other.force(m, x1, v1)
                r += (1 - p.alpha_f) * f_d
            if not tangent:
                return r, None
            assert K is not None
            T = c_a * m.inertia + (1 - p.alpha_f) * (K - Kf if Kf is not None else K)
            if added is not None:
                T = T + added.tangent(c_a, dt)
            if C is not None:
                T = T + c_v * C
            return r, T

        return residual


@dataclass(frozen=True)
class _AddedMassAtAlphaF:
    """M~ of an exchanged force g = f + M~ a weighted at alpha_f like that force, with the
    integrator's own a: M~ (alpha_m - alpha_f) (a1 - a0) beside its inertia term."""

    matrix: sp.spmatrix
    p: AlphaParameters
    a0: NDArray

    def force(self, x1: NDArray, a1: NDArray) -> NDArray:
        return self.matrix @ ((self.p.alpha_m - self.p.alpha_f) * (a1 - self.a0))

    def tangent(self, c_a: float, dt: float) -> sp.spmatrix:
        p = self.p
        return (p.alpha_m - p.alpha_f) / (p.beta * dt * dt) * self.matrix

    def carried(self, state: DynamicState, s: DynamicState) -> DynamicState:
        return replace(state, past=s.past)


@dataclass(frozen=True)
class _AddedMassOnStencil:
    """M~ ((1 - af) a_fluid1 + af a_fluid0) in place of its M~ a, a_fluid1 = c0 x1 + known the
    fluid's differentiation of the displacements (AddedMassAsForce.stencil); the state carries
    the displacements and a_fluid1 on."""

    matrix: sp.spmatrix
    p: AlphaParameters
    a0: NDArray
    c0: float
    known: NDArray | float  # the stencil's terms of the displacements before x1
    a_fluid0: NDArray
    past: tuple[NDArray, ...]

    def force(self, x1: NDArray, a1: NDArray) -> NDArray:
        p = self.p
        return self.matrix @ (
            (1 - p.alpha_f) * (self.c0 * x1 + self.known)
            + p.alpha_f * self.a_fluid0
            - (1 - p.alpha_m) * a1
            - p.alpha_m * self.a0
        )

    def tangent(self, c_a: float, dt: float) -> sp.spmatrix:
        return ((1 - self.p.alpha_f) * self.c0 - c_a) * self.matrix

    def carried(self, state: DynamicState, s: DynamicState) -> DynamicState:
        past = self.past
        a_fluid = self.c0 * state.x + self.known
        return replace(state, past=(s.x, *past)[: len(past)], a_fluid=a_fluid)


def _padded_past(s: DynamicState, n: int, dt: float) -> tuple[NDArray, ...]:
    """The n previous displacements; those not recorded (a start without the fluid's
    history) continue the state's velocity backwards (at rest: the state itself)."""
    past = list(s.past[:n])
    while len(past) < n:
        past.append(s.x - (len(past) + 1) * dt * s.v)
    return tuple(past)


class EnergyConservingIntegrator(TimeIntegrator):
    """Implicit midpoint rule with Gonzalez's discrete gradient of the strain energy:

        M (v1 - v0)/dt + C v_mid + f_alg(x0, x1) = (f0 + f1)/2,   x1 - x0 = dt v_mid,
        f_alg = grad Pi(x_mid) + [Pi(x1) - Pi(x0) - grad Pi(x_mid).dx] / (dx^T M dx) M dx,

    so f_alg . dx = Pi(x1) - Pi(x0) exactly and, undamped and unloaded, the energy
    1/2 v^T M v + Pi(x) is conserved to the Newton tolerance at any step size. The trapezoidal
    rule (generalized-alpha with rho_inf = 1) instead pumps energy into the stiff membrane
    modes once rotations are moderate (Kuhl & Crisfield 1999); this scheme cannot blow up.
    Newton uses the midpoint tangent and drops the small rank-2 derivative of the correction.
    """

    def _step(
        self,
        s: DynamicState,
        dt: float,
        loads: LoadFn,
        volts: VoltFn,
        guess: NDArray | None,
        stencil: bool = True,
    ) -> DynamicState:
        m = self.model  # starts from s.x whatever the guess (the midpoint tangent needs no help)
        t1 = s.t + dt
        V = volts(s.t + 0.5 * dt)
        pi0 = m.strain_energy(s.x, V)
        internal = MixedNewtonInternal(m)

        def residual(x1: NDArray, tangent: bool):
            dx = x1 - s.x
            f_mid, K_mid = internal(s.x + 0.5 * dx, V, tangent)
            Mdx = m.inertia @ dx
            denom = float(dx @ Mdx)
            f_alg, c, w = f_mid, 0.0, None
            if denom > 1e-300:
                f1 = m.internal(x1, V, tangent=False)[0]
                c = (m.strain_energy(x1, V) - pi0 - f_mid @ dx) / denom
                f_alg = f_mid + c * Mdx
                if tangent:  # dc/dx1
                    assert K_mid is not None
                    w = (f1 - f_mid - 0.5 * (K_mid.T @ dx) - 2.0 * c * Mdx) / denom
            f_ext, Kf = loads(t1, x1, tangent)
            r = (2.0 / dt**2) * (Mdx - dt * (m.inertia @ s.v)) + f_alg - 0.5 * (f_ext + s.f_ext)
            C = None
            if self.damping is not None:
                f_d, C = self.damping.force(m, s.x + 0.5 * dx, dx / dt)
                r += f_d
            if not tangent:
                return r, None
            assert K_mid is not None
            T = (2.0 / dt**2 + c) * m.inertia + 0.5 * K_mid
            if Kf is not None:
                T = T - 0.5 * Kf
            if C is not None:
                T = T + C / dt
            return (r, T, (Mdx, w)) if w is not None else (r, T)

        x1, its = newton(residual, s.x.copy(), m, self.settings, f"at t = {t1:.6g} s")
        self.newton_iterations += its
        v1 = 2.0 * (x1 - s.x) / dt - s.v
        f_int = m.internal(x1, volts(t1), tangent=False)[0]
        f_ext, _ = loads(t1, x1, False)
        return DynamicState(t1, x1, v1, (v1 - s.v) / dt, f_int, f_ext, self._damping_force(x1, v1))


# --------------------------------------------------------------------------- modal


@dataclass(frozen=True)
class ModalResult:
    frequencies_hz: NDArray
    shapes: NDArray  # (num_modes, ndof), mass-normalised
    rigid_modes: int
    rigid_shapes: NDArray | None = None  # (rigid_modes, ndof), inertia-normalised


def modal_analysis(
    model: ShellModel,
    num_modes: int,
    stiffness: sp.spmatrix | None = None,
    mass: sp.spmatrix | None = None,
) -> ModalResult:
    """Lowest elastic modes of K phi = w^2 M phi on the free DOFs (rigid modes dropped when the
    plate is unsupported). ``stiffness``/``mass`` default to the reference tangent and the
    model's inertia (structural mass plus any fluid added mass)."""
    K = stiffness if stiffness is not None else model.internal(model.zero_state(), np.zeros(2))[1]
    M = mass if mass is not None else model.inertia
    free = model.free_dofs
    rigid = model.layout.rigid_modes
    Kff, Mff = sp.csc_matrix(K[free][:, free]), sp.csc_matrix(M[free][:, free])
    k = num_modes + rigid
    # a fixed start vector: the same modes to the last digit from run to run
    v0 = np.random.default_rng(0).standard_normal(Kff.shape[0])
    # the shift below zero: K - sigma M must stay well conditioned on the rigid modes, where K
    # is singular. sigma = -1 is lost in K's scale on a small stiff plate (an 87 mm strip's
    # free-free modes came out as 1177 Hz and a spurious -963 Hz, against 553 Hz); a
    # millionth of the diagonals' ratio sits near the lowest elastic modes
    sigma = -1.0
    if rigid:
        sigma = -1e-6 * float(Kff.diagonal().mean() / Mff.diagonal().mean())
    w2, vec = spla.eigsh(Kff, k=k, M=Mff, sigma=sigma, which="LM", v0=v0)
    order = np.argsort(w2)
    w2, vec = w2[order], vec[:, order]
    shapes = np.zeros((len(w2), model.ndof))
    shapes[:, free] = vec.T
    return ModalResult(
        np.sqrt(np.maximum(w2[rigid:], 0.0)) / (2 * np.pi),
        shapes[rigid:],
        rigid,
        shapes[:rigid] if rigid else None,
    )


def mode_kind(model: ShellModel, shape: NDArray) -> str:
    """ "bending" (out-of-plane, symmetric across y), "torsion" (out-of-plane, antisymmetric)
    or "in-plane", from the mode's nodal translations."""
    u = shape.reshape(-1, NDOF)[:, :3]
    w, uv = np.abs(u[:, 2]).max(), np.abs(u[:, :2]).max()
    if uv > w:
        return "in-plane"
    mirror = np.array([model.mesh.nearest_node(x, -y) for x, y in model.mesh.nodes])
    sym = np.linalg.norm(u[:, 2] + u[mirror, 2])
    anti = np.linalg.norm(u[:, 2] - u[mirror, 2])
    return "bending" if sym >= anti else "torsion"
