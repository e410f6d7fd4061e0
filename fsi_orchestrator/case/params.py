"""Declarative parameters for typed, frozen case sections.

Each case section is a frozen keyword-only dataclass whose fields are declared with
:func:`param`. The metadata (documentation, unit, bounds, choices) drives three things:
validation of ``case.toml`` (:mod:`fsi_orchestrator.case.loader`), the error messages that
name the offending key, and the generated reference ``docs/case_format.md``.
"""

from __future__ import annotations

import dataclasses
import math
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
    gt=None,
    ge=None,
    lt=None,
    le=None,
    length=None,
) -> Any:
    spec = ParamSpec(doc=doc, unit=unit, gt=gt, ge=ge, lt=lt, le=le, length=length)
    return dataclasses.field(default=default, metadata={"spec": spec})


def spec_of(f: dataclasses.Field) -> ParamSpec:
    return f.metadata.get("spec", ParamSpec(doc=""))


# --------------------------------------------------------------------------- type coercion


def _describe(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, Enum):
        return " | ".join(f'"{m.value}"' for m in tp)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_describe(a) for a in typing.get_args(tp) if a is not type(None))
    if origin is tuple:
        inner = typing.get_args(tp)[0]
        return "list of " + {float: "numbers", int: "integers", str: "strings"}.get(
            inner, _describe(inner)
        )
    return {float: "number", int: "integer", str: "string", bool: "true/false"}.get(tp, str(tp))


def coerce(key: str, value: Any, tp: Any, spec: ParamSpec) -> Any:
    """Convert a TOML value to the declared type, or raise CaseError naming ``key``."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return None
        return coerce(key, value, args[0], spec)
    if isinstance(tp, type) and issubclass(tp, Enum):
        try:
            return tp(value)
        except ValueError:
            raise CaseError(f"{key} must be one of {_describe(tp)}, got {value!r}") from None
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise CaseError(f"{key} must be a {_describe(tp)}, got {value!r}")
        if spec.length is not None and len(value) != spec.length:
            raise CaseError(f"{key} must have {spec.length} entries, got {len(value)}")
        item = typing.get_args(tp)[0]
        return tuple(coerce(f"{key}[{i}]", v, item, spec) for i, v in enumerate(value))
    if tp is bool:
        if not isinstance(value, bool):
            raise CaseError(f"{key} must be true or false, got {value!r}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise CaseError(f"{key} must be an integer, got {value!r}")
        _check_bounds(key, value, spec)
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise CaseError(f"{key} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise CaseError(f"{key} must be finite, got {value!r}")
        _check_bounds(key, float(value), spec)
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise CaseError(f"{key} must be a string, got {value!r}")
        return value
    raise TypeError(f"unsupported parameter type {tp!r} for {key}")  # programming error


def _check_bounds(key: str, v: float, spec: ParamSpec) -> None:
    if spec.gt is not None and not v > spec.gt:
        raise CaseError(f"{key} must be > {spec.gt:g}, got {v:g}")
    if spec.ge is not None and not v >= spec.ge:
        raise CaseError(f"{key} must be >= {spec.ge:g}, got {v:g}")
    if spec.lt is not None and not v < spec.lt:
        raise CaseError(f"{key} must be < {spec.lt:g}, got {v:g}")
    if spec.le is not None and not v <= spec.le:
        raise CaseError(f"{key} must be <= {spec.le:g}, got {v:g}")


def build_section(cls: type, name: str, raw: dict[str, Any]) -> Any:
    """Build the frozen dataclass ``cls`` for section ``name`` from a TOML table."""
    if not isinstance(raw, dict):
        raise CaseError(f"[{name}] must be a table, got {raw!r}")
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
