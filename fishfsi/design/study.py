"""``study.toml``: a design study as typed, frozen dataclasses, validated when read.

A study is a base case (plus ``--set`` lines), the numeric case keys it varies within
``[low, high]``, one or more objectives (keys of ``fsi-run --json``'s summary, to maximise or
minimise, combined as a weighted sum), optional linear constraints between case keys, and a
method (``one-at-a-time``, ``sample`` or ``optimize``). Every user error is a CaseError whose
one line names the key (``study.toml: [[parameters]] key ...``).
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import typing
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from fsi_orchestrator.case import CaseError, load_case
from fsi_orchestrator.case.params import spec_of
from fsi_orchestrator.case.schema import SECTIONS

STUDY_FILE = "study.toml"

# keys of fsi-run --json (cli/run.py: dynamic_summary, run_dynamic, coupling_summary,
# fluid_force_summary, thrust_estimate) and of a modal case (cli/modal.py) that are numbers
SCALAR_SUMMARY_KEYS = (
    "tip_amplitude_m",
    "tip_amplitude_periodic_m",  # the periodic state estimated from the periods run
    "tip_amplitude_periodic_uncertainty_m",
    "mean_thrust_periodic_n",
    "mean_thrust_periodic_uncertainty_n",
    "tip_amplitude_change_last_period",
    "tip_max_abs_m",
    "end_time_s",
    "windows",
    "windows_per_period",
    "thrust_averaged_over_s",
    "mean_newton_iterations_per_window",
    "wall_s",
    "setup_s",
    "mean_thrust_n",
    "slender_body_mean_thrust_n",
    "lateral_force_amplitude_n",
    "mean_lateral_force_n",
    "mean_yaw_moment_nm",
    "mean_fluid_solves_per_window",
    "last_period_fluid_solves_per_window",
    "max_fluid_solves_per_window",
    "unconverged_windows",
    "non_fluid_share",
    "last_period_non_fluid_share",
    "last_period_wall_s_per_window",
    "added_mass_kg",
    "plate_mass_kg",
    "mean_voltage_buckling_factor",
    # a swimming case's (analysis.kind = "swimming": cli/swimming.py, cli/linear.py)
    "swimming_speed_m_s",
    "body_lengths_per_s",
    "swimming_number",
    "turning_rate_deg_s",
    "thrust_at_speed_n",
    "drag_at_speed_n",
    "net_force_n",
    "slip_deg",
    "yaw_drive_moment_nm",
    "tip_amplitude_at_speed_m",
    "drive_power_w",
    "drive_power_at_speed_w",
    "work_per_distance_j_m",
    "section_added_mass_coefficient",
)
# list-valued summary keys an objective may index: "wet_hz[0]" (the first wet mode)
LIST_SUMMARY_KEYS = (
    "dry_hz",
    "wet_hz",
    "wet_hz_at_mean_voltage",
    "tip_displacement_m",
    "tip_amplitude_per_period_m",
    "mean_thrust_per_period_n",
)
_INDEXED = re.compile(r"^([a-z_]+)\[(\d+)\]$")


class Method(StrEnum):
    ONE_AT_A_TIME = "one-at-a-time"  # each parameter over a grid, the others at the base
    SAMPLE = "sample"  # a space-filling sample (the seed's random search, Sec. 5.4)
    OPTIMIZE = "optimize"  # a space-filling start, then differential evolution


class Sense(StrEnum):
    MAX = "max"
    MIN = "min"


class Evaluation(StrEnum):
    AUTO = "auto"  # the linear response (and the modal path) where they answer, else a run
    LINEAR = "linear"
    TRANSIENT = "transient"


@dataclass(frozen=True, kw_only=True)
class Parameter:
    key: str  # section.name
    low: float
    high: float
    integer: bool = False

    @property
    def section(self) -> str:
        return self.key.partition(".")[0]

    @property
    def name(self) -> str:
        return self.key.partition(".")[2]

    def value(self, unit: float) -> float | int:
        """The parameter at ``unit`` in [0, 1] of its range."""
        v = self.low + unit * (self.high - self.low)
        return round(v) if self.integer else float(f"{v:.12g}")  # 0.021, not 0.0209999...


@dataclass(frozen=True, kw_only=True)
class Objective:
    quantity: str  # a summary key, or "wet_hz[0]"
    sense: Sense = Sense.MAX
    weight: float = 1.0
    where: str = dataclasses.field(default="[objective]", compare=False)  # for messages

    def score(self, value: float) -> float:
        """This objective's share of the score, larger is better."""
        return self.weight * (value if self.sense is Sense.MAX else -value)


@dataclass(frozen=True, kw_only=True)
class Term:
    coefficient: float
    key: str | None  # None: a constant


_OPS = {
    "<=": lambda a, b: a <= b,
    ">=": lambda a, b: a >= b,
    "<": lambda a, b: a < b,
    ">": lambda a, b: a > b,
}


@dataclass(frozen=True, kw_only=True)
class Constraint:
    """``left OP right``, each side a sum of ``[number *] key`` and numbers: a parser, never
    an eval."""

    expression: str
    left: tuple[Term, ...]
    op: str
    right: tuple[Term, ...]

    @property
    def keys(self) -> set[str]:
        return {t.key for t in (*self.left, *self.right) if t.key is not None}

    def holds(self, value_of: typing.Callable[[str], float]) -> tuple[bool, float, float]:
        def side(terms):
            return sum(t.coefficient * (1.0 if t.key is None else value_of(t.key)) for t in terms)

        a, b = side(self.left), side(self.right)
        return _OPS[self.op](a, b), a, b


@dataclass(frozen=True, kw_only=True)
class MethodSettings:
    kind: Method = Method.ONE_AT_A_TIME
    points: int = 5  # one-at-a-time: per parameter
    budget: int = 40  # sample, optimize: evaluations at most
    initial: int | None = None  # optimize: the space-filling start (default: a third)
    serial: bool = False  # one-at-a-time: each parameter's best is kept for the next ones
    sampler: str = "sobol"  # or "lhs"
    seed: int = 1
    evaluation: Evaluation = Evaluation.AUTO


@dataclass(frozen=True, kw_only=True)
class Study:
    directory: Path
    base_case: Path
    overrides: tuple[str, ...]
    parameters: tuple[Parameter, ...]
    objectives: tuple[Objective, ...]
    constraints: tuple[Constraint, ...]
    method: MethodSettings
    title: str = ""

    def identity(self) -> dict:
        """What an evaluation's result depends on besides its parameters (for --resume)."""
        fields = dataclasses.asdict(self)
        fields.pop("directory")
        fields["base_case"] = str(self.base_case)
        fields.pop("title")
        for objective in fields["objectives"]:  # how the file spelt it is no part of it
            objective.pop("where")
        method = fields["method"]
        for key in ("points", "budget", "initial"):  # more points may reuse the finished ones
            method.pop(key)
        return fields


def _fail(where: str, message: str) -> typing.NoReturn:
    raise CaseError(f"{STUDY_FILE}: {where} {message}")


def _table(raw: dict, name: str, known: set[str]) -> dict:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        _fail(f"[{name}]", "must be a table")
    unknown = sorted(set(value) - known)
    if unknown:
        _fail(f"{name}.{unknown[0]}", f"is not a known key (known: {', '.join(sorted(known))})")
    return value


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        _fail(where, f"must be a finite number, got {value!r}")
    return float(value)


def _integer(where: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        _fail(where, f"must be an integer in [{low}, {high}], got {value!r}")
    return value


def numeric_field(key: str) -> tuple[type, Any]:
    """(int or float, the field's ParamSpec) of a numeric case key, else CaseError."""
    section, dot, name = key.partition(".")
    cls = SECTIONS.get(section)
    fields = {f.name: f for f in dataclasses.fields(cls)} if cls is not None and dot else {}
    if name not in fields:
        raise CaseError(f"{key!r} is not a case key (section.key, docs/case_format.md)")
    tp = typing.get_type_hints(cls)[name]
    args = [a for a in typing.get_args(tp) if a is not type(None)] or [tp]
    if args[0] not in (int, float):
        raise CaseError(f"{key!r} is not a numeric case key")
    return args[0], spec_of(fields[name])


def _bounds(spec) -> tuple[float, float, str]:
    low = spec.ge if spec.ge is not None else spec.gt
    high = spec.le if spec.le is not None else spec.lt
    shown = (
        f"{'-inf' if low is None else f'{low:g}'} {'<=' if spec.ge is not None else '<'} x "
        f"{'<=' if spec.le is not None else '<'} {'inf' if high is None else f'{high:g}'}"
    )
    return low, high, shown


def _within(value: float, spec) -> bool:
    return not (
        (spec.gt is not None and not value > spec.gt)
        or (spec.ge is not None and not value >= spec.ge)
        or (spec.lt is not None and not value < spec.lt)
        or (spec.le is not None and not value <= spec.le)
    )


def _parameter(i: int, raw: Any) -> Parameter:
    where = f"[[parameters]] #{i + 1}"
    if not isinstance(raw, dict):
        _fail(where, "must be a table with key, low, high")
    unknown = sorted(set(raw) - {"key", "low", "high"})
    if unknown:
        _fail(f"{where} {unknown[0]}", "is not a known key (known: key, low, high)")
    key = raw.get("key")
    if not isinstance(key, str):
        _fail(where, 'needs key = "section.name" (a numeric case key)')
    try:
        tp, spec = numeric_field(key)
    except CaseError as err:
        _fail("[[parameters]] key", f"{err}")
    low = _number(f"[[parameters]] {key}: low", raw.get("low"))
    high = _number(f"[[parameters]] {key}: high", raw.get("high"))
    if not low < high:
        _fail(f"[[parameters]] {key}:", f"low ({low:g}) must be less than high ({high:g})")
    for end, value in (("low", low), ("high", high)):
        if not _within(value, spec):
            valid = _bounds(spec)[2]
            unit = f" {spec.unit}" if spec.unit else ""
            _fail(
                f"[[parameters]] {key}:",
                f"{end} = {value:g} is outside the key's valid range ({valid}{unit})",
            )
    if tp is int and not (float(low).is_integer() and float(high).is_integer()):
        _fail(f"[[parameters]] {key}:", "is an integer key: low and high must be integers")
    return Parameter(key=key, low=low, high=high, integer=tp is int)


def check_quantity(quantity: Any, where: str) -> str:
    if not isinstance(quantity, str):
        _fail(where, f"must be a summary key (string), got {quantity!r}")
    match = _INDEXED.match(quantity)
    if match and match.group(1) in LIST_SUMMARY_KEYS:
        return quantity
    if quantity not in SCALAR_SUMMARY_KEYS:
        _fail(
            where,
            f"{quantity!r} is not a numeric key of fsi-run's --json summary (e.g. "
            f"tip_amplitude_m, mean_thrust_n, wet_hz[0]; all: docs/design.md)",
        )
    return quantity


def _objective(raw: Any, where: str) -> Objective:
    if not isinstance(raw, dict):
        _fail(where, "must be a table with quantity and sense")
    unknown = sorted(set(raw) - {"quantity", "sense", "weight"})
    if unknown:
        _fail(f"{where} {unknown[0]}", "is not a known key (known: quantity, sense, weight)")
    quantity = check_quantity(raw.get("quantity"), f"{where} quantity")
    sense = raw.get("sense", "max")
    if sense not in ("max", "min"):
        _fail(f"{where} sense", f'must be "max" or "min", got {sense!r}')
    weight = _number(f"{where} weight", raw.get("weight", 1.0))
    if not weight > 0:
        _fail(f"{where} weight", f"must be > 0, got {weight:g}")
    return Objective(quantity=quantity, sense=Sense(sense), weight=weight, where=where)


_TOKEN = re.compile(r"\s*(<=|>=|<|>|\*|\+|-|[0-9.]+(?:[eE][-+]?\d+)?|[a-z_]+\.[a-z0-9_]+)")


def parse_constraint(text: str) -> Constraint:
    """``"geometry.peduncle_height_m <= geometry.caudal_fin_height_m"``, also with numbers,
    ``2 * key`` and sums; CaseError naming the expression otherwise."""
    where = f"[[constraints]] {text!r}:"
    tokens, pos = [], 0
    while pos < len(text.rstrip()):
        m = _TOKEN.match(text, pos)
        if m is None:
            _fail(where, f"cannot read it at {text[pos:].strip()[:20]!r} (use: a <= b, 2 * a + c)")
        tokens.append(m.group(1))
        pos = m.end()
    ops = [i for i, t in enumerate(tokens) if t in _OPS]
    if len(ops) != 1:
        _fail(where, "needs exactly one of <=, >=, <, >")
    i = ops[0]
    left, right = _side(tokens[:i], where), _side(tokens[i + 1 :], where)
    constraint = Constraint(expression=text, left=left, op=tokens[i], right=right)
    for key in sorted(constraint.keys):
        try:
            numeric_field(key)
        except CaseError as err:
            _fail(where, str(err))
    return constraint


def _side(tokens: list[str], where: str) -> tuple[Term, ...]:
    terms, sign, coefficient, expect_term = [], 1.0, None, True
    for t in tokens:
        if expect_term and t in "+-":
            sign = -sign if t == "-" else sign
        elif expect_term and (t[0].isdigit() or t[0] == "."):
            coefficient = sign * float(t) if coefficient is None else coefficient * float(t)
            expect_term = False
        elif expect_term and "." in t and t[0].isalpha():
            c = coefficient if coefficient is not None else sign
            terms.append(Term(coefficient=c, key=t))
            sign, coefficient, expect_term = 1.0, None, False
        elif not expect_term and t == "*" and coefficient is not None:
            expect_term = True
        elif not expect_term and t in "+-":
            if coefficient is not None:
                terms.append(Term(coefficient=coefficient, key=None))
            sign, coefficient, expect_term = (-1.0 if t == "-" else 1.0), None, True
        else:
            _fail(where, f"unexpected {t!r}")
    if expect_term:
        _fail(where, "a side ends without a term")
    if coefficient is not None:
        terms.append(Term(coefficient=coefficient, key=None))
    return tuple(terms)


def _method(raw: dict) -> MethodSettings:
    m = _table(raw, "method", {f.name for f in dataclasses.fields(MethodSettings)})
    kinds = {k.value for k in Method}
    kind = m.get("kind", "one-at-a-time")
    if kind not in kinds:
        _fail("method.kind", f"must be one of {', '.join(sorted(kinds))}, got {kind!r}")
    evaluation = m.get("evaluation", "auto")
    if evaluation not in {e.value for e in Evaluation}:
        _fail("method.evaluation", f'must be "auto", "linear" or "transient", got {evaluation!r}')
    sampler = m.get("sampler", "sobol")
    if sampler not in ("sobol", "lhs"):
        _fail("method.sampler", f'must be "sobol" or "lhs", got {sampler!r}')
    serial = m.get("serial", False)
    if not isinstance(serial, bool):
        _fail("method.serial", f"must be true or false, got {serial!r}")
    budget = _integer("method.budget", m.get("budget", 40), 1, 100_000)
    initial = m.get("initial")
    if initial is not None:
        initial = _integer("method.initial", initial, 2, budget)
    return MethodSettings(
        kind=Method(kind),
        points=_integer("method.points", m.get("points", 5), 2, 10_000),
        budget=budget,
        initial=initial,
        serial=serial,
        sampler=sampler,
        seed=_integer("method.seed", m.get("seed", 1), 0, 2**31 - 1),
        evaluation=Evaluation(evaluation),
    )


def _read(path: Path) -> dict:
    if not path.is_file():
        raise CaseError(f"{path.parent}: no {STUDY_FILE} found (a study is a folder with one)")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError) as err:
        raise CaseError(f"{path}: cannot read it ({err})") from None
    except tomllib.TOMLDecodeError as err:
        raise CaseError(f"{STUDY_FILE}: not valid TOML: {err}") from None


def load_study(directory: str | Path) -> Study:
    """The validated study in ``directory/study.toml``; CaseError (one line, naming the file)
    otherwise."""
    given = Path(directory)
    path = given / STUDY_FILE if given.name != STUDY_FILE else given
    try:
        return _load_study(path)
    except CaseError as err:
        text = str(err)
        if text.startswith(f"{STUDY_FILE}: "):
            raise CaseError(f"{path}: {text.removeprefix(f'{STUDY_FILE}: ')}") from None
        raise


def _load_study(path: Path) -> Study:
    directory = path.parent.resolve()
    raw = _read(path)
    known = {"study", "base", "parameters", "objective", "objectives", "constraints", "method"}
    unknown = sorted(set(raw) - known)
    if unknown:
        _fail(f"[{unknown[0]}]", f"is not a known section (known: {', '.join(sorted(known))})")
    info = _table(raw, "study", {"title"})
    base = _table(raw, "base", {"case", "overrides"})
    if not isinstance(base.get("case"), str):
        _fail("base.case", "is required: the case folder, relative to the study folder")
    overrides = base.get("overrides", [])
    if not isinstance(overrides, list) or not all(isinstance(o, str) for o in overrides):
        _fail("base.overrides", "must be a list of --set lines (section.key=value)")
    parameters = raw.get("parameters")
    if not isinstance(parameters, list) or not parameters:
        _fail("[[parameters]]", "is required: at least one table with key, low, high")
    params = tuple(_parameter(i, p) for i, p in enumerate(parameters))
    if len({p.key for p in params}) != len(params):
        _fail("[[parameters]]", "names a key twice")
    if ("objective" in raw) == ("objectives" in raw):
        _fail("[objective]", "is required (or a list [[objectives]] with weights), not both")
    if "objective" in raw:
        objectives: tuple[Objective, ...] = (_objective(raw["objective"], "[objective]"),)
    else:
        listed = raw["objectives"]
        if not isinstance(listed, list) or not listed:
            _fail("[[objectives]]", "must be a non-empty list of tables")
        objectives = tuple(_objective(o, f"[[objectives]] #{i + 1}") for i, o in enumerate(listed))
    constraints = raw.get("constraints", [])
    if not isinstance(constraints, list):
        _fail("[[constraints]]", "must be a list of tables with expression")
    parsed = []
    for i, c in enumerate(constraints):
        if (
            not isinstance(c, dict)
            or set(c) != {"expression"}
            or not isinstance(c["expression"], str)
        ):
            _fail(f"[[constraints]] #{i + 1}", 'must be a table with expression = "a <= b"')
        parsed.append(parse_constraint(c["expression"]))
    method = _method(raw)
    if method.evaluation is Evaluation.LINEAR:
        _check_linear(objectives)
    study = Study(
        directory=directory,
        base_case=(directory / base["case"]).resolve(),
        overrides=tuple(overrides),
        parameters=params,
        objectives=objectives,
        constraints=tuple(parsed),
        method=method,
        title=str(info.get("title", "")),
    )
    check_base(study)
    return study


# what the linear periodic response (and the modal path beside it) gives
LINEAR_QUANTITIES = ("tip_amplitude_m", "mean_thrust_n", "slender_body_mean_thrust_n")
MODAL_QUANTITIES = (
    "dry_hz",
    "wet_hz",
    "wet_hz_at_mean_voltage",
    "added_mass_kg",
    "plate_mass_kg",
)
# what a prescribed swimming.speed_m_s sets
SPEED_QUANTITIES = ("swimming_speed_m_s", "body_lengths_per_s", "swimming_number")
# what a swimming case's summary gives (the fast model's row at the case's drive)
SWIMMING_QUANTITIES = (
    *LINEAR_QUANTITIES,
    *SCALAR_SUMMARY_KEYS[SCALAR_SUMMARY_KEYS.index("swimming_speed_m_s") :],
)


def _check_linear(objectives: tuple[Objective, ...]) -> None:
    for o in objectives:
        match = _INDEXED.match(o.quantity)
        name = match.group(1) if match else o.quantity
        known = (*SWIMMING_QUANTITIES, *MODAL_QUANTITIES, "mean_voltage_buckling_factor")
        if name not in known:
            _fail(
                "method.evaluation",
                f'= "linear" cannot give {o.quantity!r} (it gives '
                f"{', '.join(LINEAR_QUANTITIES)}, a swimming case's keys and the modal keys); use "
                '"auto" or "transient"',
            )


def check_base(study: Study) -> None:
    """The base case loads, and every parameter applies to it (a fish key on a rectangle is
    refused by the case loader): one line naming the key."""
    try:
        base = load_case(study.base_case, study.overrides, allow_empty=False)
    except CaseError as err:
        _fail("base:", str(err))
    _check_swimming(study, base.analysis.kind.value, base.fluid.model.value)
    varied = {p.key for p in study.parameters}
    if base.swimming.speed_m_s is not None and "swimming.speed_m_s" not in varied:
        fixed = [o for o in study.objectives if o.quantity in SPEED_QUANTITIES]
        if fixed:
            _fail(
                f"{fixed[0].where} quantity",
                f"{fixed[0].quantity!r} is fixed by the base's swimming.speed_m_s = "
                f"{base.swimming.speed_m_s:g} (a flume's speed): unset it for the "
                "self-propelled speed",
            )
    for p in study.parameters:
        mid = p.value(0.5)
        try:
            load_case(study.base_case, [*study.overrides, f"{p.key}={mid!r}"])
        except CaseError as err:
            _fail(f"[[parameters]] {p.key}:", f"does not apply to the base case ({err})")


def _check_swimming(study: Study, kind: str, fluid: str) -> None:
    """A swimming base case answers its summary's keys and the modal keys; the swimming keys
    need such a base. One line naming the objective."""
    swimming_only = set(SWIMMING_QUANTITIES) - set(LINEAR_QUANTITIES)
    for o in study.objectives:
        match = _INDEXED.match(o.quantity)
        name = match.group(1) if match else o.quantity
        where = f"{o.where} quantity"
        if kind != "swimming" and name in swimming_only:
            _fail(where, f'{o.quantity!r} needs a swimming base case (analysis.kind = "swimming")')
        modal = name in (*MODAL_QUANTITIES, "mean_voltage_buckling_factor")
        if kind == "swimming" and not (modal or name in SWIMMING_QUANTITIES):
            _fail(
                where,
                f"{o.quantity!r} is not given by a swimming base case (it gives its summary's "
                "keys, e.g. swimming_speed_m_s, and the modal keys); set analysis.kind in the "
                "base for a time march",
            )
    if kind == "swimming" and study.method.evaluation is Evaluation.TRANSIENT:
        _fail(
            "method.evaluation",
            '= "transient" does not apply to a swimming base case (the fast model evaluates '
            'it); use "auto"',
        )
    if kind == "swimming" and fluid == "openfoam":
        _fail(
            "base:",
            'a design study evaluates swimming with the fast model: set fluid.model = "potential" '
            "in the base (a flume with OpenFOAM is one fsi-run per speed)",
        )
