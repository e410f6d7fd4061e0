"""The elastic head support (the thrust rig's stick, Sec. 4.3.1) between its two limits."""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.case.loader import load_case
from solid_adapter.build import build_shell_model
from solid_adapter.solvers import hinge_gauge_node, modal_analysis
from tests.conftest import ROOT, rectangle


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


# hinged-free Euler-Bernoulli beam: tan(lambda) = tanh(lambda), lambda_1 = 3.9266
# (Blevins, Formulas for Natural Frequency and Mode Shape, Table 8-1, pinned-free)
PINNED_FREE_LAMBDA_1 = 3.926602


@pytest.mark.parametrize("pin_x, span", [(0.0, 1.0), (0.25, 0.75)])
def test_a_strip_on_a_hinge_turns_freely_and_bends_as_the_pinned_free_beam(make_case, pin_x, span):
    """One rigid mode (the turn about the hinge line), then the pinned-free beam's first
    bending mode. With the hinge a quarter in, the quarter ahead of it is a free overhang:
    the test checks only that the hinge line stands where the key says (its frequency lies
    between the pinned-free beam of the whole strip and of the part behind the hinge)."""
    L, b, h, E, rho = 1.0, 0.05, 0.005, 70e9, 2700.0
    case = make_case(
        **rectangle(
            L,
            b,
            h,
            E,
            0.0,
            rho,
            boundary={"head": "pinned", "pin_x_m": pin_x},
            mesh={"elements_length": 16, "elements_width": 1},
        )
    )
    model = build_shell_model(case)
    result = modal_analysis(model, 1)
    assert result.rigid_modes == 1
    nodes = model.mesh.nodes
    turn = result.rigid_shapes[0].reshape(-1, 5)[:, 2]  # u_z of the rigid mode
    lever = nodes[:, 0] - pin_x
    assert np.corrcoef(turn, lever)[0, 1] ** 2 == pytest.approx(1.0, abs=1e-6)
    beam = np.sqrt(E * h**2 / 12 / rho) / (2 * np.pi)  # f = lambda^2 / L^2 times this
    if pin_x == 0.0:
        assert result.frequencies_hz[0] == pytest.approx(
            PINNED_FREE_LAMBDA_1**2 * beam / L**2, rel=5e-3
        )
    else:
        f1 = result.frequencies_hz[0]
        assert PINNED_FREE_LAMBDA_1**2 * beam / L**2 < f1 < PINNED_FREE_LAMBDA_1**2 * beam / span**2


def test_the_hinge_holds_the_fish_in_place_but_carries_no_moment():
    """The fish on the thrust rig's stick (pinned at the nose): under an unequal drive (left
    MFC only) the static state bends the plate; the nose line does not move, the plate turns
    about it, and the reaction-free support that holds the turn carries no force (the piezo
    load is internal)."""
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        [
            "fluid.model=none",
            "mesh.level=coarse",
            "boundary.head=pinned",
            "analysis.kind=static",
            "actuation.static_volts=[1000.0, 0.0]",
        ],
    )
    model = build_shell_model(case)
    from solid_adapter.build import run_static

    x = run_static(case, model).x
    u = model.nodal(x)[:, :3]
    nose = np.abs(model.mesh.nodes[:, 0]) < 1e-9
    assert nose.sum() >= 3
    assert np.abs(u[nose]).max() < 1e-12
    assert np.abs(u[:, 2]).max() > 1e-4  # it bends
    volts = np.array([1000.0, 0.0])
    drive = np.abs(model.internal(model.zero_state(), volts, tangent=False)[0]).max()
    gauge = hinge_gauge_node(model)
    assert abs(model.internal(x, volts, tangent=False)[0][gauge * 5 + 2]) < 1e-6 * drive
    # the static shape is seen from the hinge: a tenth of the plate behind it, the tail bends
    assert abs(u[model.mesh.nearest_node(model.layout.length_m, 0.0), 2]) > 1e-3


@pytest.mark.parametrize(
    "pin, on",
    [
        (2e-9, 0.0),  # a sliver column beside the nose made fsi-modal take 75 s
        (0.167 - 1e-8, 0.167),  # beside the tail: gmsh could not mesh the liquid
        (0.167, 0.167),  # on the trailing edge: the fish turns about its tail
        (0.05, 0.05),
    ],
)
def test_a_hinge_stands_on_a_nearby_edge_of_the_mesh_and_holds_one_turn(pin, on):
    """A hinge within a thousandth of the length of an edge the mesh has anyway (the nose,
    the tail, the actuator's ends) stands on it; one rigid mode, and the static solve's
    gauge node lies a tenth of the plate from it, on the plate."""
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        [
            "fluid.model=none",
            "mesh.level=coarse",
            "boundary.head=pinned",
            f"boundary.pin_x_m={pin!r}",
        ],
    )
    model = build_shell_model(case)
    assert model.layout.pin_x_m == pytest.approx(on, abs=1e-12)
    assert modal_analysis(model, 1).rigid_modes == 1
    gauge_x = model.mesh.nodes[hinge_gauge_node(model), 0]
    assert abs(abs(gauge_x - on) - 0.1 * 0.167) < 0.01
