"""What made a results file: the resolved case as TOML text, the overrides, the version, the
fluid model, the time and host; and the identity a checkpoint carries of the case it belongs
to. The root attribute names are a contract (docs/case_format.md, "Faults and provenance")."""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import socket
import subprocess
from collections.abc import Mapping, Sequence
from enum import Enum
from pathlib import Path
from typing import Any

from . import __version__
from .case import Case

# the sections a checkpoint's state depends on: resuming with another plate, material, support
# or mesh would load numbers that mean something else
IDENTITY_SECTIONS = ("geometry", "material", "boundary", "mesh")
IDENTITY_ATTR = "case_identity"


def version() -> str:
    """The package version, with the git commit where the source is a git checkout."""
    try:
        from importlib.metadata import version as installed

        text = installed("fishfsi")
    except Exception:  # not installed (a plain checkout on the path)
        text = __version__
    root = Path(__file__).resolve().parents[1]
    if (root / ".git").exists():
        try:
            commit = subprocess.run(
                ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                capture_output=True,
                text=True,
                timeout=5,
                check=False,
            ).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            commit = ""
        if commit:
            text += f" (git {commit})"
    return text


def _plain(value: Any) -> Any:
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def case_dict(case: Case) -> dict[str, Any]:
    """Every section of the resolved case, defaults included (None: unset)."""
    raw: dict[str, Any] = _plain(dataclasses.asdict(case))
    raw.pop("directory", None)
    return raw


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(int(value))
    if isinstance(value, float):  # numpy's float64 too: its repr is not TOML
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML for {type(value).__name__}")


def case_toml(case: Case) -> str:
    """The resolved case as a case.toml that loads back to the same case: the keys that
    differ from their defaults, then the defaults as comments (a default may not apply to
    this case, e.g. a preset to a beam, and the loader refuses such a key when given)."""
    lines: list[str] = []
    for section, values in case_dict(case).items():
        defaults = _plain(dataclasses.asdict(type(getattr(case, section))()))
        lines.append(f"[{section}]")
        for k, v in values.items():
            if v is None:
                continue
            line = f"{k} = {_toml_value(v)}"
            lines.append(line if v != defaults.get(k) else f"# {line}  (default)")
        lines.append("")
    return "\n".join(lines)


# the boundary keys each head support does not read: a change to one changes no run
UNREAD_BY_HEAD = {
    "clamped": ("pin_x_m", "support_stiffness_n_per_m"),
    "pinned": ("clamp_length_m", "support_stiffness_n_per_m"),
    "elastic": ("pin_x_m",),
    "free": ("clamp_length_m", "pin_x_m", "support_stiffness_n_per_m"),
}


def case_identity(case: Case) -> str:
    """The sections a checkpoint belongs to, and the fluid model (a run resumed under
    another one would mix two fluids' windows under one label), as JSON text."""
    raw = case_dict(case)
    identity = {s: raw[s] for s in IDENTITY_SECTIONS}
    identity["fluid"] = {"model": raw["fluid"]["model"]}
    return json.dumps(_without_unread(identity), sort_keys=True)


def _without_unread(identity: dict[str, Any], head: str | None = None) -> dict[str, Any]:
    """``identity`` less the boundary keys that ``head`` (default: its own) does not read."""
    boundary = identity.get("boundary")
    if not isinstance(boundary, dict):
        return identity
    unread = UNREAD_BY_HEAD.get(str(head or boundary.get("head")), ())
    return {**identity, "boundary": {k: v for k, v in boundary.items() if k not in unread}}


def is_new_default(section: str, key: str, value: Any) -> bool:
    """Whether ``section.key`` at ``value`` is its default: a key added to the schema after an
    identity was stored, at its default, changes nothing that identity stood for."""
    fields = {f.name: f for f in dataclasses.fields(Case)}
    spec = fields.get(section)
    if spec is None or spec.default_factory is dataclasses.MISSING:
        return False
    default = _plain(dataclasses.asdict(spec.default_factory()))
    return key in default and default[key] == value


def identity_changes(stored: str, current: str, limit: int = 3) -> list[str]:
    """``section.key`` of the first few keys that differ between two identities, over the
    sections the stored one holds (older checkpoints hold no fluid model); a key the stored
    one lacks counts only away from its default, and a boundary key the current head support
    does not read not at all."""
    a, b = json.loads(stored), json.loads(current)
    head = b.get("boundary", {}).get("head")  # a changed head is a change of its own
    a, b = _without_unread(a, head), _without_unread(b, head)
    keys = sorted(
        f"{s}.{k}"
        for s in set(a)
        for k in set(a[s]) | set(b.get(s, {}))
        if a[s].get(k) != b.get(s, {}).get(k)
        and not (k not in a[s] and is_new_default(s, k, b.get(s, {}).get(k)))
    )
    return keys[:limit]


def run_attributes(case: Case, overrides: Sequence[str]) -> dict[str, Any]:
    """Root attributes of results.h5 known before the run (``thrust_source`` comes at its end)."""
    return {
        "case": str(case.directory),
        "case_toml": case_toml(case),
        "overrides": json.dumps(list(overrides)),
        "version": version(),
        "fluid_model": case.fluid.model.value,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "host": socket.gethostname(),
    }
