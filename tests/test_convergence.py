"""Convergence measures (preCICE semantics, strict ``<``), iteration bounds, divergence
reporting, and predictors; every number is worked out by hand in the comments."""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.acceleration import make_acceleration
from fsi_orchestrator.convergence import (
    AbsoluteMeasure,
    ConvergenceCriteria,
    ConvergenceSettingsError,
    CouplingDivergenceError,
    RelativeMeasure,
    ResidualRelativeMeasure,
    WindowStatus,
)
from fsi_orchestrator.predictors import (
    EXPLICIT_RULES,
    PERIODIC_RULES,
    Predictor,
    lagrange_weights,
)

OLD, NEW = np.zeros(2), np.array([3.0, 4.0])  # ||NEW - OLD|| = 5


def test_absolute_measure():
    assert not AbsoluteMeasure(tolerance=5.0).measure(OLD, NEW)  # 5 < 5 is false
    m = AbsoluteMeasure(tolerance=5.1)
    assert m.measure(OLD, NEW) and m.norm_diff == 5.0


def test_relative_measure():
    old = np.array([3.0, 3.9])  # ||NEW - old|| = 0.1, ||NEW|| = 5: converged iff tol > 0.02
    assert RelativeMeasure(tolerance=0.03).measure(old, NEW)
    m = RelativeMeasure(tolerance=0.01)
    assert not m.measure(old, NEW)
    assert m.value == pytest.approx(0.02)
    assert not RelativeMeasure(tolerance=1.0).measure(OLD, OLD)  # 0 < 1 * 0 is false


def test_residual_relative_measure_uses_the_first_residual_of_the_window():
    m = ResidualRelativeMeasure(tolerance=0.01)
    assert not m.measure(OLD, NEW)  # first residual 5 is its own reference: never converged
    assert m.measure(OLD, np.array([0.0, 0.04]))  # 0.04 < 0.01 * 5
    assert not m.measure(OLD, np.array([0.0, 0.06]))  # 0.06 > 0.05
    m.reset_window()
    assert not m.measure(OLD, np.array([0.0, 0.04]))  # new window: 0.04 is the reference now


def test_log_lines_state_the_numbers():
    m = RelativeMeasure(tolerance=0.01)
    m.measure(np.array([3.0, 3.9]), NEW)
    line = m.log_line()
    assert line.startswith("relative:") and "1.000e-01" in line and "2.000e-02" in line
    assert line.endswith("converged no")
    criteria = ConvergenceCriteria({"force": [m]})
    criteria.new_window(4)
    criteria.check({"force": np.array([3.0, 3.9])}, {"force": NEW})
    assert criteria.log_lines()[0].startswith("window 4 iteration 1 force: relative:")


def test_tolerances_are_validated():
    with pytest.raises(ConvergenceSettingsError, match=r"relative tolerance must be in \(0, 1\]"):
        RelativeMeasure(tolerance=1.5)
    with pytest.raises(ConvergenceSettingsError, match="absolute tolerance must be in"):
        AbsoluteMeasure(tolerance=0.0)
    with pytest.raises(ConvergenceSettingsError, match="max_iterations .* must be >= min"):
        ConvergenceCriteria({}, min_iterations=3, max_iterations=2)


def test_min_and_max_iterations():
    converged_at_once = ConvergenceCriteria(
        {"f": [AbsoluteMeasure(tolerance=10.0)]}, min_iterations=2, max_iterations=5
    )
    assert converged_at_once.check({"f": OLD}, {"f": NEW}) is WindowStatus.ITERATE
    assert converged_at_once.check({"f": OLD}, {"f": NEW}) is WindowStatus.CONVERGED
    never = ConvergenceCriteria({"f": [AbsoluteMeasure(tolerance=1.0)]}, max_iterations=3)
    statuses = [never.check({"f": OLD}, {"f": NEW}) for _ in range(3)]
    assert statuses == ["iterate", "iterate", "max-iterations"] and statuses[-1].done
    # an explicit window of an implicit run: one iteration, then the run's bound again
    never.new_window(1, max_iterations=1)
    assert never.check({"f": OLD}, {"f": NEW}) is WindowStatus.MAX_ITERATIONS
    never.new_window(2)
    assert never.check({"f": OLD}, {"f": NEW}) is WindowStatus.ITERATE
    with pytest.raises(ConvergenceSettingsError, match="max_iterations must be an integer"):
        never.new_window(3, max_iterations=0)


def test_all_measures_of_all_fields_must_hold():
    criteria = ConvergenceCriteria(
        {"force": [AbsoluteMeasure(tolerance=10.0)], "displacement": [AbsoluteMeasure(tolerance=1)]}
    )
    fields = {"force": OLD, "displacement": OLD}
    assert criteria.check(fields, {"force": NEW, "displacement": OLD}) is WindowStatus.CONVERGED
    assert criteria.check(fields, {"force": NEW, "displacement": NEW}) is WindowStatus.ITERATE
    with pytest.raises(KeyError, match="displacement"):
        criteria.check({"force": OLD}, {"force": NEW})


def test_a_sufficing_measure_is_enough_on_its_own():
    # a zero field never meets the relative test (0 < tol * 0 is false); an absolute one helps
    zero = {"force": np.zeros(2)}
    strict = ConvergenceCriteria({"force": [RelativeMeasure(tolerance=1e-4)]}, max_iterations=5)
    assert strict.check(zero, zero) is WindowStatus.ITERATE
    either = ConvergenceCriteria(
        {"force": [RelativeMeasure(tolerance=1e-4), AbsoluteMeasure(tolerance=1e-9, suffices=True)]}
    )
    assert either.check(zero, zero) is WindowStatus.CONVERGED
    assert either.check({"force": OLD}, {"force": NEW}) is WindowStatus.ITERATE


def test_divergence_of_explicit_iteration_is_reported():
    # H(x) = diag(-3, 1/2) x + (1, 1), x^0 = 0, plain iteration x^{k+1} = x~^k (omega = 1):
    # r^k = H(x^k) - x^k = A^k r^0 has components (-3)^k and (1/2)^k; iteration i sees r^(i-1).
    # ||r^0|| = sqrt(2) is the reference; ||r^k|| first exceeds 1e6 sqrt(2) = 1.41e6 at
    # k = 13 (3^13 = 1.59e6, 3^12 = 5.3e5): iteration 14.
    a, b = np.diag([-3.0, 0.5]), np.ones(2)
    explicit = make_acceleration("constant", relaxation=1.0)
    explicit.initialize({"force": np.zeros(2)})
    criteria = ConvergenceCriteria({"force": [RelativeMeasure(tolerance=1e-6)]}, max_iterations=50)
    criteria.new_window(7)
    x = {"force": np.zeros(2)}
    with pytest.raises(CouplingDivergenceError) as caught:
        while True:
            xt = {"force": a @ x["force"] + b}
            assert not criteria.check(x, xt).done
            x = explicit.perform(x, xt)
    error = caught.value
    assert (error.field, error.window, error.iteration) == ("force", 7, 14)
    assert "field 'force', window 7, iteration 14" in str(error) and "grew beyond" in str(error)


def test_non_finite_data_are_reported_even_without_measures():
    explicit = ConvergenceCriteria({}, max_iterations=1)  # explicit coupling: one solve
    assert explicit.check({"force": OLD}, {"force": NEW}) is WindowStatus.CONVERGED
    explicit.new_window(3)
    with pytest.raises(CouplingDivergenceError, match=r"'force', window 3, iteration 1: non-fin"):
        explicit.check({"force": OLD}, {"force": np.array([1.0, np.nan])})
    with pytest.raises(CouplingDivergenceError, match="inf"):
        explicit.check({"force": np.array([np.inf, 0.0])}, {"force": NEW})


# Predictors: values 1 + t + t^2 at window ends t = 0, 1, 2 are 1, 3, 7; at t = 3 the exact
# value is 13. Lagrange extrapolation: constant 7; linear 2*7 - 3 = 11; quadratic
# 3*7 - 3*3 + 1 = 13.
@pytest.mark.parametrize(
    ("order", "expected"), [("constant", 7), ("linear", 11), ("quadratic", 13)]
)
def test_predictors_on_a_quadratic_history(order, expected):
    p = Predictor(order)
    for t in (0.0, 1.0, 2.0):
        p.record(t, {"force": np.full((2, 3), 1 + t + t * t)})
    predicted = p.predict(3.0)["force"]
    assert predicted.shape == (2, 3)
    np.testing.assert_allclose(predicted, expected, rtol=1e-14)


def test_predictors_fall_back_with_a_short_history_and_handle_uneven_windows():
    p = Predictor("quadratic")
    p.record(0.0, {"f": np.array([1.0])})
    assert p.predict(1.0)["f"] == pytest.approx([1.0])  # one value: constant
    p.record(0.5, {"f": np.array([1.75])})  # 1 + t + t^2 at t = 0.5
    assert p.predict(1.0)["f"] == pytest.approx([2.5])  # two values: line through them
    p.record(2.0, {"f": np.array([7.0])})
    assert p.predict(3.0)["f"] == pytest.approx([13.0], rel=1e-14)  # exact for a quadratic
    np.testing.assert_allclose(lagrange_weights([0, 1, 2], 3), [1, -3, 3])


def test_predictor_state_round_trip_and_checks():
    p = Predictor("linear")
    p.record(0.0, {"f": np.array([1.0, 2.0])})
    p.record(0.1, {"f": np.array([2.0, 2.0])})
    q = Predictor("linear")
    q.load_state(p.save_state())
    np.testing.assert_array_equal(q.predict(0.2)["f"], p.predict(0.2)["f"])
    np.testing.assert_allclose(q.predict(0.2)["f"], [3.0, 2.0])
    with pytest.raises(ValueError, match="must increase"):
        p.record(0.1, {"f": np.zeros(2)})
    with pytest.raises(ValueError, match="extrapolation must be one of"):
        Predictor("cubic")


# Periodic predictor: on a periodic history with harmonics a polynomial in time misses by
# ~(w dt)^3 (quadratic), one period back is exact; on a growing orbit the period-to-period
# change extrapolated linearly is exact for an amplitude linear in time.
def _orbit_history(p: Predictor, x, windows: int, dt: float) -> None:
    for k in range(windows):
        p.record(k * dt, {"f": x(k * dt)})


def test_periodic_predictor_is_exact_on_a_periodic_orbit_after_one_period():
    period, n = 1 / 3, 40
    dt, w = period / n, 2 * np.pi * 3

    def x(t):
        return np.array([np.sin(w * t) + 0.3 * np.sin(3 * w * t), 0.1 + np.cos(w * t)])

    p = Predictor("periodic", period=period)
    _orbit_history(p, x, 10, dt)
    assert p.rule in ("linear", "quadratic")  # less than a period recorded: the better one
    q = Predictor(p.rule)
    _orbit_history(q, x, 10, dt)
    np.testing.assert_array_equal(p.predict(10 * dt)["f"], q.predict(10 * dt)["f"])
    p, q = Predictor("periodic", period=period), Predictor("quadratic")
    _orbit_history(p, x, n + 5, dt)
    _orbit_history(q, x, n + 5, dt)
    t = (n + 5) * dt
    scale = np.linalg.norm(x(t))
    assert np.linalg.norm(q.predict(t)["f"] - x(t)) / scale > 1e-3
    assert p.rule in ("period", "period-linear")
    np.testing.assert_allclose(p.predict(t)["f"], x(t), atol=1e-12)


def test_periodic_predictor_follows_a_growing_orbit_with_the_linear_period_change():
    period, n = 1.0, 20
    dt, w, growth = period / n, 2 * np.pi, 0.05

    def x(t):
        return np.array([(1 + growth * t) * np.sin(w * t)])

    p = Predictor("periodic", period=period)
    _orbit_history(p, x, 3 * n + 5, dt)
    t = (3 * n + 5) * dt
    assert p.rule == "period-linear"
    # d(t) = x(t) - x(t - T) = growth T sin(w t): linear in t only to O((w dt)^2)
    miss = abs(p.predict(t)["f"][0] - x(t)[0])
    assert miss < growth * period * (w * dt) ** 2
    state = p.save_state()
    q = Predictor("periodic", period=period)
    q.load_state(state)
    assert q.rule == p.rule
    np.testing.assert_array_equal(q.predict(t)["f"], p.predict(t)["f"])
    with pytest.raises(ValueError, match="needs the driving period"):
        Predictor("periodic")


def test_predictor_rules_change_mid_run_and_keep_their_scores():
    """An implicit run with an explicit start-up switches from EXPLICIT_RULES to
    PERIODIC_RULES: every rule was scored all along, so the first iterated window already
    chooses the period rule, exact on a periodic orbit."""
    period, n = 1 / 3, 40
    dt, w = period / n, 2 * np.pi * 3

    def x(t):
        return np.array([np.sin(w * t) + 0.3 * np.sin(3 * w * t)])

    p = Predictor("periodic", period=period, rules=EXPLICIT_RULES)
    _orbit_history(p, x, 5, dt)
    assert p.rule == "constant"  # no period yet: the lowest order of the explicit rules
    _orbit_history_from(p, x, 5, n + 5, dt)
    assert p.rule == "period-smooth"
    p.use_rules(PERIODIC_RULES)
    assert p.rule in ("period", "period-linear") and np.isfinite(p.rule_errors).all()
    t = (n + 5) * dt
    np.testing.assert_allclose(p.predict(t)["f"], x(t), atol=1e-12)
    with pytest.raises(ValueError, match="unknown predictor rules"):
        p.use_rules(("cubic",))


def _orbit_history_from(p: Predictor, x, first: int, last: int, dt: float) -> None:
    for k in range(first, last):
        p.record(k * dt, {"f": x(k * dt)})


def test_the_explicit_period_rule_does_not_feed_back_last_periods_window_to_window_wobble():
    """One solve per window feeds the prediction straight into the structure. The plain period
    rule x_n + x_m - x_{m-1} (t_m = t - T) copies a window-to-window (Nyquist) wobble of the
    last period into this one at twice its size; with OpenFOAM such bursts came back at the
    same phase every period (docs/coupling.md). The smoothed rule drops it and misses a clean
    orbit by (w dt)^4 / 16 of each harmonic's step."""
    period, n = 1 / 3, 40
    dt, w, eps = period / n, 2 * np.pi * 3, 0.05

    def x(t):
        return np.array([np.sin(w * t) + 0.3 * np.sin(3 * w * t)])

    def wobbly(k):  # the last period wobbles around window 10, the one predicted is window 50
        return x(k * dt) + (eps * (-1) ** k if 6 <= k <= 14 else 0.0)

    def predictor(rule):
        p = Predictor("periodic", period=period, rules=(rule,))
        for k in range(n + 10):
            p.record(k * dt, {"f": wobbly(k)})
        return p

    t = (n + 10) * dt
    plain, smooth = (predictor(r).predict(t)["f"][0] - x(t)[0] for r in ("period", "period-smooth"))
    assert abs(abs(plain) - 2 * eps) < 1e-12

    # a harmonic a sin(h w t) steps by 2 a sin(h w dt / 2) per window; the filter
    # [-1, 4, 10, 4, -1] / 16 keeps H = (10 + 8 cos(h w dt) - 2 cos(2 h w dt)) / 16 of it
    def lost(theta):
        return 1 - (10 + 8 * np.cos(theta) - 2 * np.cos(2 * theta)) / 16

    bound = sum(a * 2 * np.sin(h * w * dt / 2) * lost(h * w * dt) for a, h in ((1.0, 1), (0.3, 3)))
    assert 0 < abs(smooth) <= bound
    # on the clean orbit as well
    p = Predictor("periodic", period=period, rules=EXPLICIT_RULES)
    _orbit_history(p, x, n + 10, dt)
    assert p.rule == "period-smooth"
    assert abs(p.predict(t)["f"][0] - x(t)[0]) <= bound < 1e-3
    # a checkpoint written before the rule existed (five rule scores) still loads
    state = p.save_state()
    state["predictor_all_rule_errors"] = state["predictor_all_rule_errors"][:5]
    q = Predictor("periodic", period=period, rules=EXPLICIT_RULES)
    q.load_state(state)
    assert q.rule == "constant"  # the new rule is scored from the next recorded window
