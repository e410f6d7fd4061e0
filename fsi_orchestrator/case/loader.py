"""Load and validate ``case.toml`` (plus ``--set section.key=value`` overrides) into a Case."""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from .params import CaseError, build_section
from .schema import (
    MFC_VOLTAGE_RANGE_V,
    SECTIONS,
    Case,
    CouplingScheme,
    GeometryKind,
    Integrator,
    StartMode,
)

CASE_FILE = "case.toml"
MAX_CASE_BYTES = 1_000_000  # a case file is a few kB; anything near this is not one
MAX_TIME_STEPS = 1_000_000  # windows of one dynamic run (time.periods x time.steps_per_period)
MAX_SHELL_ELEMENTS = 10_000  # Quad9 elements of an explicit shell mesh (level fine: 32 x 8)

# Geometry keys that only make sense for some kinds: a rectangle with a peduncle is a typo.
_FISH_ONLY = {
    "preset",
    "body_length_m",
    "max_height_m",
    "peduncle_height_m",
    "caudal_fin_height_m",
    "head_length_m",
    "taper_start_x_m",
    "peduncle_x_m",
    "nose_height_fraction",
    "active_length_m",
    "active_width_m",
    "head_weight_radius_m",
    "head_weight_thickness_m",
    "head_weight_x_m",
}
_ACTUATOR_KEYS = {
    "mfc_thickness_m",
    "actuator_length_m",
    "actuator_width_m",
    "actuator_start_x_m",
    "actuator_sides",
}
_NOT_FOR_KIND = {
    GeometryKind.RECTANGLE: _FISH_ONLY | _ACTUATOR_KEYS,
    GeometryKind.BEAM: _FISH_ONLY,
    GeometryKind.FISH: {"length_m", "width_m"},
}


def parse_override(text: str) -> tuple[str, str, Any]:
    """``"actuation.frequency_hz=5"`` -> ("actuation", "frequency_hz", 5); bare words: strings."""
    key, sep, raw = text.partition("=")
    section, dot, name = key.strip().partition(".")
    if not sep or not dot or not section or not name:
        raise CaseError(f"--set {text!r} must look like section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # e.g. --set fluid.model=potential
    except RecursionError:
        raise CaseError(f"--set {key.strip()}: the value is nested too deeply") from None
    except ValueError as err:  # an integer literal of more than 4300 digits
        raise CaseError(f"--set {key.strip()}: {err}") from None
    return section, name, value


def merge_overrides(raw: dict[str, Any], overrides: Iterable[str]) -> dict[str, Any]:
    merged = {k: dict(v) if isinstance(v, dict) else v for k, v in raw.items()}
    for text in overrides:
        section, name, value = parse_override(text)
        if section not in SECTIONS:
            raise CaseError(
                f"--set {text!r}: unknown section [{section}] (known: {', '.join(SECTIONS)})"
            )
        merged.setdefault(section, {})[name] = value
    return merged


def load_case(
    directory: str | Path, overrides: Iterable[str] = (), *, allow_empty: bool = True
) -> Case:
    """Read ``<directory>/case.toml``; raise CaseError with a one-line message on bad input.

    ``allow_empty=False`` (the commands) refuses a case.toml without a single key when no
    ``--set`` gives one either: an empty file is more likely a mistake than a wish for every
    default."""
    given = Path(directory)
    path = given if given.name == CASE_FILE else given / CASE_FILE
    if not path.is_file():
        raise CaseError(
            f"{given}: no {CASE_FILE} found (a case is a folder with a "
            f"{CASE_FILE}; see cases/ for examples)"
        )
    directory = path.parent
    raw = _read_toml(path)
    overrides = list(overrides)
    if not raw and not overrides and not allow_empty:
        raise CaseError(
            f"{CASE_FILE} is empty ({path}): give at least one key (to run every default on "
            f'purpose, e.g. [case] title = "defaults"); keys and defaults: docs/case_format.md'
        )
    merged = merge_overrides(raw, overrides)
    try:
        return case_from_dict(merged, directory)
    except CaseError as err:
        raise CaseError(blame_override(str(err), overrides)) from None


def blame_override(message: str, overrides: list[str], *, derived: bool = False) -> str:
    """A message about a key that --set gave names the --set, not the file: "case.toml:
    actuation.frequency_hz must be >= 0.01, ..." -> "--set 'actuation.frequency_hz=-3':
    actuation.frequency_hz must be >= 0.01, ..."."""
    prefix = f"{CASE_FILE}: "
    if not message.startswith(prefix):
        return message
    body = message[len(prefix) :]
    key = body.split(maxsplit=1)[0].rstrip(":") if body.strip() else ""
    key = key.split("[", 1)[0]  # a list's item: actuation.left_volts[0]
    given = [o for o in overrides if o.split("=", 1)[0].strip() == key]
    if given:
        return f"--set {given[-1]!r}: {body}"
    # a check across keys ("peduncle_height_m must be <= max_height_m") names the --set key
    # it mentions; a ``derived`` one (a check of the resolved plate) that mentions none may
    # still follow from a --set (a default derived from it): it names the file with every --set
    # the claim, not the advice after it ("; use ...", "(the fast models take ...)"), which
    # may name other keys
    claim = re.split(r"[;(]", body, maxsplit=1)[0]
    mentioned = [
        o
        for o in overrides
        if re.search(rf"(?<![\w.]){re.escape(o.split('=', 1)[0].strip())}(?!\w)", claim)
    ]
    if mentioned:
        return f"--set {mentioned[-1]!r}: {body}"
    if overrides and derived:
        return f"{CASE_FILE} with --set {', '.join(repr(o) for o in overrides)}: {body}"
    return message


def _read_toml(path: Path) -> dict[str, Any]:
    """The TOML table of a case file, or CaseError naming the file (or the key) in one line."""
    try:
        size = path.stat().st_size
        if size > MAX_CASE_BYTES:
            raise CaseError(
                f"{path}: {size} bytes; a case file is at most {MAX_CASE_BYTES} bytes of TOML"
            )
        data = path.read_bytes()
    except OSError as err:
        raise CaseError(f"{path}: cannot read it ({err.strerror or err})") from None
    try:
        text = data.decode("utf-8-sig")  # a UTF-8 byte-order mark is harmless
    except UnicodeDecodeError as err:
        raise CaseError(
            f"{path}: not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start}); "
            f"{CASE_FILE} must be UTF-8 TOML"
        ) from None
    # the file as given (cases/foo/case.toml): a bare "case.toml" does not say which
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise CaseError(f"{path}: not valid TOML: {err}") from None
    except RecursionError:
        where = _key_on_line(text, lambda line: line.count("[") + line.count("{") > 50)
        raise CaseError(f"{path}: {where or 'a value'} is nested too deeply") from None
    except ValueError as err:  # an integer literal of more than 4300 digits
        where = _key_on_line(text, lambda line: re.search(r"\d{1000}", line) is not None)
        raise CaseError(f"{path}: {where or 'a value'}: {err}") from None


_TABLE = re.compile(r"^\s*\[+\s*([A-Za-z0-9_.\- ]+?)\s*\]")
_KEY = re.compile(r"^\s*([A-Za-z0-9_.\-]+)\s*=")


def _key_on_line(text: str, predicate: Callable[[str], bool]) -> str | None:
    """``section.key`` whose value is on (or runs into) the first line matching ``predicate``."""
    table, key = "", None
    for line in text.splitlines():
        key_match = _KEY.match(line)
        table_match = None if key_match else _TABLE.match(line)
        if table_match and not predicate(line):
            table, key = table_match.group(1), None
        elif key_match:
            key = key_match.group(1)
        if predicate(line):
            return None if key is None else f"{table}.{key}" if table else key
    return None


def case_from_dict(raw: dict[str, Any], directory: Path) -> Case:
    unknown = sorted(set(raw) - set(SECTIONS))
    if unknown:
        raise CaseError(
            f"{CASE_FILE}: [{unknown[0]}] is not a known section (known: {', '.join(SECTIONS)})"
        )
    try:
        sections = {
            name: build_section(cls, name, raw.get(name, {})) for name, cls in SECTIONS.items()
        }
        case = Case(directory=directory.resolve(), **sections)
        _cross_check(case, raw)
    except CaseError as err:
        raise CaseError(f"{CASE_FILE}: {err}") from None
    return case


def _cross_check(case: Case, raw: dict[str, Any]) -> None:
    g = case.geometry
    given_geometry = set(raw.get("geometry", {}))
    for key in sorted(given_geometry & _NOT_FOR_KIND[g.kind]):
        raise CaseError(f'geometry.{key} does not apply to geometry.kind = "{g.kind}"')
    if g.kind is GeometryKind.RECTANGLE:
        for key in ("length_m", "width_m", "thickness_m"):
            if getattr(g, key) is None:
                raise CaseError(f'geometry.{key} is required for geometry.kind = "rectangle"')
        for key in ("youngs_modulus_pa", "poisson_ratio", "density_kg_m3"):
            if getattr(case.material, key) is None:
                raise CaseError(f'material.{key} is required for geometry.kind = "rectangle"')
        if case.material.cfrp is not None:
            raise CaseError('material.cfrp does not apply to geometry.kind = "rectangle"')
    head = case.boundary.head.value
    if head != "pinned" and case.boundary.pin_x_m != 0.0:
        raise CaseError(
            f'boundary.pin_x_m places a hinge, for boundary.head = "pinned" only (head is '
            f'"{head}"); set boundary.head = "pinned" or leave boundary.pin_x_m out'
        )
    if g.kind is not GeometryKind.FISH and head == "elastic":
        raise CaseError(
            f'boundary.head = "elastic" is the fish\'s head on springs; for geometry.kind = '
            f'"{g.kind}" use "clamped", "free" (the x = 0 edge) or "pinned"'
        )
    a = case.actuation
    lo, hi = MFC_VOLTAGE_RANGE_V
    for key in ("left_volts", "right_volts", "static_volts"):
        volts = getattr(a, key)
        if key != "static_volts" and volts[0] > volts[1]:
            raise CaseError(f"actuation.{key} must be [min, max], got {list(volts)}")
        if min(volts) < lo or max(volts) > hi:
            raise CaseError(
                f"actuation.{key} must lie within the MFC's range [{lo:g}, {hi:g}] V "
                f"(Table 3.1), got {list(volts)}"
            )
    if case.analysis.kind.value == "static" and head in ("free", "pinned"):
        outside = [
            f"loads.{key}"
            for key in ("tip_force_n", "tip_moment_nm", "pressure_pa")
            if getattr(case.loads, key) != 0
        ]
        if outside:
            plate = "a free plate" if head == "free" else "a plate on a hinge"
            raise CaseError(
                f'{", ".join(outside)} on {plate} (boundary.head = "{head}"): nothing '
                "holds the plate against an outside load, so it has no static equilibrium; "
                'clamp it (boundary.head = "clamped") or run analysis.kind = "dynamic"'
            )
    if case.analysis.kind.value == "swimming":
        if g.kind is not GeometryKind.FISH:
            raise CaseError(
                f'analysis.kind = "swimming" needs geometry.kind = "fish", got "{g.kind}"'
            )
        if head in ("clamped", "pinned"):
            raise CaseError(
                'analysis.kind = "swimming" needs boundary.head = "free" (a swimming fish is '
                'held nowhere) or "elastic" (its head on springs, a sensitivity study of what '
                f'might restrain it), got "{head}"'
            )
        if case.fluid.model.value == "none":
            raise CaseError(
                'analysis.kind = "swimming" needs a liquid to swim in: fluid.model = '
                '"potential" or "slender_body" (or "openfoam" for a flume), got "none"'
            )
        speed = case.swimming.speed_m_s
        if case.fluid.model.value == "openfoam" and (speed is None or speed <= 0):
            raise CaseError(
                'swimming.speed_m_s: a swimming case with fluid.model = "openfoam" is a flume '
                "and needs its inflow speed > 0 (e.g. --set swimming.speed_m_s=0.8)"
            )
    if case.fluid.inflow_m_s > 0 and case.fluid.model.value != "openfoam":
        raise CaseError(
            f"fluid.inflow_m_s = {case.fluid.inflow_m_s:g}: a flume's inflow needs "
            'fluid.model = "openfoam" (the fast models take the speed from swimming.speed_m_s)'
        )
    t = case.time
    if (t.step_s is None) != (t.end_time_s is None):
        raise CaseError("time.step_s and time.end_time_s go together: give both or neither")
    if case.analysis.kind.value == "dynamic":
        if t.step_s is not None and t.end_time_s is not None:
            steps, given = t.end_time_s / t.step_s, "time.end_time_s / time.step_s"
        else:
            steps, given = t.periods * t.steps_per_period, "time.periods x time.steps_per_period"
        if steps > MAX_TIME_STEPS:
            raise CaseError(
                f"{given} asks for {steps:.3g} time steps; at most {MAX_TIME_STEPS:g} in one run"
            )
    m = case.mesh
    elements = (m.elements_length or 1) * (m.elements_width or 1)
    if elements > MAX_SHELL_ELEMENTS:
        raise CaseError(
            f"mesh.elements_length x mesh.elements_width = {elements} shell elements (about "
            f"{elements * 4 * 6:.2g} unknowns); at most {MAX_SHELL_ELEMENTS} (level fine: 32 x 8)"
        )
    if t.periodic_tolerance is not None and t.step_s is not None:
        raise CaseError(
            "time.periodic_tolerance counts periods of the drive (time.periods); a run given "
            "by time.step_s / time.end_time_s has none: remove one or the other"
        )
    if t.periodic_feedback_per_s and t.step_s is not None:
        raise CaseError(
            "time.periodic_feedback_per_s feeds back the motion one drive period earlier; a run "
            "given by time.step_s / time.end_time_s has no whole number of steps per period: "
            "remove one or the other"
        )
    if t.periodic_feedback_per_s and case.analysis.integrator is Integrator.ENERGY_CONSERVING:
        raise CaseError(
            'time.periodic_feedback_per_s needs analysis.integrator = "generalized-alpha" or '
            '"newmark": the energy-conserving rule damps with the mid-step velocity, against '
            "which the feedback is not zero on a periodic motion"
        )
    if t.periodic_feedback_mirror:
        why = None
        if not t.periodic_feedback_per_s:
            why = "it is a term of the delayed feedback: set time.periodic_feedback_per_s > 0"
        elif t.steps_per_period % 2:
            n = t.steps_per_period
            why = f"half a period must be whole steps: time.steps_per_period = {n} is odd"
        elif tuple(case.actuation.left_volts) != tuple(case.actuation.right_volts):
            why = (
                "actuation.left_volts and right_volts differ, so the motion half a period later is "
                "not the mirror image (a turning drive, a one-sided actuator): set it to false"
            )
        if why:
            raise CaseError(f"time.periodic_feedback_mirror: {why}")
    if t.start_from:
        if case.geometry.kind is GeometryKind.RECTANGLE:
            raise CaseError(
                'time.start_from starts on a driven orbit; geometry.kind = "rectangle" has no '
                "actuators: remove it"
            )
        if t.step_s is not None:
            raise CaseError(
                "time.start_from starts on a recorded period of the drive; a run given by "
                "time.step_s / time.end_time_s has no whole number of steps per period: remove "
                "one or the other"
            )
        if t.start is not StartMode.PERIODIC or case.actuation.ramp_periods > 0:
            raise CaseError(
                "time.start_from starts on a periodic orbit, not from rest: remove it, or set "
                'time.start = "periodic" and actuation.ramp_periods = 0'
            )
    c = case.coupling
    if c.jacobian_from and c.scheme is not CouplingScheme.IQN_ILS_AM:
        raise CaseError(
            f'coupling.jacobian_from applies to coupling.scheme = "iqn-ils-am" only (got '
            f'"{c.scheme}"), whose quasi-Newton update keeps a Jacobian; remove it or '
            "change the scheme"
        )
    if c.explicit_until_periodic:
        if c.scheme is not CouplingScheme.IQN_ILS_AM:
            raise CaseError(
                'coupling.explicit_until_periodic applies to coupling.scheme = "iqn-ils-am" '
                f'only (got "{c.scheme}"), which can iterate once the run is periodic; '
                "remove it or change the scheme"
            )
        if t.periodic_tolerance is None:
            raise CaseError(
                "coupling.explicit_until_periodic needs time.periodic_tolerance (when the "
                "explicit windows are periodic); set it, e.g. --set time.periodic_tolerance=0.01"
            )
        if c.explicit_periods > 0:
            raise CaseError(
                "coupling.explicit_until_periodic and coupling.explicit_periods both say when "
                "the windows start to iterate; keep one of them"
            )
    if c.explicit_periods > 0:
        if c.scheme is not CouplingScheme.IQN_ILS_AM:
            raise CaseError(
                f'coupling.explicit_periods applies to coupling.scheme = "iqn-ils-am" only (got '
                f'"{c.scheme}"): one solve per window is stable only with the added-mass '
                "correction; set it to 0 or change the scheme"
            )
        if t.step_s is None and c.explicit_periods >= t.periods:
            raise CaseError(
                f"coupling.explicit_periods ({c.explicit_periods}) must be less than "
                f"time.periods ({t.periods:g}); for a run without iterations use "
                'coupling.scheme = "explicit-am"'
            )
