"""Prescribed (one-way) motion of the fish in its first clamped mode: the composition of the
shell's modal analysis (solid_adapter) with the fluid's prescribed-motion runs
(fluid_adapter.openfoam.prescribed), which get the mode as a plain callable, points -> shape.

The mode comes from the shell solver (``case.boundary.head = "clamped"``, in vacuum): its nodal
translations (u_x, u_y, u_z) are interpolated linearly from the shell's nodes to any point of
the planform and scaled so that the tail tip (trailing edge at y = 0) moves 1 m along z.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

from fluid_adapter.openfoam import prescribed as fluid
from fluid_adapter.openfoam.checkmesh import MeshQuality
from fluid_adapter.openfoam.prescribed import (
    ACOUSTIC_TAIL_AMPLITUDE_M,
    LARGEST_TAIL_AMPLITUDE_M,
    ModeMotion,
    PrescribedResult,
    ShapeOnPoints,
)
from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import HeadCondition

__all__ = [
    "ACOUSTIC_TAIL_AMPLITUDE_M",
    "LARGEST_TAIL_AMPLITUDE_M",
    "ModeMotion",
    "PrescribedResult",
    "check_motion",
    "first_mode",
    "first_mode_shape",
    "mode_motion",
    "mode_on_points",
    "run_prescribed",
    "slender_body_estimate",
]


def first_mode(case: Case) -> tuple[NDArray, NDArray]:
    """Shell node positions (n, 2) and the first clamped mode's translations (n, 3), scaled
    to +1 m of z displacement at the tail tip."""
    from solid_adapter.build import build_shell_model
    from solid_adapter.shell import NDOF
    from solid_adapter.solvers import modal_analysis

    clamped = replace(case, boundary=replace(case.boundary, head=HeadCondition.CLAMPED))
    model = build_shell_model(clamped)
    shape = modal_analysis(model, 1).shapes[0].reshape(-1, NDOF)[:, :3]
    tip = model.mesh.nearest_node(*model.layout.tip_point)
    return model.mesh.nodes.copy(), shape / shape[tip, 2]


def mode_on_points(nodes: NDArray, shape: NDArray, points: NDArray) -> NDArray:
    """Interpolate a nodal shape to points of the planform (x, y[, z]); nearest value where a
    point falls outside the shell nodes' triangulation (round-off at the outline)."""
    xy = points[:, :2]
    linear = LinearNDInterpolator(nodes, shape)(xy)
    outside = np.isnan(linear[:, 0])
    if outside.any():
        linear[outside] = NearestNDInterpolator(nodes, shape)(xy[outside])
    return linear


def first_mode_shape(case: Case) -> ShapeOnPoints:
    """The first clamped mode as the fluid takes it: points -> (n, 3), tail tip z = 1. The
    modal analysis runs when the shape is first asked for (in a run: after the mesh)."""
    mode: list[tuple[NDArray, NDArray]] = []

    def on_points(points: NDArray) -> NDArray:
        if not mode:
            mode.append(first_mode(case))
        return mode_on_points(*mode[0], points)

    return on_points


def mode_motion(
    case: Case,
    points: NDArray,
    amplitude_m: float = ACOUSTIC_TAIL_AMPLITUDE_M,
    frequency_hz: float | None = None,
    ramp_periods: float = 0.0,
) -> ModeMotion:
    """The first clamped mode times sin(2 pi f t) on ``points`` (f: the case's by default)."""
    f = frequency_hz or case.actuation.frequency_hz
    return fluid.mode_motion(first_mode_shape(case), points, amplitude_m, f, ramp_periods)


def run_prescribed(case: Case, workdir: Path, **options: Any) -> PrescribedResult:
    """One-way run: the fish moves in its first clamped mode, one pimpleFoam launch (options:
    fluid_adapter.openfoam.prescribed.run_prescribed's)."""
    return fluid.run_prescribed(case, workdir, first_mode_shape(case), **options)


def check_motion(
    case: Case, workdir: Path, **options: Any
) -> tuple[MeshQuality, list[MeshQuality]]:
    """The mesh alone through the first-mode motion (no flow): the generated mesh's quality
    and a full mesh check after every window (options: the fluid adapter's check_motion's)."""
    return fluid.check_motion(case, workdir, first_mode_shape(case), **options)


def slender_body_estimate(case: Case, **options: Any) -> float:
    """Mean thrust (N) of the first-mode motion from Lighthill's elongated-body theory (options:
    the fluid adapter's slender_body_estimate's): the CFD's first check."""
    return fluid.slender_body_estimate(case, first_mode_shape(case), **options)
