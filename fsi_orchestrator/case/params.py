"""Declarative parameters for typed, frozen case sections.

Each case section is a frozen keyword-only dataclass whose fields are declared with
:func:`param`. The metadata (documentation, unit, bounds, choices) drives three things:
validation of ``case.toml`` (:mod:`fsi_orchestrator.case.loader`), the error messages that
name the offending key, and the generated reference ``docs/case_format.md``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import types
import typing
from dataclasses import dataclass
from enum import Enum
from typing import Any


class CaseError(ValueError):
    """A case file (or a ``--set`` override) holds a wrong key or value."""


@dataclass(frozen=True, kw_only=True)
class ParamSpec:
    doc: str
    unit: str = ""
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    length: int | None = None  # for sequences: exact number of entries


def param(
    default: Any = dataclasses.MISSING,
    doc: str = "",
    *,
    unit: str = "",
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    length: int | None = None,
) -> Any:
    spec = ParamSpec(doc=doc, unit=unit, gt=gt, ge=ge, lt=lt, le=le, length=length)
    return dataclasses.field(default=default, metadata={"spec": spec})


def spec_of(f: dataclasses.Field[Any]) -> ParamSpec:
    spec = f.metadata.get("spec")
    return spec if isinstance(spec, ParamSpec) else ParamSpec(doc="")


# --------------------------------------------------------------------------- type coercion


def choices(tp: type[Enum]) -> list[Enum]:
    """The members of an enum a case file may name: all but those whose ``case_choice``
    property is false (a scheme set in code only, schema.CouplingScheme.IQN_IMVJ)."""
    return [m for m in tp if getattr(m, "case_choice", True)]


def _describe(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, Enum):
        return " | ".join(f'"{m.value}"' for m in choices(tp))
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_describe(a) for a in typing.get_args(tp) if a is not type(None))
    if origin is tuple:
        inner = typing.get_args(tp)[0]
        return "list of " + {float: "numbers", int: "integers", str: "strings"}.get(
            inner, _describe(inner)
        )
    return {float: "number", int: "integer", str: "string", bool: "true/false"}.get(tp, str(tp))


# the largest integer an integer key takes (a C int: numpy, MPI and OpenFOAM need no more)
INT_LIMIT = 2**31 - 1


def _show(value: Any) -> str:
    """A value for a one-line message: never long, never raising (huge ints, deep nesting)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**16:
        return f"an integer of about {value.bit_length() * math.log10(2):.0f} digits"
    if isinstance(value, float):  # as typed: 1e3 is 1000.0, not the integer 1000
        return repr(value)
    try:
        text = repr(value)
    except (RecursionError, ValueError):
        text = f"a {type(value).__name__}"
    return text if len(text) <= 60 else text[:56] + " ..."


def coerce(key: str, value: Any, tp: Any, spec: ParamSpec) -> Any:
    """Convert a TOML value to the declared type, or raise CaseError naming ``key``."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return None
        return coerce(key, value, args[0], spec)
    if isinstance(tp, type) and issubclass(tp, Enum):
        member = next((m for m in choices(tp) if m.value == value), None)
        if member is None:
            raise CaseError(f"{key} must be one of {_describe(tp)}, got {_show(value)}")
        return member
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise CaseError(f"{key} must be a {_describe(tp)}, got {_show(value)}")
        if spec.length is not None and len(value) != spec.length:
            raise CaseError(f"{key} must have {spec.length} entries, got {len(value)}")
        item = typing.get_args(tp)[0]
        return tuple(coerce(f"{key}[{i}]", v, item, spec) for i, v in enumerate(value))
    if tp is bool:
        if not isinstance(value, bool):
            raise CaseError(f"{key} must be true or false, got {_show(value)}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise CaseError(f"{key} must be an integer, got {_show(value)}")
        _check_bounds(key, value, spec)
        if abs(value) > INT_LIMIT:
            raise CaseError(f"{key} must lie within +-{INT_LIMIT}, got {_show(value)}")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise CaseError(f"{key} must be a number, got {_show(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise CaseError(f"{key} must be finite, got {_show(value)}")
        _check_bounds(key, value, spec)  # an int compares exactly, however large
        if abs(value) > sys.float_info.max:  # an integer literal such as 10**400
            raise CaseError(f"{key} must be a number within float range, got {_show(value)}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise CaseError(f"{key} must be a string, got {_show(value)}")
        if "\0" in value:
            raise CaseError(f"{key} must not contain a NUL character")
        return value
    raise TypeError(f"unsupported parameter type {tp!r} for {key}")  # programming error


def _check_bounds(key: str, v: float, spec: ParamSpec) -> None:
    shown, span = _show(v), _range(spec)
    # where both lower limits are declared (> 0 and >= 0.01 Hz) the tighter one is stated:
    # "must be > 0" for 0 Hz hid that 0.005 Hz is refused too
    ge_binds = spec.ge is not None and (spec.gt is None or spec.ge > spec.gt)
    # a sign error ("must be > 0, got -3") needs no range; every other violation gives it
    if spec.gt is not None and not ge_binds and not v > spec.gt:
        raise CaseError(f"{key} must be > {spec.gt:g}, got {shown}{span if spec.gt else ''}")
    if spec.ge is not None and not v >= spec.ge:
        raise CaseError(f"{key} must be >= {spec.ge:g}, got {shown}{span if spec.ge else ''}")
    if spec.lt is not None and not v < spec.lt:
        raise CaseError(f"{key} must be < {spec.lt:g}, got {shown}{span}")
    if spec.le is not None and not v <= spec.le:
        raise CaseError(f"{key} must be <= {spec.le:g}, got {shown}{span}")


def _range(spec: ParamSpec) -> str:
    """`` (range: 0 < x <= 1000 Hz)`` where both ends are declared, else nothing."""
    low = f"{spec.gt:g} < " if spec.gt is not None else None
    low = f"{spec.ge:g} <= " if spec.ge is not None else low
    high = f" < {spec.lt:g}" if spec.lt is not None else None
    high = f" <= {spec.le:g}" if spec.le is not None else high
    if low is None or high is None:
        return ""
    return f" (range: {low}x{high}{' ' + spec.unit if spec.unit else ''})"


def build_section(cls: type, name: str, raw: dict[str, Any]) -> Any:
    """Build the frozen dataclass ``cls`` for section ``name`` from a TOML table."""
    if not isinstance(raw, dict):
        raise CaseError(f"[{name}] must be a table, got {_show(raw)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        raise CaseError(
            f"{name}.{unknown[0]} is not a known key (known: {', '.join(sorted(fields))})"
        )
    kwargs = {k: coerce(f"{name}.{k}", v, hints[k], spec_of(fields[k])) for k, v in raw.items()}
    missing = [
        k
        for k, f in fields.items()
        if k not in kwargs
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise CaseError(f"{name}.{missing[0]} is required")
    return cls(**kwargs)
