"""The elastic head support (the thrust rig's stick, Sec. 4.3.1) between its two limits."""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.case.loader import load_case
from solid_adapter.build import build_shell_model
from solid_adapter.solvers import modal_analysis
from tests.conftest import ROOT


def _dry_modes(*overrides: str) -> np.ndarray:
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        ["fluid.model=none", "mesh.level=coarse", *overrides],
    )
    return modal_analysis(build_shell_model(case), 8).frequencies_hz


def test_stiff_springs_hold_the_head_like_the_clamp():
    """Springs of 1e9 N/m over the clamp region: the clamped fish's dry modes (the springs
    hold the nodes' positions, not their rotations: 1.2 % softer in the first mode)."""
    clamped = _dry_modes()
    held = _dry_modes("boundary.head=elastic", "boundary.support_stiffness_n_per_m=1e9")
    np.testing.assert_allclose(held[:4], clamped[:4], rtol=0.02)


def test_soft_springs_leave_the_free_body():
    """Springs of 1e-3 N/m: six rigid-body modes near 0 Hz, then the free-free modes."""
    free = _dry_modes("boundary.head=free")
    soft = _dry_modes("boundary.head=elastic", "boundary.support_stiffness_n_per_m=1e-3")
    assert np.all(soft[:6] < 0.1)
    assert soft[6:8] == pytest.approx(free[:2], rel=5e-3)
