"""One design: the base case, the study's ``--set`` lines and the design's parameter values,
checked against the constraints and evaluated in-process by the cheapest path that answers
the objectives.

- ``tip_amplitude_m``, ``mean_thrust_n`` (slender body) of a dynamic case with a fast fluid
  (none, potential, slender_body): the linear periodic response about the mean-voltage
  equilibrium, ``fsi-sweep --method linear``'s ``linear_sweep`` at the case's drive.
- ``wet_hz[i]``, ``dry_hz[i]`` and the modal case's keys: ``fsi-modal``'s ``modal_summary``.
- a swimming case's keys (``swimming_speed_m_s``, ...): ``fsi-run``'s ``swimming_summary``.
- everything else, and any case with OpenFOAM: the time march of ``fsi-run``
  (``run_dynamic``), into the evaluation's folder.

An evaluation returns a record (a dict of JSON values) and keeps ``case.toml`` (the resolved
case, ready for ``fsi-run``) and ``summary.json`` (the record, written last and atomically:
its presence means the evaluation finished) in ``evaluations/NNNN/``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.loader import CASE_FILE, case_from_dict, merge_overrides
from fsi_orchestrator.case.planform import resolve_fish
from fsi_orchestrator.case.schema import AnalysisKind, FluidModel, GeometryKind

from ..cli.common import atomic_write, json_text  # one writer for every table and record
from .study import (
    _INDEXED,
    LINEAR_QUANTITIES,
    MODAL_QUANTITIES,
    Constraint,
    Evaluation,
    Objective,
    Study,
)

LINEAR_KEYS = frozenset(LINEAR_QUANTITIES)
MODAL_KEYS = frozenset({*MODAL_QUANTITIES, "mean_voltage_buckling_factor"})
SUMMARY_FILE = "summary.json"
OK, INFEASIBLE, FAILED = "ok", "infeasible", "failed"


@dataclass(frozen=True, kw_only=True)
class EvaluationSpec:
    """What every evaluation of a study shares (picklable: it goes to the pool's processes
    and the MPI ranks)."""

    base_case: Path
    base_raw: dict
    overrides: tuple[str, ...]
    objectives: tuple[Objective, ...]
    constraints: tuple[Constraint, ...]
    evaluation: Evaluation
    folder: Path  # OUTPUT/evaluations

    @classmethod
    def of(cls, study: Study, output: Path) -> EvaluationSpec:
        path = study.base_case / CASE_FILE
        return cls(
            base_case=study.base_case,
            base_raw=tomllib.loads(path.read_text(encoding="utf-8-sig")),
            overrides=study.overrides,
            objectives=study.objectives,
            constraints=study.constraints,
            evaluation=study.method.evaluation,
            folder=output / "evaluations",
        )


@dataclass(frozen=True, kw_only=True)
class Design:
    index: int
    values: dict[str, float | int]  # parameter key -> value
    stage: str = ""  # where the method asked for it: the varied key, "initial", "generation 2"


def design_key(values: dict[str, float | int]) -> str:
    """A design's identity among a study's evaluations (12 significant digits)."""
    return json.dumps({k: float(f"{v:.12g}") for k, v in sorted(values.items())})


def set_lines(values: dict[str, float | int]) -> list[str]:
    return [f"{k}={v!r}" for k, v in values.items()]


def resolved_raw(spec: EvaluationSpec, values: dict[str, float | int]) -> dict:
    return merge_overrides(spec.base_raw, [*spec.overrides, *set_lines(values)])


def evaluate(spec: EvaluationSpec, design: Design) -> dict:
    """The record of one design; never raises for a design the model refuses or cannot
    solve (its status and reason say why)."""
    from solid_adapter.solvers import SolverError  # the composition root may know adapters

    start = time.perf_counter()
    folder = spec.folder / f"{design.index:04d}"
    folder.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {
        "index": design.index,
        "key": design_key(design.values),
        "stage": design.stage,
        "parameters": dict(design.values),
        "status": OK,
        "reason": "",
        "objectives": {o.quantity: math.nan for o in spec.objectives},
        "score": math.nan,
        "fidelity": {},
        "summary": {},
    }
    raw = resolved_raw(spec, design.values)
    atomic_write(folder / CASE_FILE, case_toml(raw, spec, design))
    try:
        case = case_from_dict(raw, spec.base_case)
        check_design(case, spec.constraints, design.values)
    except CaseError as err:
        record.update(status=INFEASIBLE, reason=str(err).removeprefix("case.toml: "))
    else:
        try:
            summary, fidelity = run_design(case, spec, folder)
            record.update(summary=summary, fidelity=fidelity)
            values = {o.quantity: quantity_of(summary, o.quantity) for o in spec.objectives}
            record["objectives"] = values
            bad = [q for q, v in values.items() if not math.isfinite(v)]
            if bad:
                record.update(status=FAILED, reason=_why_not_finite(bad, summary))
            else:
                record["score"] = sum(o.score(values[o.quantity]) for o in spec.objectives)
                record["reason"] = "; ".join(summary.get("notes", []))  # the model's reach
        except CaseError as err:  # a design the model refuses (a buckling mean voltage)
            record.update(status=INFEASIBLE, reason=str(err).removeprefix("case.toml: "))
        except (SolverError, RuntimeError, ValueError, ArithmeticError) as err:
            first = str(err).splitlines()[0] if str(err) else type(err).__name__
            record.update(status=FAILED, reason=first)
    record["wall_s"] = time.perf_counter() - start
    atomic_write(folder / SUMMARY_FILE, json_text(record, indent=1))
    return record


def _why_not_finite(bad: list[str], summary: dict) -> str:
    missing = [q for q in bad if summary.get(_base_name(q)) is None]
    if missing and summary.get("swimming_speed_m_s") == 0:
        return f"{', '.join(missing)} not given: the fish does not swim (swimming_speed_m_s = 0)"
    if missing:
        return f"{', '.join(missing)} not given by this design's evaluation"
    return f"{', '.join(bad)} not finite"


def check_design(case: Case, constraints: tuple[Constraint, ...], values: dict) -> None:
    """The design's plate fits its clamp and tank, its outline is valid (the geometry's own
    checks), and the study's constraints hold; else CaseError saying which does not."""
    from ..cli.common import check_plausible

    check_plausible(case)
    for c in constraints:
        ok, a, b = c.holds(lambda key: resolved_value(case, key, values))
        if not ok:
            raise CaseError(f"constraint {c.expression!r} does not hold ({a:.6g} vs {b:.6g})")


def resolved_value(case: Case, key: str, values: dict) -> float:
    """A numeric case key's value in this design: the parameter's, the case's, or (a fish
    dimension left to the preset) the preset's."""
    if key in values:
        return float(values[key])
    section, _, name = key.partition(".")
    value = getattr(getattr(case, section), name)
    if value is None and section == "geometry" and case.geometry.kind is GeometryKind.FISH:
        value = getattr(resolve_fish(case), name, None)
    if value is None:
        raise CaseError(f"constraint: {key} has no value in this case (give it in the base)")
    return float(value)


def quantity_of(summary: dict, quantity: str) -> float:
    match = _INDEXED.match(quantity)
    if match:
        values = summary.get(match.group(1)) or []
        i = int(match.group(2))
        return float(values[i]) if i < len(values) and values[i] is not None else math.nan
    value = summary.get(quantity)
    return math.nan if value is None else float(value)


def _base_name(quantity: str) -> str:
    match = _INDEXED.match(quantity)
    return match.group(1) if match else quantity


def linear_applies(case: Case) -> bool:
    """The linear periodic response answers for a driven dynamic case with a fast fluid whose
    added mass sits in the structure's inertia."""
    return (
        case.analysis.kind is AnalysisKind.DYNAMIC
        and case.geometry.kind is not GeometryKind.RECTANGLE
        and case.fluid.model is not FluidModel.OPENFOAM
        and not case.coupling.partitioned
        and case.time.step_s is None
    )


def run_design(case: Case, spec: EvaluationSpec, folder: Path) -> tuple[dict, dict]:
    """(summary with fsi-run --json's keys, fidelity) of the cheapest paths answering the
    objectives."""
    wanted = {_base_name(o.quantity) for o in spec.objectives}
    summary: dict = {}
    fidelity: dict = {"shell_mesh": mesh_name(case), "fluid": case.fluid.model.value}
    if case.fluid.model is not FluidModel.NONE:
        fidelity["fluid_mesh"] = case.fluid.mesh_level.value
    methods = []
    modal = wanted & MODAL_KEYS
    if modal:
        summary.update(modal_figures(case, spec.objectives))
        methods.append("modal")
    rest = wanted - MODAL_KEYS
    if rest and case.analysis.kind is AnalysisKind.SWIMMING:
        summary.update(swimming_figures(case))
        fidelity.update(modes=_sweep_modes(), samples_per_period=_samples())
        methods.append("swimming")
    elif rest:
        use_linear = spec.evaluation is Evaluation.LINEAR or (
            spec.evaluation is Evaluation.AUTO and rest <= LINEAR_KEYS and linear_applies(case)
        )
        if use_linear:
            summary.update(linear_figures(case))
            fidelity.update(modes=_sweep_modes(), samples_per_period=_samples())
            methods.append("linear")
        else:
            summary.update(transient_figures(case, folder / "run"))
            fidelity.update(steps_per_period=case.time.steps_per_period, periods=case.time.periods)
            methods.append("transient")
    fidelity["method"] = "+".join(methods)
    return summary, fidelity


def mesh_name(case: Case) -> str:
    m = case.mesh
    if m.elements_length or m.elements_width:
        return f"{m.elements_length or '-'}x{m.elements_width or '-'}"
    return m.level.value


def _sweep_modes() -> int:
    from ..cli.fast_model import MODES

    return MODES


def _samples() -> int:
    from ..cli.linear import SAMPLES_PER_PERIOD

    return SAMPLES_PER_PERIOD


def linear_figures(case: Case) -> dict:
    """fsi-sweep --method linear's row at the case's own drive, under fsi-run's keys."""
    from ..cli.fast_model import without_cfd
    from ..cli.linear import linear_sweep

    case = without_cfd(case)
    (row,) = linear_sweep(
        case, [case.actuation.frequency_hz], [case.actuation.waveform], notes=False
    )
    if row["status"] != "ok":
        raise RuntimeError(row["status"].removeprefix("failed: "))
    figures = {"tip_amplitude_m": row["tip_amplitude_m"]}
    if "slender_body_mean_thrust_n" in row:  # not in vacuum
        figures |= {
            "slender_body_mean_thrust_n": row["slender_body_mean_thrust_n"],
            "mean_thrust_n": row["mean_thrust_n"],
            "thrust_source": "slender_body",
        }
    return figures


def swimming_figures(case: Case) -> dict:
    """fsi-run --json's summary of a swimming case: the fast model at the case's drive."""
    from ..cli.fast_model import without_cfd
    from ..cli.linear import swimming_summary

    summary = swimming_summary(without_cfd(case), say_notes=False)  # in the record's reason
    summary.pop("wall_s", None)
    return summary


def modal_figures(case: Case, objectives: tuple[Objective, ...]) -> dict:
    """fsi-modal's summary, with enough modes for the indexed objectives."""
    from ..cli.modal import modal_summary

    needed = [int(m.group(2)) + 1 for o in objectives if (m := _INDEXED.match(o.quantity))]
    if needed and max(needed) > case.analysis.num_modes:
        analysis = dataclasses.replace(case.analysis, num_modes=max(needed))
        case = dataclasses.replace(case, analysis=analysis)
    driven = any(_base_name(o.quantity) == "wet_hz_at_mean_voltage" for o in objectives)
    summary = modal_summary(case, at_mean_voltage=driven, refuse_a_buckling_mean=driven)
    summary.pop("wall_s", None)
    return summary


def transient_figures(case: Case, folder: Path) -> dict:
    """fsi-run's summary of the time march (a dynamic case), run afresh in ``folder``."""
    from ..cli.run import run_dynamic

    if case.analysis.kind is not AnalysisKind.DYNAMIC:
        raise CaseError(
            f'the objectives need a time march, but analysis.kind = "{case.analysis.kind}"'
        )
    summary = run_dynamic(case, folder, resume=False, show_progress=False)
    summary.pop("wall_s", None)
    return summary


# --------------------------------------------------------------------------- files


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(int(value))
    if isinstance(value, float):  # numpy's float64 too: its repr is not TOML
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for every printable text
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {value!r}")  # case sections hold no other values


def case_toml(raw: dict, spec: EvaluationSpec, design: Design) -> str:
    """A case file for fsi-run: the base's keys, the study's overrides and the design's
    values (the base's comments are not kept)."""
    lines = [
        f"# design {design.index:04d} of a design study (fsi-design): the base case "
        f"{spec.base_case}",
        *(f"# --set {s}" for s in [*spec.overrides, *set_lines(design.values)]),
    ]
    for section, table in raw.items():
        if not isinstance(table, dict):
            continue
        lines.append(f"\n[{section}]")
        for key, value in table.items():
            name = key if _BARE_KEY.match(key) else json.dumps(key)
            lines.append(f"{name} = {toml_value(value)}")
    return "\n".join(lines) + "\n"


def read_record(folder: Path) -> dict | None:
    try:
        record = json.loads((folder / SUMMARY_FILE).read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "key" in record else None


def finite(value: Any) -> float:
    return float(value) if value is not None else math.nan


def is_ok(record: dict) -> bool:
    return record.get("status") == OK and np.isfinite(finite(record.get("score")))
