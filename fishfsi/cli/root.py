"""What the orchestrator's Python API asks of the application layer, registered as the entry
point ``fsi_orchestrator.composition`` (pyproject.toml): check a loaded case against the plate it
resolves to, and run a case. The orchestrator never imports this package; it looks the entry
point up (fsi_orchestrator.api). Both import lazily, so that loading a case stays fast."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fsi_orchestrator.case import Case


def check_plausible(case: Case) -> None:
    """The commands' checks across keys (the clamp, the fluid domain around the plate)."""
    from .common import check_plausible as check

    check(case)


def execute(
    case: Case,
    output: Path,
    resume: bool,
    overwrite: bool,
    show_progress: bool,
    overrides: Sequence[str] = (),
) -> dict[str, Any]:
    """Run a case as ``fsi-run`` does; its summary."""
    from .run import execute as run

    return run(case, output, resume, overwrite, show_progress, overrides)
