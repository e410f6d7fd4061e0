"""Plane-strain St. Venant-Kirchhoff flag (turek_hron.plane_strain).

References:
- Turek & Hron (2006), "Proposal for numerical benchmarking of fluid-structure interaction
  between an elastic object and laminar incompressible flow" (in Bungartz & Schaefer (eds.),
  Fluid-Structure Interaction, LNCSE 53, Springer), Section 2 (geometry), tables "CSM1" and
  "CSM3": CSM1 tip displacement ux = -7.187e-3 m, uy = -66.10e-3 m; CSM3
  uy = -63.607 +- 65.160 mm at 1.0995 Hz (finest level).
- Cantilever formulas (Timoshenko & Gere, Mechanics of Materials): uniform load q,
  w = q L^4 / (8 E' I); tip force P, w = P L^3 / (3 E' I); first bending frequency
  f1 = (1.87510^2 / 2 pi) sqrt(E' I / (rho A L^4)); E' = E / (1 - nu^2) in plane strain.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from fsi_orchestrator.participant import Participant
from turek_hron.plane_strain import (
    FlagGeometry,
    FlagIntegrator,
    SvkMaterial,
    build_flag_model,
    build_flag_participant,
    natural_frequencies_hz,
    solve_csm,
    solve_static,
)

# Turek & Hron (2006) CSM material: rho_s = 1000 kg/m3, mu_s = 0.5e6 Pa, nu_s = 0.4.
CSM: dict[str, Any] = {"density_kg_m3": 1000.0, "shear_modulus_pa": 0.5e6, "poisson_ratio": 0.4}
MATERIAL = SvkMaterial(**CSM)
STRAIGHT = FlagGeometry.turek_hron(curved_clamp=False)


def second_moment(geometry: FlagGeometry) -> float:
    """I = h^3 / 12 per unit depth (m^3)."""
    return geometry.height_m**3 / 12


# --------------------------------------------------------------------------- statics


def test_csm1_matches_turek_hron():
    """CSM1, 40 x 4 quadratic elements, clamp on the cylinder's arc: error -0.38 % (ux),
    -0.22 % (uy); 160 x 16 gives -0.02 % / -0.01 % (benchmarks/plane_strain_csm.py)."""
    tip = solve_csm(**CSM, gravity_m_s2=2.0, elements=(40, 4))
    ref = np.array([-7.187e-3, -66.10e-3])  # Turek & Hron (2006), table CSM1
    np.testing.assert_allclose(tip, ref, rtol=0.01)


def test_small_uniform_load_matches_plane_strain_beam_theory():
    """Gravity 1e-4 m/s^2 (tip deflection ~1e-5 of the length): w = q L^4 / (8 E' I)."""
    g = 1e-4
    tip = solve_csm(**CSM, gravity_m_s2=g, elements=(40, 4), geometry=STRAIGHT, load_steps=1)
    q = CSM["density_kg_m3"] * g * STRAIGHT.height_m  # N/m per unit depth
    w = q * STRAIGHT.length_m**4 / (8 * MATERIAL.plane_strain_modulus_pa * second_moment(STRAIGHT))
    assert tip[1] == pytest.approx(-w, rel=0.01)
    assert abs(tip[0]) < 1e-4 * w


def test_small_tip_force_through_the_interface_matches_beam_theory():
    """Nodal forces on the free end (total P = 1e-3 N/m): w = P L^3 / (3 E' I)."""
    model = build_flag_model(**CSM, elements=(40, 4), geometry=STRAIGHT)
    points = model.mesh.nodes[model.mesh.interface_nodes]
    end = np.isclose(points[:, 0], STRAIGHT.x_tip_m)
    traction = np.zeros((len(points), 2))
    force = np.zeros_like(traction)
    force[end, 1] = -1e-3 * _simpson_weights(points[end, 1])
    x = solve_static(model, model.interface_load(force, traction), steps=1)
    EI = MATERIAL.plane_strain_modulus_pa * second_moment(STRAIGHT)
    w = 1e-3 * STRAIGHT.length_m**3 / (3 * EI)
    assert x.reshape(-1, 2)[model.mesh.tip_node, 1] == pytest.approx(-w, rel=0.01)


def _simpson_weights(y: np.ndarray) -> np.ndarray:
    """Consistent nodal weights of a unit total load on one straight quadratic edge."""
    order = np.argsort(y)
    w = np.zeros(len(y))
    for k in range(0, len(y) - 2, 2):
        w[order[k : k + 3]] += np.array([1.0, 4.0, 1.0]) / 6 * (y[order[k + 2]] - y[order[k]])
    return w / (y.max() - y.min())


def test_first_bending_frequency_matches_euler_bernoulli():
    model = build_flag_model(**CSM, elements=(40, 4), geometry=STRAIGHT)
    f1 = natural_frequencies_hz(model, 1)[0]
    mass = CSM["density_kg_m3"] * STRAIGHT.height_m
    EI = MATERIAL.plane_strain_modulus_pa * second_moment(STRAIGHT)
    f_ref = 1.87510407**2 / (2 * np.pi) * np.sqrt(EI / (mass * STRAIGHT.length_m**4))
    assert f1 == pytest.approx(f_ref, rel=0.01)


def test_tangent_is_the_derivative_of_the_internal_force_and_energy():
    model = build_flag_model(**CSM, elements=(6, 2))
    rng = np.random.default_rng(1)
    x, d, h = 1e-2 * rng.standard_normal(model.ndof), rng.standard_normal(model.ndof), 1e-6
    r, K = model.internal(x)
    fd_force = (model.internal(x + h * d, False)[0] - model.internal(x - h * d, False)[0]) / 2 / h
    fd_energy = (model.strain_energy(x + h * d) - model.strain_energy(x - h * d)) / 2 / h
    np.testing.assert_allclose(K @ d, fd_force, atol=1e-6 * np.abs(fd_force).max())
    assert r @ d == pytest.approx(fd_energy, rel=1e-6)


def test_mass_and_gravity_totals():
    model = build_flag_model(**CSM, gravity_m_s2=2.0, elements=(8, 2), geometry=STRAIGHT)
    area = STRAIGHT.length_m * STRAIGHT.height_m
    assert model.total_mass_kg_m() == pytest.approx(1000.0 * area, rel=1e-12)
    ones_y = np.tile([0.0, 1.0], model.n_nodes)
    assert ones_y @ model.mass @ ones_y == pytest.approx(1000.0 * area, rel=1e-12)
    assert model.gravity_load.sum() == pytest.approx(-2.0 * 1000.0 * area, rel=1e-12)


# --------------------------------------------------------------------------- dynamics


def _release(rho_inf: float, periods: int = 10, steps_per_period: int = 20):
    """Release the 20 x 2 flag from a static 1 mm tip deflection with no load; return the
    energy relative to the start at every step and the tip's vertical displacement."""
    model = build_flag_model(**CSM, elements=(20, 2))
    period = 1.0 / natural_frequencies_hz(model, 1)[0]
    EI = MATERIAL.plane_strain_modulus_pa * second_moment(model.geometry)
    load = np.zeros(model.ndof)
    load[2 * model.mesh.tip_node + 1] = -1e-3 * 3 * EI / model.geometry.length_m**3  # ~1 mm
    integrator = FlagIntegrator(model, rho_inf=rho_inf)
    state = integrator.initial_state(0.0, np.zeros(model.ndof), solve_static(model, load, 1))
    e0 = integrator.energy(state)
    energy, tip = [], []
    for _ in range(periods * steps_per_period):
        state = integrator.step(state, period / steps_per_period, np.zeros(model.ndof))
        energy.append(integrator.energy(state) / e0)
        tip.append(state.x[2 * model.mesh.tip_node + 1])
    return np.array(energy), np.array(tip)


def test_free_oscillation_conserves_energy_with_rho_inf_one():
    """10 periods at 20 steps per period: the trapezoidal rule (rho_inf = 1) keeps the energy
    within 1 % (measured: 2e-5) and the period within 2 % of the linearised first mode (its
    period error at 20 steps is (w dt)^2 / 12 = 0.8 %)."""
    energy, tip = _release(rho_inf=1.0)
    assert np.max(np.abs(energy - 1)) < 0.01
    up = np.flatnonzero(np.diff(np.sign(tip)) > 0)  # upward zero crossings, one per period
    assert len(up) == 10
    assert (up[-1] - up[0]) / 20 / 9 == pytest.approx(1.0, abs=0.02)


def test_numerical_damping_with_rho_inf_below_one():
    """The same release with rho_inf = 0.5 dissipates (measured: 9 % over 10 periods)."""
    energy, _ = _release(rho_inf=0.5)
    assert energy[-1] < 0.95


def test_csm3_first_swing_matches_turek_hron():
    """CSM3 (gravity switched on at t = 0, from rest): the tip's lowest point in the first
    swing against Turek & Hron's CSM3 uy mean - amplitude = -63.607 - 65.160 mm, reached after
    half their period 1 / 1.0995 Hz."""
    flag = build_flag_participant(**CSM, gravity_m_s2=2.0, elements=(20, 2), rho_inf=1.0)
    uy = []
    for _ in range(60):
        flag.solve(0.01)
        uy.append(flag.monitor()["tip_displacement_m"][1])
    assert min(uy) == pytest.approx(-128.767e-3, rel=0.01)
    assert 0.01 * (np.argmin(uy) + 1) == pytest.approx(0.5 / 1.0995, abs=0.01)


def test_heavily_damped_windows_reach_the_static_solution_of_the_forces_read():
    """rho_inf = 0 and windows 100 periods long annihilate the dynamics: the participant fed
    nodal forces through read_data ends at the static equilibrium under them."""
    flag = build_flag_participant(**CSM, elements=(20, 2), rho_inf=0.0)
    points = flag.interface().points
    force = np.zeros_like(points)
    end = np.isclose(points[:, 0], 0.6)
    force[end] = np.array([0.02, -0.05, 7.0]) / end.sum()  # z is ignored
    flag.read_data({"force": force})
    for _ in range(6):
        flag.solve(100.0)
    model = flag.model
    static = solve_static(model, model.interface_load(force[:, :2], 0 * force[:, :2]), 1)
    np.testing.assert_allclose(flag.state.x, static, atol=1e-9 * np.abs(static).max())


def test_static_windows_give_the_static_solution_at_rest():
    """static=True: one window under the forces read is solve_static of the same load, with
    zero velocity and acceleration (what steady FSI1 relies on)."""
    flag = build_flag_participant(**CSM, elements=(20, 2), static=True)
    points = flag.interface().points
    force = np.zeros_like(points)
    end = np.isclose(points[:, 0], 0.6)
    force[end] = np.array([0.02, -0.05, 0.0]) / end.sum()
    flag.read_data({"force": force})
    flag.solve(0.5)
    model = flag.model
    static = solve_static(model, model.interface_load(force[:, :2], 0 * force[:, :2]), 1)
    np.testing.assert_allclose(flag.state.x, static, atol=1e-12 * np.abs(static).max())
    assert not flag.state.v.any() and not flag.state.a.any()
    assert flag.time == 0.5


# --------------------------------------------------------------------------- participant


@pytest.fixture
def flag():
    return build_flag_participant(**CSM, gravity_m_s2=2.0, elements=(8, 2), rho_inf=0.8)


def test_is_a_participant(flag):
    assert isinstance(flag, Participant)


def test_interface_is_the_wetted_boundary(flag):
    mesh = flag.interface()
    g = FlagGeometry.turek_hron()
    assert mesh.cell_type == "line3"
    assert np.all(mesh.points[:, 2] == 0.0)
    nx, ny = 8, 2
    assert len(mesh.points) == 2 * (2 * nx + 1) + 2 * ny - 1
    assert len(mesh.cells) == 2 * nx + ny
    ends = mesh.points[mesh.cells[:, :2]]
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1).sum()
    assert length == pytest.approx(2 * g.length_m + g.height_m, rel=1e-12)
    middle = mesh.points[mesh.cells[:, 2]]
    np.testing.assert_allclose(middle, ends.mean(axis=1), atol=1e-15)
    assert np.all(mesh.points[:, 0] >= g.x_clamp_m - 1e-15)


def test_uniform_traction_gives_its_total_force(flag):
    n = len(flag.interface().points)
    traction = np.tile([3.0, -2.0, 0.0], (n, 1))
    flag.read_data({"traction": traction})
    load = flag.external_load() - flag.model.gravity_load
    wetted = 2 * FlagGeometry.turek_hron().length_m + 0.02
    np.testing.assert_allclose(load.reshape(-1, 2).sum(axis=0), [3.0 * wetted, -2.0 * wetted])


def test_write_data_and_monitor(flag):
    flag.solve(0.01)
    data = flag.write_data()
    n = len(flag.interface().points)
    for key in ("displacement", "velocity", "acceleration"):
        assert data[key].shape == (n, 3)
        assert np.all(data[key][:, 2] == 0.0)
    tip = flag.monitor()["tip_displacement_m"]
    assert tip.shape == (3,)
    assert tip[1] < 0  # falling under gravity
    points = flag.interface().points
    at_a = np.flatnonzero(np.all(np.isclose(points[:, :2], [0.6, 0.2]), axis=1))
    np.testing.assert_array_equal(data["displacement"][at_a[0]], tip)


def test_read_data_rejects_a_wrong_shape(flag):
    with pytest.raises(ValueError, match="force"):
        flag.read_data({"force": np.zeros((3, 3))})


def test_checkpoint_is_a_copy(flag):
    flag.solve(0.01)
    before = flag.save_state()
    flag.store_checkpoint()
    flag.state.x[:] += 1.0  # mutate the live state in place
    flag.state.v[:] -= 1.0
    flag.read_data({"force": np.ones((len(flag.interface().points), 3))})
    flag.solve(0.01)
    flag.restore_checkpoint()
    _assert_states_equal(flag.save_state(), before)
    flag.state.a[:] = 7.0  # mutating after a restore must not reach the checkpoint either
    flag.restore_checkpoint()
    _assert_states_equal(flag.save_state(), before)
    assert flag.time == before["t"]


def test_restored_window_solves_again_identically(flag):
    flag.store_checkpoint()
    flag.solve(0.01)
    first = flag.save_state()
    flag.restore_checkpoint()
    flag.solve(0.01)
    _assert_states_equal(flag.save_state(), first, newton=False)


def test_save_and_load_state_round_trip_bit_for_bit(flag):
    force = np.tile([0.0, 0.3, 0.0], (len(flag.interface().points), 1))
    flag.read_data({"force": force})
    for _ in range(3):
        flag.solve(0.01)
    saved = flag.save_state()
    snapshot = {k: np.copy(v) for k, v in saved.items()}
    for _ in range(2):
        flag.solve(0.01)
    other = build_flag_participant(**CSM, gravity_m_s2=2.0, elements=(8, 2), rho_inf=0.8)
    other.load_state(saved)
    for _ in range(2):
        other.solve(0.01)
    _assert_states_equal(other.save_state(), flag.save_state())
    _assert_states_equal(saved, snapshot)  # the saved dict was not changed by running on


def _assert_states_equal(a, b, newton: bool = True) -> None:
    keys = set(a) - ({"newton_iterations"} if not newton else set())
    assert keys <= set(b)
    for key in keys:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_bad_configuration_names_the_field():
    with pytest.raises(ValueError, match="poisson_ratio"):
        SvkMaterial(density_kg_m3=1000.0, shear_modulus_pa=0.5e6, poisson_ratio=0.5)
    with pytest.raises(ValueError, match="rho_inf"):
        build_flag_participant(**CSM, rho_inf=1.5)
    with pytest.raises(ValueError, match="elements"):
        build_flag_model(**CSM, elements=(0, 2))
