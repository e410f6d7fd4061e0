"""The study methods, on a batch evaluator (``Evaluator.run``: parameter values -> records).

- one-at-a-time: each parameter over ``points`` evenly spaced values with the others at the
  base case's (``serial = true``: at the best value found for the parameters before it, the
  seed's serial optimisation, Sec. 5.3).
- sample: ``budget`` designs of a scrambled Sobol sequence or a Latin hypercube
  (scipy.stats.qmc; the seed's random search of Sec. 5.4, space-filling).
- optimize: such a sample as the first population of scipy's differential evolution, which
  then runs as many generations as the budget holds (a generation is one parallel batch).

Every method maximises the score (the weighted sum of the objectives, each with its sense);
an infeasible or failed design scores PENALTY for the optimiser.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import differential_evolution
from scipy.stats import qmc

from .evaluate import is_ok
from .runner import Evaluator
from .study import Method, Study

# what the optimiser sees for a design without a score: far below any objective's values
PENALTY = 1e12


def run_method(study: Study, evaluator: Evaluator) -> None:
    kind = study.method.kind
    if kind is Method.ONE_AT_A_TIME:
        one_at_a_time(study, evaluator)
    elif kind is Method.SAMPLE:
        sample(study, evaluator)
    else:
        optimize(study, evaluator)


def one_at_a_time(study: Study, evaluator: Evaluator) -> None:
    grid = np.linspace(0.0, 1.0, study.method.points)
    if not study.method.serial:  # one batch keeps every worker busy
        designs = [(p.key, {p.key: p.value(u)}) for p in study.parameters for u in grid]
        evaluator.run([v for _, v in designs], stage=[k for k, _ in designs])
        return
    fixed: dict = {}
    for p in study.parameters:  # the next parameter starts from this one's best
        records = evaluator.run([{**fixed, p.key: p.value(u)} for u in grid], stage=p.key)
        best = best_of([r for r in records if r is not None])
        if best is not None:
            fixed[p.key] = best["parameters"][p.key]


def unit_sample(study: Study, n: int) -> np.ndarray:
    d = len(study.parameters)
    if study.method.sampler == "lhs":
        sampler = qmc.LatinHypercube(d=d, seed=study.method.seed)
        return sampler.random(n)
    sampler = qmc.Sobol(d=d, scramble=True, seed=study.method.seed)
    with warnings.catch_warnings():  # n need not be a power of two
        warnings.simplefilter("ignore", UserWarning)
        return sampler.random(n)


def values_at(study: Study, unit: np.ndarray) -> dict:
    return {p.key: p.value(float(u)) for p, u in zip(study.parameters, unit, strict=True)}


def sample(study: Study, evaluator: Evaluator) -> None:
    units = unit_sample(study, study.method.budget)
    evaluator.run([values_at(study, u) for u in units], stage="sample")


def initial_size(study: Study) -> int:
    """The first population: method.initial, else ten per parameter, at most a quarter of
    the budget (a few generations follow), at least five (differential evolution's least)."""
    m = study.method
    if m.initial is not None:
        return max(5, m.initial)
    return max(5, min(10 * len(study.parameters), m.budget // 4))


def optimize(study: Study, evaluator: Evaluator) -> None:
    budget = study.method.budget
    size = initial_size(study)
    if budget < size:  # no generation fits: the space-filling start is the study
        evaluator.run([values_at(study, u) for u in unit_sample(study, budget)], "initial")
        return
    scores: dict[tuple, float] = {}
    generation = [0]

    def batch(func, population):
        units = [np.asarray(u, dtype=float) for u in population]
        stage = "initial" if generation[0] == 0 else f"generation {generation[0]}"
        records = evaluator.run([values_at(study, u) for u in units], stage, budget=budget)
        for u, record in zip(units, records, strict=True):
            ok = record is not None and is_ok(record)
            scores[tuple(u)] = -float(record["score"]) if ok else PENALTY
        generation[0] += 1
        return [func(u) for u in units]

    d = len(study.parameters)
    differential_evolution(
        lambda u: scores[tuple(np.asarray(u, dtype=float))],
        bounds=[(0.0, 1.0)] * d,
        init=unit_sample(study, size),
        popsize=size,  # with an init array, the population is that array
        maxiter=(budget - size) // size,
        tol=0.0,
        atol=0.0,
        polish=False,
        updating="deferred",
        workers=batch,
        rng=np.random.default_rng(study.method.seed),
    )


def best_of(records: list[dict]) -> dict | None:
    ok = [r for r in records if is_ok(r)]
    return max(ok, key=lambda r: r["score"]) if ok else None


def pareto_front(records: list[dict], study: Study) -> list[dict]:
    """The feasible designs no other one beats in every objective (each with its sense)."""
    ok = [r for r in records if is_ok(r)]
    signs = [1.0 if o.sense.value == "max" else -1.0 for o in study.objectives]
    points = np.array(
        [
            [s * r["objectives"][o.quantity] for s, o in zip(signs, study.objectives, strict=True)]
            for r in ok
        ]
    ).reshape(len(ok), len(signs))
    front = []
    for i, r in enumerate(ok):
        others = np.delete(points, i, axis=0)
        dominated = np.any(np.all(others >= points[i], axis=1) & np.any(others > points[i], axis=1))
        if not dominated:
            front.append(r)
    return front
