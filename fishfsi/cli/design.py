"""``fsi-design STUDY_DIR``: a design study (docs/design.md).

Reads ``STUDY_DIR/study.toml`` (base case, parameters with ranges, objectives, constraints,
method), evaluates its designs (the linear periodic response where it answers, the modal path
for mode frequencies, a time march otherwise), and writes into ``--output`` (default
``STUDY_DIR/output``): ``evaluations.csv`` / ``.h5``, ``evaluations/NNNN/`` (each design's
``case.toml`` and ``summary.json``), ``response.png``, ``history.png`` (``pareto.png`` and
``pareto.json`` for two objectives) and ``best_case/case.toml``. In parallel over
``--workers`` processes, or over the MPI ranks under mpiexec/srun (as fsi-sweep).
``--resume`` reuses every finished evaluation of the same study. ``--confirm K`` re-runs the
best K designs with OpenFOAM at the coarse level and says whether the ranking holds.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from fsi_orchestrator.case import CaseError

from ..design.evaluate import (
    Design,
    EvaluationSpec,
    atomic_write,
    evaluate,
    finite,
    is_ok,
)
from ..design.methods import best_of, pareto_front, run_method
from ..design.outputs import plot_all, write_best_case, write_pareto, write_tables
from ..design.runner import (
    Evaluator,
    prepare_output,
    refuse_earlier_study,
    serve,
    study_identity,
)
from ..design.study import Evaluation, Study, load_study
from .common import (
    EXIT_OK,
    OneLineParser,
    add_version,
    emit,
    guarded,
    json_text,
    output_folder,
    plural,
)
from .sweep import mpi_world


def progress_line(record: dict, study: Study) -> str:
    shown = ", ".join(f"{k.partition('.')[2]}={v:.4g}" for k, v in record["parameters"].items())
    if is_ok(record):
        result = ", ".join(f"{q} = {v:.5g}" for q, v in record["objectives"].items())
        how = f"{record['fidelity'].get('method', '')}, "
    else:
        result, how = f"{record['status']}: {record['reason']}", ""
    wall = record["wall_s"]
    return f"design {record['index']:04d} [{shown or 'base'}]: {result} ({how}{wall:.1f} s)"


def study_summary(study: Study, evaluator: Evaluator, output: Path, wall_s: float) -> dict:
    records = evaluator.all_records()
    best = best_of(records)
    counts = {s: sum(r["status"] == s for r in records) for s in ("ok", "infeasible", "failed")}
    summary: dict = {
        "evaluations": len(records),
        "evaluated_now": evaluator.evaluated,
        "resumed": evaluator.reused,
        **counts,
        "method": study.method.kind.value,
        "objectives": [o.quantity for o in study.objectives],
    }
    if best is not None:
        single = len(study.objectives) == 1
        summary["best"] = {
            "parameters": best["parameters"],
            "objective": best["objectives"][study.objectives[0].quantity]
            if single
            else best["score"],
            "objectives": best["objectives"],
            "fidelity": best["fidelity"],
            "evaluation": f"{best['index']:04d}",
            "case": str(output / "best_case"),
        }
    if len(study.objectives) >= 2:
        summary["pareto"] = [
            {"parameters": r["parameters"], "objectives": r["objectives"]}
            for r in pareto_front(records, study)
        ]
    summary.update(output=str(output), wall_s=wall_s)
    return summary


def finish(study: Study, evaluator: Evaluator, output: Path, quiet: bool) -> dict | None:
    """Tables, plots and the best case from every evaluation so far; the best record."""
    records = evaluator.all_records()
    write_tables(records, study, output)
    best = best_of(records)
    if best is None:
        return None
    front = pareto_front(records, study) if len(study.objectives) >= 2 else []
    if front:
        write_pareto(front, study, output)
    plot_all(records, study, output, front)
    write_best_case(best, output)
    return best


# OpenFOAM as the main job couples it (cases/fixed_head_3Hz): one fluid step per window
# (sub-stepped windows made converged coupled runs oscillate, docs/coupling.md) and
# pimpleFoam kept loaded
CONFIRM_OVERRIDES = (
    "fluid.model=openfoam",
    "fluid.mesh_level=coarse",
    "fluid.max_courant=10",
    "fluid.driver=persistent",
)


def confirm(study: Study, records: list[dict], k: int, output: Path, say) -> dict:
    """The best k designs again, with OpenFOAM (coarse) in the time march: their objectives
    and whether the fast model's ranking holds."""
    ranked = sorted((r for r in records if is_ok(r)), key=lambda r: -r["score"])[:k]
    spec = EvaluationSpec.of(study, output)
    spec = dataclasses.replace(
        spec,
        overrides=(*spec.overrides, *CONFIRM_OVERRIDES),
        evaluation=Evaluation.TRANSIENT,
        folder=output / "confirm",
    )
    rows = []
    for rank, r in enumerate(ranked):
        say(f"confirm: design {r['index']:04d} with OpenFOAM (coarse), {rank + 1} of {len(ranked)}")
        again = evaluate(spec, Design(index=r["index"], values=r["parameters"], stage="confirm"))
        rows.append(
            {
                "evaluation": f"{r['index']:04d}",
                "fast": r["objectives"],
                "openfoam": again["objectives"],
                "openfoam_status": again["status"],
                "openfoam_score": again["score"],
            }
        )
    scores = [finite(row["openfoam_score"]) for row in rows]
    holds = all(math.isfinite(s) for s in scores) and all(
        a >= b for a, b in zip(scores, scores[1:], strict=False)
    )
    result = {"designs": rows, "ranking_holds": holds}
    atomic_write(output / "confirm.json", json_text(result, indent=1))
    return result


def _design(args: argparse.Namespace) -> int:
    comm = mpi_world()  # first: a mismatched launch stops before any work
    rank = comm.Get_rank() if comm is not None else 0
    study = load_study(args.study)
    output = output_folder(args.output, study.directory / "output")
    output = output.resolve()
    if args.workers < 1:
        raise CaseError(f"--workers must be >= 1, got {args.workers}")
    if args.confirm < 0:
        raise CaseError(f"--confirm must be >= 0 (designs to re-run), got {args.confirm}")
    if args.resume and args.overwrite:
        raise CaseError("--resume and --overwrite exclude each other: continue, or replace")
    spec = EvaluationSpec.of(study, output)
    identity = study_identity(study, spec)
    refuse_earlier_study(output, identity, args.resume, args.overwrite)  # every rank, first
    if rank != 0:
        serve(comm, spec)
        return EXIT_OK

    def say(line: str) -> None:
        if not args.quiet:
            print(line, file=sys.stderr, flush=True)

    start = time.perf_counter()
    done = prepare_output(output, identity, args.resume, args.overwrite)
    evaluator = Evaluator(
        spec,
        done,
        workers=args.workers,
        comm=comm,
        on_record=lambda r: say(progress_line(r, study)),
        # the tables after every batch: a killed study's are never older than a batch
        on_batch=lambda: write_tables(evaluator.all_records(), study, output),
    )
    size = comm.Get_size() if comm is not None else args.workers
    say(
        f"design: {study.method.kind.value}, {plural(len(study.parameters), 'parameter')}, "
        f"into {output} ({plural(size, 'MPI rank' if comm is not None else 'worker')}"
        f"{f', {len(done)} finished before (--resume)' if args.resume else ''})"
    )
    try:
        run_method(study, evaluator)
    finally:
        evaluator.close()
        best = finish(study, evaluator, output, args.quiet)
    records = evaluator.all_records()
    if best is None:
        reasons = sorted({r["reason"] for r in records})
        raise CaseError(
            f"{study.directory / 'study.toml'}: all {len(records)} designs are infeasible or "
            f"failed (e.g. {reasons[0] if reasons else 'none evaluated'}); see "
            f"{output / 'evaluations.csv'}"
        )
    summary = study_summary(study, evaluator, output, time.perf_counter() - start)
    if args.confirm:
        summary["confirm"] = confirm(study, records, args.confirm, output, say)
    if args.json:
        print(json_text(summary))
    else:
        emit({k: v for k, v in summary.items() if k not in ("best", "pareto")}, False)
        b = summary["best"]
        print(f"best (evaluation {b['evaluation']}): {json_text(b['parameters'])}")
        print(f"  {json_text(b['objectives'])} -> {b['case']}")
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineParser(
        prog="fsi-design",
        description="A design study: parameters, objectives and constraints over a base case.",
        epilog="study.toml keys, methods and outputs: docs/design.md.",
    )
    add_version(parser)
    parser.add_argument("study", help="study folder (holding study.toml)")
    parser.add_argument("--output", help="output folder (default: STUDY_DIR/output)")
    parser.add_argument("--json", action="store_true", help="print the study summary as JSON")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="reuse the finished evaluations in --output (same study) and run the rest",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the evaluations an earlier study left in --output",
    )
    parser.add_argument(
        "--workers", type=int, default=1, help="evaluations in parallel processes (default 1)"
    )
    parser.add_argument(
        "--confirm",
        type=int,
        default=0,
        metavar="K",
        help="re-run the best K designs with OpenFOAM (coarse level) and compare the ranking",
    )
    parser.add_argument("--quiet", action="store_true", help="no line per evaluation")
    args = parser.parse_args(argv)
    return guarded(lambda: _design(args))


if __name__ == "__main__":
    raise SystemExit(main())
