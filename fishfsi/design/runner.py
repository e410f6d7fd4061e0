"""Runs a study's designs: each one once (a design asked for again, or finished before a
``--resume``, is looked up), in batches, in this process, a process pool or over MPI ranks.

Every finished evaluation is on disk (``evaluations/NNNN/summary.json``) before the next batch
starts; the tables are merged from those files. ``OUTPUT/study.json`` holds the study's
identity: ``--resume`` refuses an output folder of another study.
"""

from __future__ import annotations

import concurrent.futures as futures
import json
import shutil
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from fsi_orchestrator.case import CaseError

from .evaluate import Design, EvaluationSpec, design_key, evaluate, finite, is_ok, read_record
from .study import Study

IDENTITY_FILE = "study.json"

OnRecord = Callable[[dict], None]


EVALUATION_REVISION = 2


def study_identity(study: Study, spec: EvaluationSpec) -> dict:
    from fsi_orchestrator import __version__
    from fsi_orchestrator.case.schema import Fluid

    identity = {
        "version": __version__,
        "study": study.identity(),
        "base": spec.base_raw,
        # the fast thrust's default KC0: records of Lighthill's thrust alone do not resume
        "fast_thrust_shedding_kc": Fluid().thrust_shedding_kc,
        # raised where the same inputs are evaluated otherwise (2: a swimming base case's
        # keys by the fast model, where designs had been recorded infeasible)
        "evaluation_revision": EVALUATION_REVISION,
    }
    return json.loads(json.dumps(identity, default=str))


def refuse_earlier_study(output: Path, identity: dict, resume: bool, overwrite: bool) -> None:
    """An earlier study's evaluations are kept unless --resume (of the same study) or
    --overwrite says otherwise. A read alone: every MPI rank calls it before rank 0 changes
    anything, so all stop together (a rank waiting in serve() for a study that rank 0 refused
    would wait forever)."""
    evaluations = output / "evaluations"
    identity_file = output / IDENTITY_FILE

    def held() -> int:
        if not evaluations.is_dir():
            return 0
        return sum(1 for folder in evaluations.iterdir() if read_record(folder) is not None)

    if resume and (identity_file.is_file() or held()):
        try:
            old = json.loads(identity_file.read_text())
        except (OSError, ValueError):
            old = None
        if old != identity:
            if old is None:  # evaluations whose study is unknown are no safer to reuse
                why = f"a study it cannot tell ({IDENTITY_FILE} is missing or damaged)"
            else:
                why = "another study (its study.toml, base case or version differ)"
            raise CaseError(
                f"--resume: {output} holds evaluations of {why}; use another --output, or "
                "replace them with --overwrite"
            )
    if resume or overwrite:
        return
    count = held()
    if count:
        raise CaseError(
            f"--output {output}: holds {count} evaluations of an earlier study; continue it "
            "with --resume, write elsewhere with --output, or replace it with --overwrite"
        )


def prepare_output(
    output: Path, identity: dict, resume: bool, overwrite: bool = False
) -> dict[str, dict]:
    """The finished records to reuse (by design key) with ``resume``, else none. An earlier
    study's evaluations in ``output`` are refused, or go with ``overwrite``."""
    from .evaluate import atomic_write

    evaluations = output / "evaluations"
    try:
        evaluations.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        why = "it is a file" if output.is_file() else err.strerror
        raise CaseError(f"--output {output}: cannot write there ({why})") from None
    identity_file = output / IDENTITY_FILE
    done: dict[str, dict] = {}
    refuse_earlier_study(output, identity, resume, overwrite)
    if resume:
        for folder in sorted(evaluations.iterdir()):
            record = read_record(folder)
            if record is not None and finished(record):
                done[record["key"]] = record  # a failed or damaged design is tried again
    else:
        try:
            shutil.rmtree(evaluations)
            evaluations.mkdir()
        except OSError as err:
            raise CaseError(
                f"--overwrite: cannot replace {err.filename or evaluations} ({err.strerror}); "
                "make the folder writable or use another --output"
            ) from None
        shutil.rmtree(output / "best_case", ignore_errors=True)  # an earlier study's
    atomic_write(identity_file, json.dumps(identity, indent=1))
    return done


def finished(record: dict) -> bool:
    """A record to reuse: infeasible, or ok with every figure finite (a summary damaged to
    NaN is evaluated again)."""
    if record.get("status") == "infeasible":
        return True
    objectives = record.get("objectives")
    try:
        return (
            is_ok(record)
            and isinstance(objectives, dict)
            and all(np.isfinite(finite(v)) for v in objectives.values())
        )
    except (TypeError, ValueError):  # a figure that is no number
        return False


class Evaluator:
    """``run(values)``: the records of a batch of designs, in order. New designs get the next
    index; with ``budget``, designs past it are not run (None)."""

    def __init__(
        self,
        spec: EvaluationSpec,
        done: dict[str, dict],
        *,
        workers: int = 1,
        comm=None,
        on_record: OnRecord | None = None,
        on_batch: Callable[[], None] | None = None,
    ) -> None:
        self.spec, self.comm, self.on_record, self.on_batch = spec, comm, on_record, on_batch
        self.resumed = dict(done)
        self.records: dict[str, dict] = {}  # this study's designs, in the order asked for
        self.evaluated = 0  # run in this invocation
        self.reused = 0  # taken from an earlier, resumed invocation
        self._taken = {r["index"] for r in done.values()}
        self._index = 0
        self.pool = None
        if comm is None and workers > 1:
            self.pool = futures.ProcessPoolExecutor(max_workers=workers)

    def run(
        self, batch: Sequence[dict], stage: str | Sequence[str] = "", budget: int | None = None
    ) -> list[dict | None]:
        """``stage``: one for the batch, or one per design."""
        stages = [stage] * len(batch) if isinstance(stage, str) else list(stage)
        new: list[Design] = []
        for values, stage_of in zip(batch, stages, strict=True):
            key = design_key(values)
            if key in self.records:
                continue
            if budget is not None and len(self.records) >= budget:
                continue
            if key in self.resumed:
                self.records[key] = {**self.resumed[key], "resumed": True}
                self.reused += 1
                continue
            self.records[key] = {}  # reserved
            new.append(Design(index=self._next_index(), values=dict(values), stage=stage_of))
        for record in self._evaluate(new):
            self.records[record["key"]] = record
            self.evaluated += 1
        if new and self.on_batch is not None:
            self.on_batch()
        return [self.records.get(design_key(v)) or None for v in batch]

    def _next_index(self) -> int:
        """The next folder number no earlier evaluation of this output holds."""
        while self._index in self._taken:
            self._index += 1
        self._taken.add(self._index)
        return self._index

    def _evaluate(self, designs: list[Design]):
        if not designs:
            return
        if self.comm is not None:
            yield from self._mpi(designs)
            return
        if self.pool is None:
            for d in designs:
                record = evaluate(self.spec, d)
                self._said(record)
                yield record
            return
        jobs = [self.pool.submit(evaluate, self.spec, d) for d in designs]
        for job in futures.as_completed(jobs):
            record = job.result()
            self._said(record)
            yield record

    def _mpi(self, designs: list[Design]):
        comm = self.comm
        comm.bcast(designs, root=0)
        mine = []
        for d in designs[0 :: comm.Get_size()]:
            mine.append(evaluate(self.spec, d))
            self._said(mine[-1])
        for rank, part in enumerate(comm.gather(mine, root=0)):
            for record in part:
                if rank:  # rank 0's own were said as they finished
                    self._said(record)
                yield record

    def _said(self, record: dict) -> None:
        if self.on_record is not None:
            self.on_record(record)

    def all_records(self) -> list[dict]:
        """Every design of the study, in the order the method asked for them."""
        return [r for r in self.records.values() if r]

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
        if self.comm is not None:
            self.comm.bcast(None, root=0)  # the other ranks' serve() returns


def serve(comm, spec: EvaluationSpec) -> None:
    """A rank other than 0: evaluate its share of each batch rank 0 deals, until None."""
    rank, size = comm.Get_rank(), comm.Get_size()
    while True:
        designs = comm.bcast(None, root=0)
        if designs is None:
            return
        comm.gather([evaluate(spec, d) for d in designs[rank::size]], root=0)


def warn(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
