"""Coupling accelerations on small fixed-point maps ``H(x) = A x + b`` with hand-checkable
numbers (in the spirit of preCICE ``tests/AccelerationSerialTest.cpp``)."""

from __future__ import annotations

import copy
import dataclasses
import subprocess
import sys
from collections.abc import Callable

import numpy as np
import pytest

from fsi_orchestrator.acceleration import (
    AccelerationSettingsError,
    AccelerationStateError,
    AitkenRelaxation,
    AitkenSettings,
    ConstantRelaxation,
    ConstantSettings,
    IQNILSAcceleration,
    IQNILSSettings,
    apply_relaxation,
    make_acceleration,
    qr1_filter,
    qr2_filter,
)
from fsi_orchestrator.convergence import ConvergenceCriteria, RelativeMeasure

Map = Callable[[np.ndarray], np.ndarray]


def affine(a: np.ndarray, b: np.ndarray) -> Map:
    return lambda x: a @ x + b


def random_map(n: int, radius: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``A`` with spectral radius ``radius`` (> 1: plain iteration diverges) and ``b``."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    return a * radius / max(abs(np.linalg.eigvals(a))), rng.normal(size=n)


def iterate(acc, h: Map, x0: np.ndarray, steps: int) -> list[np.ndarray]:
    """``steps`` accelerated iterations on the single field "f"; returns x^1 .. x^steps."""
    x, out = {"f": x0}, []
    for _ in range(steps):
        x = acc.perform(x, {"f": h(x["f"])})
        out.append(x["f"])
    return out


def run_window(acc, h: Map, x0: np.ndarray, tol: float = 1e-10) -> tuple[np.ndarray, int, list]:
    """One coupled window as the loop runs it: (converged x, number of solves, iterates)."""
    criteria = ConvergenceCriteria({"f": [RelativeMeasure(tolerance=tol)]}, max_iterations=60)
    x, iterates = {"f": x0}, list[np.ndarray]()
    while True:
        xt = {"f": h(x["f"])}
        if criteria.check(x, xt).done:
            acc.iterations_converged(x, xt)
            return x["f"], criteria.iteration, iterates
        x = acc.perform(x, xt)
        iterates.append(x["f"])


def started(acc, n: int = 2):
    acc.initialize({"f": np.zeros(n)})
    return acc


def test_apply_relaxation_is_the_precice_formula():
    # omega * x~ + (1 - omega) * x = 0.25 * 4 + 0.75 * 0 = 1
    np.testing.assert_array_equal(
        apply_relaxation(0.25, np.zeros(2), np.array([4.0, -8.0])), [1, -2]
    )


def test_constant_relaxation_matches_hand_iterates():
    # H(x) = diag(1/2, -1) x + (1, 1), x^0 = 0, omega = 1/2; by hand:
    # x~0 = (1, 1)       -> x1 = (0.5, 0.5)
    # x~1 = (1.25, 0.5)  -> x2 = (0.875, 0.5)
    # x~2 = (1.4375, 0.5) -> x3 = (1.15625, 0.5)
    acc = started(ConstantRelaxation(ConstantSettings(relaxation=0.5)))
    h = affine(np.diag([0.5, -1.0]), np.ones(2))
    xs = iterate(acc, h, np.zeros(2), 3)
    np.testing.assert_allclose(xs, [[0.5, 0.5], [0.875, 0.5], [1.15625, 0.5]], rtol=0, atol=1e-15)


def test_aitken_matches_hand_iterates():
    # H(x) = diag(1/2, -1/2) x + (1, 1), x^0 = 0, omega_0 = 1/2. By hand (r = x~ - x):
    # r0 = (1, 1), x1 = (1/2, 1/2); r1 = (3/4, 1/4), dr = (-1/4, -3/4),
    # omega_1 = -1/2 * (r0.dr)/(dr.dr) = -1/2 * (-1)/(5/8) = 4/5, x2 = x1 + 4/5 r1 = (11/10, 7/10);
    # r2 = (9/20, -1/20), dr = (-3/10, -3/10), omega_2 = -4/5 * (-3/10)/(18/100) = 4/3,
    # x3 = x2 + 4/3 r2 = (17/10, 19/30).
    acc = started(AitkenRelaxation(AitkenSettings(initial_relaxation=0.5)))
    h = affine(np.diag([0.5, -0.5]), np.ones(2))
    x, omegas = {"f": np.zeros(2)}, []
    for _ in range(3):
        x = acc.perform(x, {"f": h(x["f"])})
        omegas.append(acc.omega)
    np.testing.assert_allclose(omegas, [0.5, 4 / 5, 4 / 3], rtol=1e-14)
    np.testing.assert_allclose(x["f"], [17 / 10, 19 / 30], rtol=1e-14)


def test_aitken_restarts_each_window_with_sign_of_last_factor():
    # H(x) = 3 x - 2 (fixed point 1, slope 3: plain iteration diverges), x^0 = 0, omega_0 = 1/2:
    # r0 = -2, x1 = -1; r1 = -4, dr = -2, omega_1 = -1/2 * (r0 dr)/(dr dr) = -1/2 * 4/4 = -1/2,
    # x2 = -1 + (-1/2)(-4) = 1 (secant: exact). Next window: omega = sign(-1/2) min(1/2, 1/2).
    acc = AitkenRelaxation(AitkenSettings(initial_relaxation=0.5))
    acc.initialize({"f": np.zeros(1)})
    h = affine(np.array([[3.0]]), np.array([-2.0]))
    x_end, solves, _ = run_window(acc, h, np.zeros(1))
    assert solves == 3 and x_end == pytest.approx([1.0], abs=1e-15)
    acc.perform({"f": np.zeros(1)}, {"f": h(np.zeros(1))})
    assert acc.omega == -0.5


@pytest.mark.parametrize(
    ("filter_", "eps"), [("none", 1e-2), ("QR1", 1e-12), ("QR2", 1e-8)], ids=str
)
def test_iqn_ils_solves_affine_map_within_n_plus_1_iterations(filter_, eps):
    n = 6
    a, b = random_map(n, radius=1.8, seed=1)  # spectral radius 1.8: explicit iteration diverges
    x_star = np.linalg.solve(np.eye(n) - a, b)
    acc = IQNILSAcceleration(
        IQNILSSettings(initial_relaxation=0.3, filter=filter_, filter_eps=eps, reuse_windows=0)
    )
    xs = iterate(started(acc, n), affine(a, b), np.zeros(n), n + 1)
    # after n columns the least-squares model is the exact inverse Jacobian: x^{n+1} = x*
    assert np.linalg.norm(xs[-1] - x_star) < 1e-10 * np.linalg.norm(x_star)
    assert np.linalg.norm(xs[-3] - x_star) > 1e-6  # ... and not trivially earlier


def test_iqn_ils_reusing_past_windows_converges_faster():
    n = 6
    a, b = random_map(n, radius=1.8, seed=2)
    b2 = b + 0.1 * np.random.default_rng(3).normal(size=n)  # next window: other load
    solves = {}
    for reuse in (0, 1):
        acc = started(
            IQNILSAcceleration(
                IQNILSSettings(initial_relaxation=0.3, filter="none", reuse_windows=reuse)
            ),
            n,
        )
        _, solves[reuse, 1], _ = run_window(acc, affine(a, b), np.zeros(n))
        x2, solves[reuse, 2], _ = run_window(acc, affine(a, b2), np.zeros(n))
        np.testing.assert_allclose(x2, np.linalg.solve(np.eye(n) - a, b2), rtol=1e-9)
    assert solves[0, 1] == solves[1, 1] <= n + 2  # n + 1 updates, then the converged solve
    assert solves[0, 2] == solves[0, 1]  # without reuse window 2 starts from scratch
    assert solves[1, 2] == 2  # window 1's columns span the space: one exact QN step


def test_reuse_keeps_only_the_last_windows():
    n = 30  # more unknowns than the columns of two windows: no column limit
    a, b = random_map(n, radius=0.5, seed=4)
    settings = IQNILSSettings(initial_relaxation=0.5, reuse_windows=2, filter="none")
    acc = started(IQNILSAcceleration(settings), n)
    added = []  # a window of K solves adds K - 1 columns (K - 2 updates + the converged pair)
    for k in range(4):
        _, solves, _ = run_window(acc, affine(a, b * (1 + 0.1 * k)), np.zeros(n), tol=1e-4)
        added.insert(0, solves - 1)
        cols = acc.save_state()["qn_window_cols"]
        np.testing.assert_array_equal(cols, [0, *added[:2]])  # current (empty), last, previous
        assert acc.n_columns == sum(added[:2])
    assert acc.dropped_columns == sum(added[2:])


def _feed(acc, residuals: list[np.ndarray]) -> None:
    """Iterations whose residuals are given (x = 0, x~ = r): V columns are r^k - r^{k-1}."""
    for r in residuals:
        acc.perform({"f": np.zeros(r.size)}, {"f": r})


def test_column_limit_drops_the_oldest_columns():
    rs = list(np.random.default_rng(8).normal(size=(10, 6)))  # 10 iterations -> 9 differences
    acc = started(IQNILSAcceleration(IQNILSSettings(initial_relaxation=0.5, max_columns=3)), 6)
    _feed(acc, rs)
    v, _ = acc.matrices
    assert acc.n_columns == 3 and acc.dropped_columns == 6
    np.testing.assert_allclose(v, np.column_stack([rs[9] - rs[8], rs[8] - rs[7], rs[7] - rs[6]]))


def test_qr2_filter_removes_nearly_dependent_column():
    a, b, e = np.array([1.0, 0, 0, 0]), np.array([0, 1.0, 1.0, 0]), np.array([0, 0, 0, 1.0])
    v = np.column_stack([a + 1e-10 * e, b, a])  # newest first; the oldest repeats the newest
    q, r, kept = qr2_filter(v, 1e-6)
    assert kept == [0, 1]
    np.testing.assert_allclose(q @ r, v[:, kept], atol=1e-15)
    assert qr1_filter(v, 1e-6)[2] == [0, 1]
    assert qr2_filter(v, 0.0)[2] == [0, 1, 2]  # "none" keeps it: 1e-10 is not exactly zero
    # the same through the accelerator: residual steps a, b, a + 1e-10 e
    acc = started(
        IQNILSAcceleration(IQNILSSettings(initial_relaxation=0.5, filter="QR2", filter_eps=1e-6)), 4
    )
    r0 = np.array([1.0, 2.0, 3.0, 4.0])
    _feed(acc, [r0, r0 + a, r0 + a + b, r0 + 2 * a + b + 1e-10 * e])
    assert acc.n_columns == 2 and acc.deleted_columns == 1
    v_kept, _ = acc.matrices
    np.testing.assert_allclose(v_kept, np.column_stack([a + 1e-10 * e, b]), atol=1e-15)


def test_h0_exact_inverse_jacobian_gives_the_solution_in_one_iteration():
    n = 5
    a, b = random_map(n, radius=3.0, seed=5)
    jac = np.eye(n) - a  # dx = (I - H')^{-1} r is Newton's step for r = H(x) - x

    def h0(r):
        return np.linalg.solve(jac, r)

    acc = started(make_acceleration("iqn-ils", h0=h0, initial_relaxation=0.1), n)
    for window, load in enumerate((b, 2 * b)):  # window 1 already has columns: H0 stays exact
        x_end, solves, iterates = run_window(acc, affine(a, load), np.ones(n))
        np.testing.assert_allclose(iterates[0], np.linalg.solve(jac, load), rtol=1e-12)
        assert solves == 2, window


def test_h0_identity_is_plain_iqn_ils():
    n = 5
    a, b = random_map(n, radius=1.5, seed=6)
    plain = started(IQNILSAcceleration(IQNILSSettings(initial_relaxation=1.0, filter="none")), n)
    ident = started(
        IQNILSAcceleration(IQNILSSettings(initial_relaxation=0.2, filter="none"), h0=lambda r: r), n
    )
    for p, q in zip(
        iterate(plain, affine(a, b), np.zeros(n), 4),
        iterate(ident, affine(a, b), np.zeros(n), 4),
        strict=True,
    ):
        np.testing.assert_allclose(p, q, rtol=1e-12, atol=1e-12)


SCHEMES = {
    "constant": dict(relaxation=0.3),
    "aitken": dict(initial_relaxation=0.3),
    "iqn-ils": dict(initial_relaxation=0.3, reuse_windows=2, max_columns=4),
}


def two_field_map():
    """A 5-unknown map on fields of very different size: force (N, ~1e3), displacement (m)."""
    a, b = random_map(5, radius=0.95, seed=7)
    scale = np.array([1e3, 1e3, 1e3, 1e-3, 1e-3])
    a, b = a * scale[:, None] / scale[None, :], b * scale

    def h(x: dict) -> dict:
        y = a @ np.concatenate([x["force"].ravel(), x["displacement"]]) + b
        return {"force": y[:3].reshape(1, 3), "displacement": y[3:]}

    return h, {"force": np.zeros((1, 3)), "displacement": np.zeros(2)}


def run_fields(acc, h, x, iterations):
    out = []
    for _ in range(iterations):
        x = acc.perform(x, h(x))
        out.append(x)
    return x, out


@pytest.mark.parametrize("name", list(SCHEMES))
@pytest.mark.parametrize("mid_window", [False, True], ids=["at-window-end", "mid-window"])
def test_state_round_trip_gives_identical_iterates(name, mid_window):
    h, x0 = two_field_map()
    live = make_acceleration(name, **SCHEMES[name])
    live.initialize(x0)
    x = x0
    for _ in range(2):  # two windows of 4 iterations
        x, _ = run_fields(live, h, x0, 4)
        live.iterations_converged(x, h(x))
    if mid_window:
        x, _ = run_fields(live, h, x0, 2)
    saved = live.save_state()
    kept = copy.deepcopy(saved)
    _, expected = run_fields(live, h, x, 4)  # the live object goes on ...
    for key, value in saved.items():  # ... without touching what was saved
        np.testing.assert_array_equal(value, kept[key])
    fresh = make_acceleration(name, **SCHEMES[name])
    fresh.initialize(x0)
    fresh.load_state(saved)
    for key, value in saved.items():  # loading leaves its input alone ...
        np.testing.assert_array_equal(value, kept[key])
        value[...] = 7  # ... and keeps copies: this must not reach `fresh`
    _, resumed = run_fields(fresh, h, x, 4)
    for e, r in zip(expected, resumed, strict=True):
        for field in e:
            np.testing.assert_allclose(r[field], e[field], rtol=1e-15, atol=0)


def test_load_state_rejects_another_layout():
    acc = started(make_acceleration("iqn-ils", initial_relaxation=0.5), 3)
    _feed(acc, [np.ones(3), np.arange(3.0)])
    other = started(make_acceleration("iqn-ils", initial_relaxation=0.5), 4)
    with pytest.raises(AccelerationStateError, match="4 unknowns"):
        other.load_state(acc.save_state())


def test_two_fields_of_different_units_keep_their_shapes_and_converge():
    h, x0 = two_field_map()
    for scaling in (
        dict(),
        dict(preconditioner="constant", field_scales={"force": 1e3, "displacement": 1e-3}),
    ):
        acc = make_acceleration("iqn-ils", initial_relaxation=0.1, filter="none", **scaling)
        acc.initialize(x0)
        x, _ = run_fields(acc, h, x0, 6)  # 5 unknowns: exact after n + 1 = 6 updates
        assert x["force"].shape == (1, 3) and x["displacement"].shape == (2,)
        r = {k: h(x)[k] - x[k] for k in x}
        assert np.linalg.norm(r["force"]) < 1e-9 * 1e3
        assert np.linalg.norm(r["displacement"]) < 1e-9 * 1e-3


def test_settings_are_validated_with_clear_messages():
    with pytest.raises(AccelerationSettingsError, match=r"relaxation must be in \(0, 1\], got 1.7"):
        ConstantSettings(relaxation=1.7)
    with pytest.raises(AccelerationSettingsError, match="initial_relaxation .* got 0"):
        AitkenSettings(initial_relaxation=0)
    bad = [
        (dict(filter="QR4"), "filter must be one of"),
        (dict(reuse_windows=-1), "reuse_windows must be an integer >= 0, got -1"),
        (dict(max_columns=0), "max_columns must be an integer >= 1, got 0"),
        (dict(filter_eps=0.0), r"filter_eps must be in \(0, 1\), got 0.0"),
        (dict(preconditioner="value"), "preconditioner must be one of"),
        (dict(preconditioner="constant"), "needs field_scales"),
        (dict(field_scales={"force": -1.0}), r"field_scales\['force'\] must be a positive"),
    ]
    for kwargs, message in bad:
        with pytest.raises(AccelerationSettingsError, match=message):
            IQNILSSettings(initial_relaxation=0.5, **kwargs)
    settings = IQNILSSettings(initial_relaxation=0.5, filter="QR1")
    assert settings.filter == "QR1" and settings.filter.__class__.__name__ == "QRFilter"
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.max_columns = 3  # type: ignore[misc]


def test_make_acceleration_names_and_errors():
    assert isinstance(make_acceleration("constant", relaxation=0.5), ConstantRelaxation)
    assert isinstance(make_acceleration("aitken", initial_relaxation=0.5), AitkenRelaxation)
    assert isinstance(make_acceleration("iqn-ils", initial_relaxation=0.5), IQNILSAcceleration)
    with pytest.raises(AccelerationSettingsError, match="must be one of .*got 'iqn-mvj'"):
        make_acceleration("iqn-mvj", initial_relaxation=0.5)
    with pytest.raises(AccelerationSettingsError, match=r"unknown settings \['relax'\]"):
        make_acceleration("constant", relax=0.5)
    with pytest.raises(AccelerationSettingsError, match=r"needs the settings \['relaxation'\]"):
        make_acceleration("constant")
    with pytest.raises(AccelerationSettingsError, match="h0 is only used by 'iqn-ils'"):
        make_acceleration("aitken", initial_relaxation=0.5, h0=lambda r: r)


def test_fields_must_match_the_initialized_layout():
    acc = make_acceleration("constant", relaxation=0.5)
    with pytest.raises(RuntimeError, match="initialize"):
        acc.perform({"f": np.zeros(2)}, {"f": np.zeros(2)})
    acc.initialize({"force": np.zeros((4, 3))})
    with pytest.raises(AccelerationStateError, match=r"'force' must have shape \(4, 3\)"):
        acc.perform({"force": np.zeros(12)}, {"force": np.zeros(12)})
    with pytest.raises(AccelerationStateError, match="accelerated fields are"):
        acc.perform({"pressure": np.zeros(4)}, {"pressure": np.zeros(4)})


def test_modules_stay_free_of_solver_libraries():
    code = (
        "import sys, fsi_orchestrator.acceleration, fsi_orchestrator.convergence, "
        "fsi_orchestrator.predictors; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "{'skfem', 'foamlib', 'solid_adapter', 'fluid_adapter'}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_imvj_keeps_the_jacobian_across_windows():
    """IQN-IMVJ (Lindner et al. 2015): on the same affine map every window, after the first
    window has been solved its Jacobian memory makes the next windows converge in 1-2 QN steps
    (plain IQN-ILS without reuse needs n + 1)."""
    from fsi_orchestrator.acceleration.iqn_ils import IQNILSSettings
    from fsi_orchestrator.acceleration.iqn_imvj import IQNIMVJAcceleration

    rng = np.random.default_rng(3)
    n = 6
    A = rng.normal(size=(n, n)) * 0.4
    counts = []
    acc = IQNIMVJAcceleration(IQNILSSettings(initial_relaxation=0.5))
    acc.initialize({"x": np.zeros(n)})
    for _ in range(4):
        b = rng.normal(size=n)
        exact = np.linalg.solve(np.eye(n) - A, b)
        x = np.zeros(n)
        for k in range(1, 30):  # noqa: B007 -- k is the iteration count used below
            xt = A @ x + b
            if np.linalg.norm(xt - x) < 1e-10 * np.linalg.norm(exact):
                break
            x = acc.perform({"x": x}, {"x": xt})["x"]
        acc.iterations_converged({"x": x}, {"x": xt})
        counts.append(k)
        np.testing.assert_allclose(x, exact, rtol=1e-8)
    assert counts[0] <= n + 2 and max(counts[1:]) <= 3


def test_imvj_warm_started_from_another_run_skips_the_learning():
    """A Jacobian learned by one run (saved state) warm-starts another on the same affine
    map: its first window converges in the 1-2 QN steps that the first run reached only after
    learning (n + 1 or more cold); the state of another layout is refused by shape."""
    from fsi_orchestrator.acceleration import AccelerationStateError
    from fsi_orchestrator.acceleration.iqn_ils import IQNILSSettings
    from fsi_orchestrator.acceleration.iqn_imvj import IQNIMVJAcceleration

    rng = np.random.default_rng(3)
    n = 6
    a = rng.normal(size=(n, n)) * 0.4
    h = affine(a, rng.normal(size=n))

    def fresh():
        return started(IQNIMVJAcceleration(IQNILSSettings(initial_relaxation=0.5)), n)

    learner = fresh()
    cold = [run_window(learner, h, np.zeros(n))[1] for _ in range(3)]
    warm = fresh()
    warm.warm_start(learner.save_state())
    x, solves, _ = run_window(warm, h, np.zeros(n))
    np.testing.assert_allclose(x, np.linalg.solve(np.eye(n) - a, h(np.zeros(n))), rtol=1e-8)
    assert cold[0] >= n + 1 and solves <= 3
    other = started(IQNIMVJAcceleration(IQNILSSettings(initial_relaxation=0.5)), n + 1)
    with pytest.raises(AccelerationStateError, match="imvj_jacobian"):
        other.warm_start(learner.save_state())
