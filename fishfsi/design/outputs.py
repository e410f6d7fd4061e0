"""A study's outputs: the table of every evaluation (``evaluations.csv``, ``evaluations.h5``),
the plots (each parameter's response, the history, the Pareto front of two objectives) and the
best design as a case folder (``best_case/case.toml``, ready for ``fsi-run``)."""

from __future__ import annotations

import csv
import io
import math
import shutil
from pathlib import Path

import numpy as np

from fsi_orchestrator.case.loader import CASE_FILE

from ..cli.common import json_text, replaced_atomically, save_figure
from .evaluate import SUMMARY_FILE, atomic_write, finite, is_ok
from .study import Study

FIDELITY_COLUMNS = ("method", "shell_mesh", "fluid", "fluid_mesh", "steps_per_period", "modes")


def table_rows(records: list[dict], study: Study) -> list[dict]:
    rows = []
    for order, r in enumerate(records):
        row = {"evaluation": order, "folder": f"{r['index']:04d}", "stage": r.get("stage", "")}
        row.update({p.key: r["parameters"].get(p.key, "") for p in study.parameters})
        row.update({o.quantity: finite(r["objectives"].get(o.quantity)) for o in study.objectives})
        row["score"] = finite(r.get("score"))
        row["status"], row["reason"] = r["status"], r.get("reason", "")
        fidelity = r.get("fidelity", {})
        row.update({f"fidelity_{k}": fidelity.get(k, "") for k in FIDELITY_COLUMNS})
        row["wall_s"] = r.get("wall_s", math.nan)
        rows.append(row)
    return rows


def write_tables(records: list[dict], study: Study, output: Path) -> None:
    """``evaluations.csv`` and ``evaluations.h5``, each replaced atomically."""
    rows = table_rows(records, study)
    if not rows:
        return
    text = io.StringIO(newline="")
    # "\n" line ends, as every other text file the tool writes (csv's default is "\r\n")
    writer = csv.DictWriter(text, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write(output / "evaluations.csv", text.getvalue())
    write_h5(rows, study, output / "evaluations.h5")


def write_h5(rows: list[dict], study: Study, path: Path) -> None:
    import h5py

    strings = h5py.string_dtype()
    with replaced_atomically(path) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["title"] = study.title
        h5.attrs["base_case"] = str(study.base_case)
        h5.attrs["method"] = study.method.kind.value
        keys = [p.key for p in study.parameters]
        quantities = [o.quantity for o in study.objectives]
        h5["parameters"] = np.array([[float(r[k] or math.nan) for k in keys] for r in rows])
        h5["parameters"].attrs["keys"] = keys
        h5["objectives"] = np.array([[r[q] for q in quantities] for r in rows], dtype=float)
        h5["objectives"].attrs["quantities"] = quantities
        h5["objectives"].attrs["senses"] = [o.sense.value for o in study.objectives]
        h5["objectives"].attrs["weights"] = [o.weight for o in study.objectives]
        for name in ("score", "wall_s"):
            h5[name] = np.array([r[name] for r in rows], dtype=float)
        h5["folder"] = np.array([int(r["folder"]) for r in rows])
        for name in ("status", "reason", "stage", *(f"fidelity_{k}" for k in FIDELITY_COLUMNS)):
            h5.create_dataset(name, data=[str(r[name]) for r in rows], dtype=strings)


def write_best_case(best: dict, output: Path) -> Path:
    """``best_case/``: the best design's case.toml and its summary."""
    folder = output / "best_case"
    folder.mkdir(parents=True, exist_ok=True)
    source = output / "evaluations" / f"{best['index']:04d}"
    for name in (CASE_FILE, SUMMARY_FILE):
        with replaced_atomically(folder / name) as tmp:
            shutil.copyfile(source / name, tmp)
    return folder


def write_pareto(front: list[dict], study: Study, output: Path) -> None:
    atomic_write(output / "pareto.json", json_text(front, indent=1))


def plot_all(records: list[dict], study: Study, output: Path, front: list[dict]) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    written = [plot_response(records, study, output / "response.png")]
    written.append(plot_history(records, study, output / "history.png"))
    if len(study.objectives) == 2:
        written.append(plot_pareto(records, front, study, output / "pareto.png"))
    return written


def _label(quantity: str) -> str:
    return quantity.replace("_m", " [mm]") if quantity.endswith("_m") else quantity


def _shown(quantity: str, value: float) -> float:
    """Lengths in mm on the plots, the rest as stored."""
    return 1e3 * value if quantity.endswith("_m") else value


def plot_response(records: list[dict], study: Study, path: Path) -> Path:
    """The first objective against each parameter (Fig. 5.5's study: one panel, one line);
    failed designs as crosses at the bottom."""
    import matplotlib.pyplot as plt

    q = study.objectives[0].quantity
    n = len(study.parameters)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.4), squeeze=False)
    ok = [r for r in records if is_ok(r)]
    for ax, p in zip(axes[0], study.parameters, strict=True):
        mine = [r for r in ok if r.get("stage") in (p.key, "")] if _oat(study) else ok
        xs = np.array([_shown(p.key, r["parameters"][p.key]) for r in mine])
        ys = np.array([_shown(q, r["objectives"][q]) for r in mine])
        order = np.argsort(xs)
        style = "o-" if _oat(study) else "o"
        ax.plot(xs[order], ys[order], style, ms=4)
        bad = [r for r in records if not is_ok(r) and p.key in r["parameters"]]
        if bad and len(ys):
            ax.plot(
                [_shown(p.key, r["parameters"][p.key]) for r in bad],
                [ys.min()] * len(bad),
                "rx",
                label="infeasible / failed",
            )
            ax.legend(fontsize=7)
        ax.set_xlabel(_label(p.key.partition(".")[2]))
        ax.set_ylabel(_label(q))
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def _oat(study: Study) -> bool:
    return study.method.kind.value == "one-at-a-time"


def plot_history(records: list[dict], study: Study, path: Path) -> Path:
    import matplotlib.pyplot as plt

    scores = np.array([finite(r.get("score")) if is_ok(r) else np.nan for r in records])
    best = np.fmax.accumulate(np.where(np.isnan(scores), -np.inf, scores))
    best[np.isinf(best)] = np.nan
    fig, ax = plt.subplots(figsize=(6, 3.4))
    ax.plot(np.arange(len(scores)), scores, ".", label="evaluation")
    ax.plot(np.arange(len(scores)), best, "-", label="best so far")
    ax.set_xlabel("evaluation")
    ax.set_ylabel("score (weighted objectives, larger is better)")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def plot_pareto(records: list[dict], front: list[dict], study: Study, path: Path) -> Path:
    import matplotlib.pyplot as plt

    a, b = (o.quantity for o in study.objectives)
    ok = [r for r in records if is_ok(r)]
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.plot([r["objectives"][a] for r in ok], [r["objectives"][b] for r in ok], ".", label="all")
    front = sorted(front, key=lambda r: r["objectives"][a])
    ax.plot(
        [r["objectives"][a] for r in front],
        [r["objectives"][b] for r in front],
        "o-",
        label="Pareto front",
    )
    ax.set_xlabel(a)
    ax.set_ylabel(b)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return path
