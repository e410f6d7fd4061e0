"""The layer every coupling acceleration shares (preCICE ``src/acceleration/Acceleration.hpp``).

Within a time window the coupling loop solves both participants with the interface data
``x^k`` and obtains the fixed-point output ``x~^k = H(x^k)``; the residual is
``r^k = x~^k - x^k``. An :class:`Acceleration` turns the history of ``(x^k, x~^k)`` into the
next input ``x^{k+1}``:

* ``initialize(fields)``: fix the names and shapes of the accelerated fields;
* ``perform(x, x_tilde) -> x_next``: one coupling iteration (called only when not converged);
* ``iterations_converged(x, x_tilde)``: end of window; keeps what is reused, resets the rest.

Data cross this boundary as ``{name: array}`` mappings (e.g. ``{"force": f}`` with ``f`` of
shape ``(n, 3)``); inside, the fields are concatenated into one flat vector
(:class:`FieldLayout`). Fields of different units are weighted per field
(:class:`FieldScaling`, preCICE's preconditioners) wherever norms or inner products mix them.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType

import numpy as np
from numpy.typing import NDArray

Fields = Mapping[str, NDArray[np.float64]]
State = dict[str, NDArray[np.float64]]


class AccelerationSettingsError(ValueError):
    """A coupling-acceleration setting has a value the scheme cannot use."""


class AccelerationStateError(ValueError):
    """Data given to an accelerator (fields, restored state) do not fit its layout."""


def check_relaxation(name: str, value: float) -> None:
    """Raise unless ``0 < value <= 1`` (preCICE's bound on relaxation factors)."""
    if isinstance(value, bool) or not (isinstance(value, int | float) and 0.0 < value <= 1.0):
        raise AccelerationSettingsError(f"{name} must be in (0, 1], got {value!r}")


def apply_relaxation(
    omega: float, x: NDArray[np.float64], x_tilde: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Under-relaxation ``x^{k+1} = omega * x~^k + (1 - omega) * x^k``.

    Written as in preCICE's ``Acceleration::applyRelaxation``; ``omega = 1`` is the plain
    fixed-point (Gauss-Seidel) iteration.
    """
    return omega * np.asarray(x_tilde, dtype=float) + (1.0 - omega) * np.asarray(x, dtype=float)


@dataclass(frozen=True)
class FieldLayout:
    """Names and shapes of the accelerated fields, and their place in the flat vector."""

    names: tuple[str, ...]
    shapes: tuple[tuple[int, ...], ...]

    @classmethod
    def from_fields(cls, fields: Fields) -> FieldLayout:
        if not fields:
            raise AccelerationStateError("at least one field must be accelerated, got none")
        names = tuple(fields)
        return cls(names, tuple(np.shape(fields[n]) for n in names))

    @property
    def sizes(self) -> tuple[int, ...]:
        return tuple(math.prod(s) for s in self.shapes)

    @property
    def size(self) -> int:
        return sum(self.sizes)

    def slices(self) -> dict[str, slice]:
        bounds = np.concatenate([[0], np.cumsum(self.sizes)]).tolist()
        return {n: slice(a, b) for n, a, b in zip(self.names, bounds[:-1], bounds[1:], strict=True)}

    def concat(self, fields: Fields) -> NDArray[np.float64]:
        """The flat vector ``[field_1.ravel(), field_2.ravel(), ...]`` in layout order."""
        self.check(fields)
        return np.concatenate([np.asarray(fields[n], dtype=float).ravel() for n in self.names])

    def split(self, flat: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """Inverse of :meth:`concat`; the arrays are copies."""
        cuts = self.slices()
        shapes = dict(zip(self.names, self.shapes, strict=True))
        return {n: flat[cuts[n]].reshape(shapes[n]).copy() for n in self.names}

    def check(self, fields: Fields) -> None:
        if set(fields) != set(self.names):
            raise AccelerationStateError(
                f"accelerated fields are {sorted(self.names)}, got {sorted(fields)}"
            )
        for name, shape in zip(self.names, self.shapes, strict=True):
            if np.shape(fields[name]) != shape:
                raise AccelerationStateError(
                    f"field {name!r} must have shape {shape}, got {np.shape(fields[name])}"
                )


class Preconditioner(StrEnum):
    """How fields are weighted against each other (preCICE ``<preconditioner type=...>``)."""

    NONE = "none"
    CONSTANT = "constant"  # weight 1 / field_scales[name], e.g. a typical magnitude
    RESIDUAL_SUM = "residual-sum"  # weight 1 / sum_k ||r_i^k|| / ||r^k|| over the window


@dataclass(frozen=True, kw_only=True)
class ScalingSettings:
    """Per-field weighting shared by the schemes that mix fields (Aitken, quasi-Newton).

    ``field_scales`` (only for ``preconditioner="constant"``): a typical magnitude per field in
    its own units, e.g. ``{"force": 1.0, "displacement": 1e-3}``.
    """

    preconditioner: Preconditioner = Preconditioner.RESIDUAL_SUM
    field_scales: Mapping[str, float] = field(default_factory=dict, hash=False)

    def __post_init__(self) -> None:
        choices = [p.value for p in Preconditioner]
        if self.preconditioner not in choices:
            raise AccelerationSettingsError(
                f"preconditioner must be one of {choices}, got {self.preconditioner!r}"
            )
        object.__setattr__(self, "preconditioner", Preconditioner(self.preconditioner))
        object.__setattr__(self, "field_scales", MappingProxyType(dict(self.field_scales)))
        for name, scale in self.field_scales.items():
            if not (isinstance(scale, int | float) and math.isfinite(scale) and scale > 0):
                raise AccelerationSettingsError(
                    f"field_scales[{name!r}] must be a positive number, got {scale!r}"
                )
        if self.preconditioner is Preconditioner.CONSTANT and not self.field_scales:
            raise AccelerationSettingsError(
                "preconditioner 'constant' needs field_scales, e.g. {'force': 1.0}"
            )


class FieldScaling:
    """Diagonal weights ``P`` (one value per field) applied to residuals before they are mixed.

    ``residual-sum`` (preCICE's default for quasi-Newton) accumulates, over the iterations of
    the window, each field's share of the residual ``s_i += ||r_i|| / ||r||`` and weights the
    field by ``1 / s_i``; so every field enters with a comparable magnitude whatever its units.
    Unlike preCICE the weights are refreshed every iteration (its ``update-on-threshold="false"``).
    """

    def __init__(self, settings: ScalingSettings, layout: FieldLayout) -> None:
        self.kind, self.layout = settings.preconditioner, layout
        self._cuts = list(layout.slices().values())
        self.weights = np.ones(layout.size)
        self._sums = np.zeros(len(layout.names))
        if self.kind is Preconditioner.CONSTANT:
            self._set_constant(settings.field_scales)

    def _set_constant(self, field_scales: Mapping[str, float]) -> None:
        missing = [n for n in self.layout.names if n not in field_scales]
        if missing:
            raise AccelerationSettingsError(f"field_scales lacks the fields {missing}")
        for name, cut in zip(self.layout.names, self._cuts, strict=True):
            self.weights[cut] = 1.0 / field_scales[name]

    def update(self, residual: NDArray[np.float64]) -> None:
        """Account for one more residual of the window."""
        if self.kind is not Preconditioner.RESIDUAL_SUM:
            return
        norms = np.array([np.linalg.norm(residual[cut]) for cut in self._cuts])
        total = np.linalg.norm(norms)
        if total == 0.0:
            return  # keep the last weights: no information in a zero residual
        self._sums += norms / total
        for s, cut in zip(self._sums, self._cuts, strict=True):
            if s > 0.0:
                self.weights[cut] = 1.0 / s

    def end_window(self) -> None:
        self._sums[:] = 0.0

    def save_state(self) -> State:
        return {"scaling_weights": self.weights.copy(), "scaling_sums": self._sums.copy()}

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        self.weights = restored(state, "scaling_weights", self.weights.shape)
        self._sums = restored(state, "scaling_sums", self._sums.shape)


def restored(
    state: Mapping[str, NDArray[np.float64]], key: str, shape: tuple[int, ...]
) -> NDArray[np.float64]:
    """A copy of ``state[key]``, checked against the expected shape."""
    if key not in state:
        raise AccelerationStateError(f"saved accelerator state lacks {key!r}")
    value = np.array(state[key], dtype=float)  # np.array copies
    if value.shape != shape:
        raise AccelerationStateError(
            f"saved {key!r} has shape {value.shape}, this accelerator expects {shape}"
        )
    return value


def restored_optional(
    state: Mapping[str, NDArray[np.float64]], key: str, size: int
) -> NDArray[np.float64] | None:
    """A saved vector that may be absent (stored as an empty array), e.g. the last residual."""
    if key not in state:
        raise AccelerationStateError(f"saved accelerator state lacks {key!r}")
    value = np.array(state[key], dtype=float)
    if value.size == 0:
        return None
    return restored(state, key, (size,))


def restored_scalar(state: Mapping[str, NDArray[np.float64]], key: str) -> float:
    return float(restored(state, key, ()))


def optional_array(value: NDArray[np.float64] | None) -> NDArray[np.float64]:
    return np.empty(0) if value is None else value.copy()


class Acceleration(ABC):
    """Abstract coupling acceleration: ``initialize / perform / iterations_converged``.

    Subclasses implement :meth:`_perform` on flat vectors; this class converts the named fields.
    ``save_state`` / ``load_state`` carry everything needed to continue a killed run with the
    same iterates; both copy, so later changes on either side do not leak into the other.
    """

    name: str = "acceleration"

    def __init__(self) -> None:
        self._layout: FieldLayout | None = None

    @property
    def layout(self) -> FieldLayout:
        if self._layout is None:
            raise RuntimeError(f"{self.name}: call initialize(fields) before using the accelerator")
        return self._layout

    def initialize(self, fields: Fields) -> None:
        """Fix the accelerated fields (names, shapes) from a template, e.g. the first values."""
        self._layout = FieldLayout.from_fields(fields)
        self._on_initialize()

    def _on_initialize(self) -> None:  # noqa: B027 -- optional hook
        """Allocate per-layout state (scaling weights, ...); nothing by default."""

    def perform(self, x: Fields, x_tilde: Fields) -> dict[str, NDArray[np.float64]]:
        """The next input ``x^{k+1}`` from the input ``x^k`` and the output ``x~^k = H(x^k)``."""
        flat = self._perform(self.layout.concat(x), self.layout.concat(x_tilde))
        return self.layout.split(flat)

    @abstractmethod
    def _perform(self, x: NDArray[np.float64], x_tilde: NDArray[np.float64]) -> NDArray[np.float64]:
        """``x^{k+1}`` on flat vectors."""

    def iterations_converged(self, x: Fields | None = None, x_tilde: Fields | None = None) -> None:
        """End of the window. Pass the converged pair ``(x^k, x~^k)`` so that quasi-Newton
        schemes keep its secant information too (preCICE does); without it that pair is lost.
        """
        if (x is None) != (x_tilde is None):
            raise ValueError("pass both x and x_tilde to iterations_converged, or neither")
        if x is not None and x_tilde is not None:
            self._converged(self.layout.concat(x), self.layout.concat(x_tilde))
        else:
            self._converged(None, None)

    def _converged(  # noqa: B027
        self, x: NDArray[np.float64] | None, x_tilde: NDArray[np.float64] | None
    ) -> None:
        """Window end on flat vectors; nothing to do by default."""

    def save_state(self) -> State:
        """Everything needed to continue bit-for-bit (copies)."""
        return {}

    def load_state(self, state: Mapping[str, NDArray[np.float64]]) -> None:
        """Restore from :meth:`save_state` (copies; ``state`` is not changed)."""
        _ = self.layout  # raises unless initialized: the layout sizes the restored arrays

    def log_line(self) -> str:
        return self.name
