"""Render the case schema as ``docs/case_format.md``: ``python -m fsi_orchestrator.case.docgen``.

A test compares the committed file with this output, so the reference never drifts."""

from __future__ import annotations

import dataclasses
import sys
import types
import typing
from enum import Enum
from pathlib import Path
from typing import Any

from .params import ParamSpec, choices, spec_of
from .schema import SECTIONS

HEADER = """# Case file reference (`case.toml`)

Generated from `fsi_orchestrator/case/schema.py` by `python -m fsi_orchestrator.case.docgen`;
do not edit by hand. A case is a folder holding `case.toml`. Every key is optional unless marked;
an unknown key, a wrong type or a value out of range stops the run with one line naming the key.
Any key can be overridden on the command line: `--set section.key=value` (TOML syntax; bare
words are strings, e.g. `--set fluid.model=potential`).

Units are SI and stated in each key's name. A default of "unset": the key has no value
unless given, and its meaning says what then holds (a preset's value, one derived from other
keys, or off).
"""


def _type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return _type_name(args[0])
    if isinstance(tp, type) and issubclass(tp, Enum):
        return " \\| ".join(f'`"{m.value}"`' for m in choices(tp))
    if origin is tuple:
        return "list of numbers"
    return {float: "number", int: "integer", str: "string", bool: "boolean"}.get(tp, str(tp))


def _default(f: dataclasses.Field[Any]) -> str:
    value = f.default
    if value is None:  # what unset means: the description says (a preset's, derived, off)
        return "unset"
    if isinstance(value, Enum):
        return f'`"{value.value}"`'
    if isinstance(value, tuple):
        return "`[" + ", ".join(f"{v:g}" for v in value) + "]`"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    return f"`{value:g}`" if isinstance(value, float) else f"`{value}`"


def _bounds(spec: ParamSpec) -> str:
    parts = []
    for name, op in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
        v = getattr(spec, name)
        if name == "gt" and spec.ge is not None and v is not None and spec.ge > v:
            continue  # "> 0" for the sign, ">= 0.01" the sane end: the reader needs the latter
        if v is not None:
            parts.append(f"{op} {v:g}")
    return ", ".join(parts)


def render() -> str:
    lines = [HEADER]
    for section, cls in SECTIONS.items():
        hints = typing.get_type_hints(cls)
        lines += [
            f"## [{section}]",
            "",
            "| key | type | default | range | meaning |",
            "|---|---|---|---|---|",
        ]
        for f in dataclasses.fields(cls):
            spec = spec_of(f)
            doc = spec.doc.replace("|", "\\|")
            lines.append(
                f"| `{section}.{f.name}` | {_type_name(hints[f.name])} | {_default(f)} "
                f"| {_bounds(spec)} | {doc} |"
            )
        lines.append("")
    return "\n".join(lines).replace("\n\n\n", "\n\n")


def main() -> int:
    """``python -m fsi_orchestrator.case.docgen [FILE]``: (re)write the case format reference
    (default: the repository's docs/case_format.md)."""
    if len(sys.argv) > 1 and sys.argv[1].startswith("-"):
        print((main.__doc__ or "").split(":", 1)[0].strip("`"), file=sys.stderr)
        return 0 if sys.argv[1] in ("-h", "--help") else 2
    default = Path(__file__).resolve().parents[2] / "docs" / "case_format.md"
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else default
    target.write_text(render())
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
