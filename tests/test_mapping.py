"""Interface mapping: exactness, conservation, convergence, continuity, errors.

References: linear precision of RBF interpolation with a linear polynomial and of a partition of
unity built from such local interpolants (Wendland, "Fast evaluation of radial basis functions:
methods based on partition of unity", Approximation Theory X, 2002), which gives O(h^2) for
smooth fields; conservation of force and moment by the transpose of a linear-exact consistent
map (de Boer, van Zuijlen, Bijl, CMAME 196, 2007, Sec. 2; preCICE ``constraint="conservative"``).
"""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.mapping import InterfaceMapping, MappingError
from fsi_orchestrator.participant import InterfaceMesh

LENGTH_M = 0.167  # the original fish's length (docs/geometry.md)
HALF_THICKNESS_M = 0.4e-3  # 0.8 mm laminate


def half_height(x):
    """Fish-like planform: 27.5 mm half-height with a narrow peduncle near x = 0.14 m."""
    return 0.0275 * (1.0 - 0.45 * np.exp(-(((x - 0.14) / 0.015) ** 2)))


def structure_nodes(nx, ny):
    """9-node-quad node positions: 2 nx + 1 graded columns, 2 ny + 1 rows scaled by the outline."""
    s = np.linspace(0.0, 1.0, 2 * nx + 1)
    x = LENGTH_M * (s + 0.05 * np.sin(2 * np.pi * s))
    frac = np.linspace(-1.0, 1.0, 2 * ny + 1)
    X = np.repeat(x, len(frac))
    return np.column_stack([X, np.tile(frac, len(x)) * half_height(X)])


def fluid_points(n, seed=0):
    """Points on both faces (z = +-h/2) and on the outline, like an OpenFOAM plate patch."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, LENGTH_M, n)
    y = rng.uniform(-1.0, 1.0, n) * half_height(x)
    xe = np.linspace(0.0, LENGTH_M, n // 10)
    edge = np.column_stack([np.r_[xe, xe], np.r_[half_height(xe), -half_height(xe)]])
    xy = np.vstack([np.column_stack([x, y]), edge])
    z = np.r_[np.full(len(xy), HALF_THICKNESS_M), np.full(len(xy), -HALF_THICKNESS_M)]
    return np.column_stack([np.vstack([xy, xy]), z])


@pytest.fixture(scope="module")
def fish():
    src = structure_nodes(16, 4)
    tgt = fluid_points(1000)
    return src, tgt, InterfaceMapping.from_points(src, tgt[:, :2])


def test_constant_and_linear_fields_are_exact(fish):
    src, tgt, mapping = fish
    rng = np.random.default_rng(1)
    a, b, c = rng.standard_normal((3, 3))
    field_s = a + np.outer(src[:, 0] / LENGTH_M, b) + np.outer(src[:, 1] / LENGTH_M, c)
    field_t = a + np.outer(tgt[:, 0] / LENGTH_M, b) + np.outer(tgt[:, 1] / LENGTH_M, c)
    assert np.abs(mapping.consistent(field_s) - field_t).max() < 1e-10
    assert np.abs(mapping.consistent(np.full(len(src), 2.5)) - 2.5).max() < 1e-12


def test_conservative_preserves_force_and_in_plane_moment(fish):
    src, tgt, mapping = fish
    rng = np.random.default_rng(2)
    forces = rng.standard_normal((len(tgt), 3))
    nodal = mapping.conservative(forces)
    assert np.allclose(nodal.sum(axis=0), forces.sum(axis=0), rtol=0, atol=1e-10 * len(tgt))
    for point in rng.uniform(-0.1, 0.3, (3, 3)):
        arms_t = np.column_stack([tgt[:, :2], np.zeros(len(tgt))]) - point
        arms_s = np.column_stack([src, np.zeros(len(src))]) - point
        m_fluid = np.cross(arms_t, forces).sum(axis=0)
        m_shell = np.cross(arms_s, nodal).sum(axis=0)
        scale = np.abs(np.cross(arms_t, forces)).sum()
        assert np.abs(m_shell - m_fluid).max() < 1e-10 * scale
        # The documented difference to the true moment is the face-offset arm e_z x sum z F.
        m_true = np.cross(tgt - point, forces).sum(axis=0)
        offset = np.cross([0.0, 0.0, 1.0], (tgt[:, 2:] * forces).sum(axis=0))
        assert np.abs(m_true - m_shell - offset).max() < 1e-10 * scale


def test_conservative_is_the_transpose(fish):
    """Equal virtual work on both sides: <H u, F> = <u, H^T F>."""
    src, tgt, mapping = fish
    rng = np.random.default_rng(3)
    u, f = rng.standard_normal((len(src), 3)), rng.standard_normal((len(tgt), 3))
    work_fluid = np.sum(mapping.consistent(u) * f)
    assert np.sum(u * mapping.conservative(f)) == pytest.approx(work_fluid, rel=1e-12)


def test_both_faces_move_together(fish):
    src, tgt, mapping = fish
    values = np.sin(src[:, 0] / LENGTH_M * 5) * src[:, 1]
    mapped = mapping.consistent(values)
    half = len(tgt) // 2  # fluid_points stacks the +z face over the -z face
    assert np.array_equal(mapped[:half], mapped[half:])


def quadratic(xy):
    x, y = xy[:, 0] / LENGTH_M, xy[:, 1] / LENGTH_M
    return x**2 + 3 * x * y - 2 * y**2


def test_quadratic_field_converges_at_second_order():
    tgt = fluid_points(2000, seed=4)[:, :2]
    spacings, errors = [], []
    for nx, ny in ((4, 1), (8, 2), (16, 4), (32, 8), (64, 16)):
        src = structure_nodes(nx, ny)
        mapping = InterfaceMapping.from_points(src, tgt)
        errors.append(np.abs(mapping.consistent(quadratic(src)) - quadratic(tgt)).max())
        spacings.append(LENGTH_M / (2 * nx))
    rate = np.polyfit(np.log(spacings[1:]), np.log(errors[1:]), 1)[0]
    print(f"quadratic field: max errors {np.array(errors)}, fitted rate {rate:.2f}")
    assert np.all(np.diff(errors) < 0)
    assert rate > 1.8  # O(h^2): linear precision (Wendland 2002)


def test_mapped_field_has_no_jumps():
    """Along a dense line the mapped field changes by at most a few times |grad f| per step,
    so no patch edge makes a jump (a nearest-neighbour stencil switch would)."""
    src = structure_nodes(8, 2)
    x = np.linspace(0.07, 0.09, 20001)
    line = np.column_stack([x, 0.3 * half_height(x)])
    mapped = InterfaceMapping.from_points(src, line).consistent(quadratic(src))
    slope = np.abs(np.diff(mapped)) / np.diff(x)
    grad_max = 2 * 0.09 / LENGTH_M**2 + 3 * 0.3 * 0.0275 / LENGTH_M**2
    assert slope.max() < 3 * grad_max


def test_inputs_are_not_changed(fish):
    src, tgt, mapping = fish
    src_copy, tgt_copy = src.copy(), tgt[:, :2].copy()
    InterfaceMapping.from_points(src_copy, tgt_copy)
    values = np.ones((len(src), 3))
    mapping.consistent(values)
    assert np.array_equal(src_copy, src) and np.array_equal(tgt_copy, tgt[:, :2])
    assert np.array_equal(values, np.ones((len(src), 3)))


def test_from_interfaces_maps_in_the_plate_plane(fish):
    src, tgt, mapping = fish
    no_cells = np.zeros((0, 4), dtype=np.int64)
    shell = InterfaceMesh(np.column_stack([src, np.zeros(len(src))]), no_cells, "quad")
    fluid = InterfaceMesh(tgt, no_cells, "quad")
    other = InterfaceMapping.from_interfaces(shell, fluid)
    assert (other.matrix != mapping.matrix).nnz == 0


def test_fixed_support_radius_is_also_exact(fish):
    src, tgt, _ = fish
    mapping = InterfaceMapping.from_points(src, tgt[:, :2], support_radius=0.012)
    assert (
        np.abs(mapping.consistent(src[:, 0] - 2 * src[:, 1]) - (tgt[:, 0] - 2 * tgt[:, 1])).max()
        < 1e-10
    )


@pytest.mark.parametrize(
    ("source", "target", "match"),
    [
        (np.zeros((5, 3)), np.zeros((4, 2)), "source_xy"),
        (structure_nodes(4, 1), np.zeros((4, 3)), "target_xy"),
        (np.vstack([structure_nodes(4, 1)] * 2), np.zeros((4, 2)), "coincident"),
        (structure_nodes(4, 1), np.array([[1.0, 1.0]]), "outside every source patch"),
    ],
)
def test_bad_inputs_name_the_problem(source, target, match):
    with pytest.raises(MappingError, match=match):
        InterfaceMapping.from_points(source, target)


def test_wrong_data_shape_is_rejected(fish):
    _, _, mapping = fish
    with pytest.raises(MappingError, match="values"):
        mapping.consistent(np.zeros(mapping.n_source + 1))


def test_fish_size_mapping_reproduces_constant_and_linear_fields():
    """At the fish's size (495 shell x 4992 fluid points; timings: benchmarks/mapping_cost.py)
    the consistent map keeps a rigid translation and a linear field exactly."""
    src, tgt = structure_nodes(16, 7), fluid_points(2080, seed=5)[:, :2]
    mapping = InterfaceMapping.from_points(src, tgt)
    np.testing.assert_allclose(mapping.consistent(np.ones((len(src), 3))), 1.0, atol=1e-10)
    linear = 0.3 * src[:, :1] - 2.0 * src[:, 1:2] + 0.01
    np.testing.assert_allclose(
        mapping.consistent(linear), 0.3 * tgt[:, :1] - 2.0 * tgt[:, 1:2] + 0.01, atol=1e-10
    )
