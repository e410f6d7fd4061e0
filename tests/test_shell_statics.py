"""Static verification of the large-deflection laminated shell against analytic references."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from solid_adapter.build import build_shell_model, run_static
from solid_adapter.materials import MFC
from solid_adapter.solvers import static_free_dofs
from tests.conftest import BIMORPH_STRIP, rectangle


def test_linear_cantilever_tip_load_matches_beam_theory(make_case):
    """Small tip load: w = PL^3/(3EI) + PL/(kGA) (Timoshenko; Euler-Bernoulli + shear)."""
    L, b, h, E, P = 10.0, 1.0, 0.1, 1.2e6, 1e-4
    case = make_case(
        **rectangle(
            L,
            b,
            h,
            E,
            loads={"tip_force_n": P},
            analysis={"kind": "static", "load_steps": 1},
            mesh={"elements_length": 8, "elements_width": 1},
        )
    )
    w = run_static(case).tip_displacement_m[2]
    EI, kGA = E * b * h**3 / 12, 5 / 6 * E / 2 * b * h
    reference = P * L**3 / (3 * EI) + P * L / kGA
    assert w == pytest.approx(reference, rel=5e-3)


def test_tip_moment_rolls_the_strip_into_a_circular_arc(make_case):
    """Pure moment M: curvature M/EI everywhere; tip at (sin(kL)/k, (1 - cos(kL))/k)."""
    L, b, h, E = 10.0, 1.0, 0.1, 1.2e6
    EI = E * b * h**3 / 12
    M = 0.75 * np.pi * EI / L  # 135 degrees of tip rotation
    case = make_case(
        **rectangle(
            L,
            b,
            h,
            E,
            loads={"tip_moment_nm": M},
            analysis={"kind": "static", "load_steps": 8},
            mesh={"elements_length": 16, "elements_width": 1},
        )
    )
    u = run_static(case).tip_displacement_m
    k = M / EI
    assert L + u[0] == pytest.approx(np.sin(k * L) / k, rel=1e-2)
    assert u[2] == pytest.approx((1 - np.cos(k * L)) / k, rel=1e-2)


def elastica_tip(P_over_EI: float, L: float) -> tuple[float, float]:
    """Cantilever under a dead tip force normal to the undeformed axis, by shooting on
    theta'' = -(P/EI) cos(theta), theta(0) = 0, theta'(L) = 0. Returns (u, w) of the tip."""

    def rhs(s, y):
        theta, kappa, x, w = y
        return [kappa, -P_over_EI * np.cos(theta), np.cos(theta), np.sin(theta)]

    def end_moment(kappa0):
        return solve_ivp(rhs, (0, L), [0, kappa0, 0, 0], rtol=1e-11, atol=1e-12).y[1, -1]

    kappa0 = brentq(end_moment, 1e-9, P_over_EI * L)
    y = solve_ivp(rhs, (0, L), [0, kappa0, 0, 0], rtol=1e-11, atol=1e-12).y[:, -1]
    return y[2] - L, y[3]


def test_large_tip_force_matches_the_elastica(make_case):
    """PL^2/EI = 4 (Mattiasson 1981 tabulates w/L = 0.6700, u/L = -0.3289)."""
    L, b, h, E, P = 10.0, 1.0, 0.1, 1.2e6, 4.0
    EI = E * b * h**3 / 12
    case = make_case(
        **rectangle(
            L,
            b,
            h,
            E,
            loads={"tip_force_n": P},
            analysis={"kind": "static", "load_steps": 10},
            mesh={"elements_length": 10, "elements_width": 1},
        )
    )
    u = run_static(case).tip_displacement_m
    u_ref, w_ref = elastica_tip(P / EI, L)
    assert w_ref / L == pytest.approx(0.6700, abs=1e-4)  # the reference itself, vs the table
    assert u[2] == pytest.approx(w_ref, rel=1e-2)
    assert u[0] == pytest.approx(u_ref, rel=1e-2)


def test_uniform_follower_pressure_small_load_matches_beam_theory(make_case):
    """Uniform load q = p b on a cantilever: w_tip = q L^4 / (8 EI)."""
    L, b, h, E, p = 10.0, 1.0, 0.1, 1.2e6, 1e-6
    case = make_case(
        **rectangle(
            L,
            b,
            h,
            E,
            loads={"pressure_pa": p},
            analysis={"kind": "static", "load_steps": 1},
            mesh={"elements_length": 8, "elements_width": 1},
        )
    )
    w = run_static(case).tip_displacement_m[2]
    assert w == pytest.approx(p * b * L**4 / (8 * E * b * h**3 / 12), rel=5e-3)


# --------------------------------------------------------------------------- piezo driving


def _reduced(E1, E2, nu12, G):
    nu21 = nu12 * E2 / E1
    d = 1 - nu12 * nu21
    return np.array([[E1 / d, nu21 * E1 / d, 0], [nu21 * E1 / d, E2 / d, 0], [0, 0, G]])


def laminated_beam_curvature(regions, d33=460e-12, d31=-210e-12, W=0.5e-3):
    """Classical lamination theory condensed to a beam: each region (width b, layers) is free
    across the width (N_y = N_xy = M_y = M_xy = 0), all regions share eps_x and kappa_x.
    Layers: (Q, z0, z1, volts or None); eigenstrain [d33, d31, 0] V / W (eqs. 3-9..3-11)."""
    C_total, rhs = np.zeros((2, 2)), np.zeros(2)
    for b, layers in regions:
        ABD, F0 = np.zeros((6, 6)), np.zeros(6)
        for Q, z0, z1, V in layers:
            ABD[:3, :3] += Q * (z1 - z0)
            ABD[:3, 3:] += Q * (z1**2 - z0**2) / 2
            ABD[3:, 3:] += Q * (z1**3 - z0**3) / 3
            if V is not None:
                sigma = Q @ np.array([d33, d31, 0.0]) * V / W  # eq. 3-10
                F0[:3] += sigma * (z1 - z0)
                F0[3:] += sigma * (z1**2 - z0**2) / 2
        ABD[3:, :3] = ABD[:3, 3:].T
        F = np.linalg.inv(ABD)
        free = (F @ F0)[[0, 3]]
        C = np.linalg.inv(F[np.ix_([0, 3], [0, 3])])
        C_total += b * C
        rhs += b * C @ free
    return np.linalg.solve(C_total, rhs)  # (eps_x, kappa_x)


def arc_tip_deflection(kappa, eps, x0, length_active, length_total):
    """Straight root (x0), circular arc of the active length, straight rest."""
    phi = kappa * length_active * (1 + eps)
    rest = length_total - x0 - length_active
    return (1 - np.cos(phi)) / kappa + rest * np.sin(phi)


Q_MFC = _reduced(30.336e9, 15.9e9, 0.31, 5.515e9)  # Table 3.1
Q_CFRP = _reduced(20.05e9, 20.05e9, 0.3, 20.05e9 / 2.6)  # Table 3.2
TC, TM = 0.2e-3, 0.3e-3


def test_unimorph_beam_static_tip_deflection_at_1500V(make_case):
    """Table 3.2 beam, one MFC on the +z face at +1500 V: it extends, the strip curls to -z."""
    core = (Q_CFRP, -TC / 2, TC / 2, None)
    eps, kappa = laminated_beam_curvature(
        [(7e-3, [core, (Q_MFC, TC / 2, TC / 2 + TM, 1500.0)]), (1e-3, [core])]
    )
    case = make_case(
        geometry={"kind": "beam"},
        analysis={"kind": "static", "load_steps": 4},
        actuation={"static_volts": [1500.0, 0.0]},
    )
    model = build_shell_model(case)
    x0 = model.layout.region_rules[0][1].x0
    w_ref = arc_tip_deflection(kappa, eps, x0, 85e-3, 87e-3)
    w = run_static(case, model).tip_displacement_m[2]
    assert abs(w_ref) > 0.01  # large deflection: 14 mm on 87 mm
    assert -w == pytest.approx(w_ref, rel=2e-2)


def test_bimorph_uniform_strip_static_tip_deflection(make_case):
    """MFC on both faces of a uniform strip, driven in opposite senses (+1500 V / -500 V)."""
    core = (Q_CFRP, -TC / 2, TC / 2, None)
    layers = [core, (Q_MFC, TC / 2, TC / 2 + TM, 1500.0), (Q_MFC, -TC / 2 - TM, -TC / 2, -500.0)]
    eps, kappa = laminated_beam_curvature([(8e-3, layers)])
    w_ref = arc_tip_deflection(kappa, eps, 0.0, 87e-3, 87e-3)
    case = make_case(
        geometry=BIMORPH_STRIP,
        analysis={"kind": "static", "load_steps": 4},
        actuation={"static_volts": [1500.0, -500.0]},
    )
    w = run_static(case).tip_displacement_m[2]
    assert -w == pytest.approx(w_ref, rel=2e-2)


def test_mfc_material_is_table_3_1():
    assert MFC.e1_pa == 30.336e9 and MFC.nu21 == pytest.approx(0.16, abs=5e-3)


def test_factorize_solves_a_tangent_that_needs_pivoting():
    """factorize uses diagonal pivots; a matrix with a zero diagonal falls back to partial
    pivoting and still solves exactly (a saddle-point-like 3 x 3 and a SPD 3 x 3)."""
    import scipy.sparse as sp

    from solid_adapter.solvers import factorize

    for dense in (
        [[0.0, 1.0, 0.0], [1.0, 0.0, 2.0], [0.0, 2.0, 1.0]],
        [[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]],
    ):
        A = sp.csc_matrix(np.array(dense))
        b = np.array([1.0, 2.0, 3.0])
        np.testing.assert_allclose(A @ factorize(A).solve(b), b, rtol=0, atol=1e-12)


def test_a_free_bimorph_strip_curls_into_the_clamped_arc_about_its_support(make_case):
    """A free plate (boundary.head = "free") has no stiffness against rigid motion; statics hold
    it by a statically determinate support (solvers.static_free_dofs) that carries no reaction
    under the self-equilibrated piezo load. So the strip curls into the same circular arc as a
    clamped one, about the held node: each end's deflection relative to it is that of a strip
    clamped there with the end's distance as its length."""
    core = (Q_CFRP, -TC / 2, TC / 2, None)
    layers = [core, (Q_MFC, TC / 2, TC / 2 + TM, 1500.0), (Q_MFC, -TC / 2 - TM, -TC / 2, -500.0)]
    eps, kappa = laminated_beam_curvature([(8e-3, layers)])
    length = 87e-3
    case = make_case(
        geometry=BIMORPH_STRIP,
        boundary={"head": "free"},
        analysis={"kind": "static", "load_steps": 4},
        actuation={"static_volts": [1500.0, -500.0]},
    )
    model = build_shell_model(case)
    assert not model.fixed_dofs.any()
    held = static_free_dofs(model)
    assert (~held).sum() == 6  # one node's five DOFs and a second node's u_y
    x = run_static(case, model).x.reshape(-1, 5)
    support = np.flatnonzero((~held).reshape(-1, 5).all(axis=1))[0]
    xs = model.mesh.nodes[support, 0]
    tail = model.mesh.nearest_node(length, 0.0)
    nose = model.mesh.nearest_node(0.0, 0.0)
    for end, arm in ((tail, length - xs), (nose, xs)):
        w_ref = arc_tip_deflection(kappa, eps, 0.0, arm, arm)
        assert -(x[end, 2] - x[support, 2]) == pytest.approx(w_ref, rel=2e-2)
