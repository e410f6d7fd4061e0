"""Coupling accelerations for the implicit coupling loop (layered as preCICE ``src/acceleration``).

``base``: abstract :class:`Acceleration` and :func:`apply_relaxation`; ``constant``: constant
under-relaxation; ``aitken``: Aitken dynamic relaxation; ``quasi_newton``: V/W bookkeeping,
filtering and reuse; ``iqn_ils``: the IQN-ILS update; ``iqn_imvj``: IQN-ILS around a
multi-vector inverse Jacobian kept from window to window. Pure numpy/scipy.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from .aitken import AitkenRelaxation, AitkenSettings
from .base import (
    Acceleration,
    AccelerationSettingsError,
    AccelerationStateError,
    FieldLayout,
    Preconditioner,
    apply_relaxation,
)
from .constant import ConstantRelaxation, ConstantSettings
from .iqn_ils import InverseJacobian, IQNILSAcceleration, IQNILSSettings
from .iqn_imvj import IQNIMVJAcceleration
from .quasi_newton import BaseQNAcceleration, QRFilter, qr1_filter, qr2_filter

SCHEMES: dict[str, tuple[type, Callable[..., Acceleration]]] = {
    "constant": (ConstantSettings, ConstantRelaxation),
    "aitken": (AitkenSettings, AitkenRelaxation),
    "iqn-ils": (IQNILSSettings, IQNILSAcceleration),
    "iqn-imvj": (IQNILSSettings, IQNIMVJAcceleration),
}


def make_acceleration(
    name: str, *, h0: InverseJacobian | None = None, **settings: Any
) -> Acceleration:
    """Build the scheme ``name`` ("constant", "aitken", "iqn-ils", "iqn-imvj") from its
    settings.

    ``h0`` (IQN-ILS only): initial inverse-Jacobian approximation, see :mod:`.iqn_ils`.
    """
    if name not in SCHEMES:
        raise AccelerationSettingsError(
            f"acceleration scheme must be one of {sorted(SCHEMES)}, got {name!r}"
        )
    settings_cls, scheme_cls = SCHEMES[name]
    _check_keys(name, settings_cls, settings)
    if h0 is not None:
        if scheme_cls is not IQNILSAcceleration:
            raise AccelerationSettingsError(f"h0 is only used by 'iqn-ils', not by {name!r}")
        return IQNILSAcceleration(settings_cls(**settings), h0=h0)
    return scheme_cls(settings_cls(**settings))


def _check_keys(name: str, settings_cls: type, given: dict[str, Any]) -> None:
    fields = dataclasses.fields(settings_cls)
    known = {f.name for f in fields}
    required = {
        f.name
        for f in fields
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    }
    if unknown := sorted(set(given) - known):
        raise AccelerationSettingsError(
            f"unknown settings {unknown} for scheme {name!r}; known: {sorted(known)}"
        )
    if missing := sorted(required - set(given)):
        raise AccelerationSettingsError(f"scheme {name!r} needs the settings {missing}")


__all__ = [
    "SCHEMES",
    "Acceleration",
    "AccelerationSettingsError",
    "AccelerationStateError",
    "AitkenRelaxation",
    "AitkenSettings",
    "BaseQNAcceleration",
    "ConstantRelaxation",
    "ConstantSettings",
    "FieldLayout",
    "IQNILSAcceleration",
    "IQNILSSettings",
    "IQNIMVJAcceleration",
    "InverseJacobian",
    "Preconditioner",
    "QRFilter",
    "apply_relaxation",
    "make_acceleration",
    "qr1_filter",
    "qr2_filter",
]
