"""Typed settings of the coupling loop: one frozen dataclass per scheme, validated when built.

Each scheme's settings hold only what that scheme reads (its relaxation, its iteration limit,
its share of the added mass, ...); :class:`CouplingSettings` adds what every scheme shares (the
tolerance that measures a window, the predictor, the lead-in). The case's flat ``[coupling]``
keys map onto them with :func:`scheme_settings`, which passes each scheme the keys it reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .acceleration import Acceleration, make_acceleration
from .acceleration.base import check_relaxation
from .case.schema import CouplingScheme

RELAXATION = 0.5  # the default first relaxation of the plain schemes
# ... of iqn-ils-am: its inverse Jacobian starts as the identity (the preconditioned map is
# contractive)
ADDED_MASS_RELAXATION = 1.0


class CouplingSettingsError(ValueError):
    """A coupling setting has a value the loop cannot use."""


def _check(name: str, value: float, ok: bool, bound: str) -> None:
    if not ok:
        raise CouplingSettingsError(f"{name} must be {bound}, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class SchemeSettings:
    """What every scheme's settings answer; the subclasses below are the schemes."""

    scheme: ClassVar[CouplingScheme]

    def __post_init__(self) -> None:
        """Validation: each subclass checks its own fields, then calls super()."""

    def make_accelerator(self) -> Acceleration | None:
        """The acceleration that proposes each next iterate; None: one solve per window."""
        return None

    def iterates(self, window: int) -> bool:
        """Whether ``window`` is iterated to convergence."""
        return False


@dataclass(frozen=True, kw_only=True)
class Explicit(SchemeSettings):
    """One solve per window, the fluid's force passed on as it is."""

    scheme = CouplingScheme.EXPLICIT


@dataclass(frozen=True, kw_only=True)
class AddedMassShare(SchemeSettings):
    """The *-am schemes: share of the fast added mass moved to the structure's side. Any value
    leaves the converged solution unchanged; the best one makes g = f + M' a insensitive to the
    window's displacement. For OpenFOAM (backward ddt, plate moved to u_k) the force responds
    with about 3 M~/dt^2 (measured), the structure's a_k with 1/(beta dt^2) = 3.6/dt^2: M' = M~
    is within 20 % of the optimum (docs/coupling.md)."""

    added_mass_scale: float = 1.0

    def __post_init__(self) -> None:
        s = self.added_mass_scale
        _check("added_mass_scale", s, s > 0, "positive")
        super().__post_init__()


@dataclass(frozen=True, kw_only=True)
class ExplicitAddedMass(AddedMassShare):
    """One solve per window with the added-mass correction."""

    scheme = CouplingScheme.EXPLICIT_AM


@dataclass(frozen=True, kw_only=True)
class Iterated(SchemeSettings):
    """A scheme that solves a window again until it converges, at most ``max_iterations``
    times (a window that has not converged by then is accepted)."""

    max_iterations: int = 50

    def __post_init__(self) -> None:
        n = self.max_iterations
        _check("max_iterations", n, n >= 1, "at least 1")
        super().__post_init__()

    def iterates(self, window: int) -> bool:
        return True


@dataclass(frozen=True, kw_only=True)
class ConstantRelaxationScheme(Iterated):
    scheme = CouplingScheme.CONSTANT
    relaxation: float = RELAXATION

    def __post_init__(self) -> None:
        check_relaxation("relaxation", self.relaxation)
        super().__post_init__()

    def make_accelerator(self) -> Acceleration:
        return make_acceleration("constant", relaxation=self.relaxation)


@dataclass(frozen=True, kw_only=True)
class _FirstRelaxation(Iterated):
    """A scheme whose first iteration of a window is relaxed (then learns its own steps)."""

    initial_relaxation: float = RELAXATION

    def __post_init__(self) -> None:
        check_relaxation("initial_relaxation", self.initial_relaxation)
        super().__post_init__()

    def make_accelerator(self) -> Acceleration:
        name = self.scheme.accelerator
        assert name is not None  # an iterated scheme has one
        return make_acceleration(name, initial_relaxation=self.initial_relaxation)


@dataclass(frozen=True, kw_only=True)
class AitkenScheme(_FirstRelaxation):
    scheme = CouplingScheme.AITKEN


@dataclass(frozen=True, kw_only=True)
class IQNILSScheme(_FirstRelaxation):
    """IQN-ILS reusing the secant information of ``reuse_windows`` past windows."""

    scheme = CouplingScheme.IQN_ILS
    reuse_windows: int = 8

    def __post_init__(self) -> None:
        n = self.reuse_windows
        _check("reuse_windows", n, n >= 0, "at least 0")
        super().__post_init__()

    def make_accelerator(self) -> Acceleration:
        return make_acceleration(
            "iqn-ils", initial_relaxation=self.initial_relaxation, reuse_windows=self.reuse_windows
        )


@dataclass(frozen=True, kw_only=True)
class IQNIMVJScheme(_FirstRelaxation):
    """IQN-IMVJ without the added-mass preconditioning (participants without a fast model)."""

    scheme = CouplingScheme.IQN_IMVJ


@dataclass(frozen=True, kw_only=True)
class IQNILSAddedMass(_FirstRelaxation, AddedMassShare):
    """IQN-IMVJ on the added-mass preconditioned map; its inverse Jacobian starts as
    ``initial_relaxation`` times the identity (1: the preconditioned map is contractive).
    Windows before ``explicit_windows`` take one solve each, as explicit-am."""

    scheme = CouplingScheme.IQN_ILS_AM
    initial_relaxation: float = ADDED_MASS_RELAXATION
    explicit_windows: int = 0

    def __post_init__(self) -> None:
        n = self.explicit_windows
        _check("explicit_windows", n, n >= 0, "at least 0")
        super().__post_init__()

    def iterates(self, window: int) -> bool:
        return window >= self.explicit_windows


def scheme_settings(
    scheme: CouplingScheme,
    *,
    relaxation: float | None = None,
    max_iterations: int = 50,
    reuse_windows: int = 8,
    added_mass_scale: float = 1.0,
    explicit_windows: int = 0,
) -> SchemeSettings:
    """The flat ``[coupling]`` keys on ``scheme``'s settings: each scheme takes the keys it
    reads and ignores the others (``relaxation`` None: the scheme's default)."""
    if scheme is CouplingScheme.EXPLICIT:
        return Explicit()
    if scheme is CouplingScheme.EXPLICIT_AM:
        return ExplicitAddedMass(added_mass_scale=added_mass_scale)
    if scheme is CouplingScheme.IQN_ILS_AM:
        return IQNILSAddedMass(
            max_iterations=max_iterations,
            initial_relaxation=ADDED_MASS_RELAXATION if relaxation is None else relaxation,
            added_mass_scale=added_mass_scale,
            explicit_windows=explicit_windows,
        )
    r = RELAXATION if relaxation is None else relaxation
    if scheme is CouplingScheme.CONSTANT:
        return ConstantRelaxationScheme(max_iterations=max_iterations, relaxation=r)
    if scheme is CouplingScheme.IQN_ILS:
        return IQNILSScheme(
            max_iterations=max_iterations, initial_relaxation=r, reuse_windows=reuse_windows
        )
    kind = AitkenScheme if scheme is CouplingScheme.AITKEN else IQNIMVJScheme
    return kind(max_iterations=max_iterations, initial_relaxation=r)


@dataclass(frozen=True, kw_only=True)
class CouplingSettings:
    """The scheme's own settings and what every scheme shares."""

    scheme_settings: SchemeSettings
    tolerance_rel: float = 1e-4  # of the window's residual (explicit schemes: reported)
    predictor: str = "linear"
    period_s: float = 0.0  # the driving period, for the periodic predictor
    # A fluid with memory (CFD) starts at rest while the structure may start on its periodic
    # orbit: before window 0 the fluid alone follows that orbit, ramped up from rest, for this
    # many windows (see Coupling.lead_in).
    lead_in_windows: int = 0
    lead_in_omega: float = 0.0
    # periods of that lead-in without a start correction (the first ramped up): a start on a
    # recorded CFD orbit takes two, so that the flow at t = 0 is the periodic one
    lead_in_periods: int = 1
    # the fluid starts displaced on the orbit, with the flow of the run that recorded it: the
    # lead-in is one period, not ramped (enough to seed the predictor)
    lead_in_displaced: bool = False

    def __post_init__(self) -> None:
        tol = self.tolerance_rel
        _check("tolerance_rel", tol, 0 < tol < 1, "in (0, 1)")
        for name, value in (
            ("period_s", self.period_s),
            ("lead_in_windows", self.lead_in_windows),
            ("lead_in_omega", self.lead_in_omega),
        ):
            _check(name, value, value >= 0, "at least 0")
        _check("lead_in_periods", self.lead_in_periods, self.lead_in_periods >= 1, "at least 1")

    @property
    def scheme(self) -> CouplingScheme:
        return self.scheme_settings.scheme

    @property
    def implicit(self) -> bool:
        return self.scheme.iterates

    def iterates(self, window: int) -> bool:
        """Whether ``window`` is iterated to convergence."""
        return self.scheme_settings.iterates(window)

    @property
    def uses_added_mass(self) -> bool:
        return self.scheme.uses_added_mass

    @property
    def added_mass_scale(self) -> float | None:
        """The *-am schemes' share of the fast added mass; None for the others."""
        s = self.scheme_settings
        return s.added_mass_scale if isinstance(s, AddedMassShare) else None

    @property
    def max_iterations(self) -> int:
        s = self.scheme_settings
        return s.max_iterations if isinstance(s, Iterated) else 1
