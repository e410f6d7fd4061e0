"""fsi-run's output folder: refused before the set-up where it cannot be written or already
holds a run (no silent overwrite), and a run's results checked and labelled at its end."""

from __future__ import annotations

import errno
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from fsi_orchestrator.case import CaseError
from fsi_orchestrator.loop import AFRESH, ResumeError
from fsi_orchestrator.results import (
    CHECKPOINT_FILE,
    MIN_FREE_BYTES,
    RESULTS_FILE,
    OutputError,
    check_writable,
    read_checkpoint,
    write_failure,
)

from .common import cannot_write

SWEEP_FILES = ("sweep.csv", "sweep_rows")  # what fsi-sweep keeps in its --output
# what an earlier fsi-run leaves besides a dynamic run's results: its summary, a flume's
RUN_FILES = ("summary.json", "flume.json")


def refuse_unwritable(output: Path, names: tuple[str, ...] | None = None) -> None:
    """Refuse, before any work, an output folder where ``names`` (a dynamic run's results
    and checkpoint by default) cannot be written."""
    try:
        check_writable(output) if names is None else check_writable(output, names)
    except OutputError as err:
        if not err.not_writable:  # a full disk is the machine's state, not the input's
            raise
        # a folder given that cannot be written is bad input, as one that cannot be made
        # (exit 2, as fsi-sweep and fsi-post refuse it)
        raise CaseError(str(err)) from None


def prepare_output(output: Path, resume: bool, overwrite: bool) -> bool:
    """Before the set-up's seconds: a folder that cannot be written, a --resume without a
    checkpoint, and a folder holding an earlier run (without --resume or --overwrite) each
    fail at once in one line. True when an earlier run is to be replaced (--overwrite): its
    checkpoint goes once the set-up is done (coupling.jacobian_from may still read it)."""
    checkpoint = output / CHECKPOINT_FILE
    if resume and not checkpoint.exists():  # before the folder is made: nothing left behind
        raise ResumeError(f"{checkpoint}: no checkpoint to resume from; {AFRESH}")
    held = open_run_folder(output, (RESULTS_FILE, CHECKPOINT_FILE, *RUN_FILES))
    if held and not resume and not overwrite:
        raise CaseError(
            f"--output {output}: holds an earlier run ({', '.join(held)}); continue it with "
            "--resume, write elsewhere with --output, or replace it with --overwrite"
        )
    refuse_unwritable(output)
    if resume:
        check_results_readable(output / RESULTS_FILE, checkpoint)
    return bool(held) and not resume


def open_run_folder(output: Path, names: tuple[str, ...]) -> list[str]:
    """Make a run's --output (one line where it cannot be made), refuse a sweep's folder, and
    return which of an earlier run's ``names`` it holds."""
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise CaseError(cannot_write(output, err)) from None
    sweep = [n for n in SWEEP_FILES if (output / n).exists()]
    if sweep:  # a run's files among a sweep's points would be taken for a point's
        raise CaseError(
            f"--output {output}: holds a sweep of fsi-sweep ({', '.join(sweep)}); write the run "
            "elsewhere with --output"
        )
    return [n for n in names if (output / n).exists()]


def check_results_readable(results: Path, checkpoint: Path) -> None:
    """A --resume appends to results.h5 after the checkpoint's windows: a damaged one is
    refused before the set-up, where it would read back as a diverged run after minutes of
    work. Rows after the checkpoint are replaced by the resumed run and not checked."""
    if not results.exists():
        return
    try:
        windows = int(read_checkpoint(checkpoint)[0]["window"])
    except (OSError, KeyError, ValueError, TypeError, RuntimeError):
        return  # the checkpoint's own check refuses it, in its words
    fix = "rerun with --overwrite, or restore it"
    try:
        bad = first_not_finite(results)
    except (OSError, KeyError, ValueError, TypeError) as err:
        raise ResumeError(
            f"{results}: not a readable results file ({err.__class__.__name__}); {fix}"
        ) from None
    if bad is not None and bad[1] < windows:
        raise ResumeError(
            f"{results}: not a readable results file ({bad[0]} is not finite from window "
            f"{bad[1] + 1} on: damaged, or a run that diverged); {fix}"
        )


# the recorded quantities a run's figures come from; coupling statistics may be NaN ("none")
CHECKED_GROUPS = ("time_s", "shell/", "fluid/")
CHECKED_SUMMARY = ("tip_amplitude_m", "tip_max_abs_m", "mean_thrust_n", "end_time_s")


def first_not_finite(results: Path) -> tuple[str, int] | None:
    """The recorded quantity (and its row) where a run's results first stop being finite."""
    bad: tuple[str, int] | None = None
    with h5py.File(results, "r", locking=False) as h5:
        names: list[str] = []
        h5.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for name in sorted(names):
            if not name.startswith(CHECKED_GROUPS):
                continue
            rows = np.asarray(h5[name][()], dtype=float).reshape(h5[name].shape[0], -1)
            broken = ~np.isfinite(rows).all(axis=1)
            if broken.any() and (bad is None or np.argmax(broken) < bad[1]):
                bad = (name, int(np.argmax(broken)))
    return bad


def check_finite(results: Path, summary: Mapping[str, Any]) -> None:
    """A run whose results hold NaN or infinity ends with an error, never with exit 0."""
    bad = first_not_finite(results)
    if bad is not None:
        name, row = bad
        raise RuntimeError(
            f"{results}: {name} is not finite from window {row + 1} on: the run diverged; "
            "try a smaller time step (time.steps_per_period or time.step_s) and check the "
            "case's values"
        )
    for key in CHECKED_SUMMARY:
        value = summary.get(key)
        if isinstance(value, float) and not np.isfinite(value):
            raise RuntimeError(
                f"{results}: the run's {key} is not finite; try a smaller time step "
                "(time.steps_per_period or time.step_s) and check the case's values"
            )


def label_results(results: Path, attributes: Mapping[str, Any]) -> None:
    """Root attributes known only at a run's end (e.g. ``thrust_source``)."""
    kept = f"the results are kept, without {', '.join(attributes)}"
    try:
        if shutil.disk_usage(results.parent).free < MIN_FREE_BYTES:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        with h5py.File(results, "a", locking=False) as h5:
            for key, value in attributes.items():
                h5.attrs[key] = value
    except OSError as err:
        raise write_failure(results, err, kept, then="--resume adds it") from None
