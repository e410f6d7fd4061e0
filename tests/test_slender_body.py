"""Slender-body thrust (seed eqs. 5-1..5-12) against closed forms derived by hand.

The closed forms follow from eq. 5-12 (module docstring of fluid_adapter/slender_body.py) for
motions whose integrals can be done by hand; the constant-height mean thrust is Lighthill's
(1960, J. Fluid Mech. 9, 305-317): <T> = A(L)/2 <h_t^2 - V^2 h_x^2> at the tail.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import i1

from fluid_adapter.slender_body import (
    added_mass_per_length,
    mean_thrust_from_shell,
    slender_body_thrust,
)

LENGTH_M = 0.167  # original fish (docs/geometry.md)
RHO = 1820.0  # FC-3283, kg/m3 (issue 5)
H0 = 0.02  # tail amplitude, m (seed: about 20 mm at 3 Hz, Sec. 3.4.3)
OMEGA = 2 * np.pi * 3.0
PERIOD = 2 * np.pi / OMEGA


def sample_times(n_per_period, periods=1):
    return np.arange(n_per_period * periods) * PERIOD / n_per_period


def thrust(x, b, h, n_per_period, **kw):
    return slender_body_thrust(x, b, h, PERIOD / n_per_period, density_kg_m3=RHO, **kw)


def notch(x, a=0.14, b1=0.0275, b2=0.01, b3=0.025):
    """Half-height falling linearly from b1 (nose) to b2 at x = a, then a fin growing to b3."""
    return np.where(x <= a, b1 + (b2 - b1) * x / a, b2 + (b3 - b2) * (x - a) / (LENGTH_M - a))


def test_quadratic_amplitude_constant_height_matches_closed_form():
    """h = h0 (x/L)^2 sin(wt), constant b, V = 0. By hand: int A w h_x dx = A h0^2 w sin(2wt)/4,
    so T(t) = -A h0^2 w^2 cos(2wt)/2 + A h0^2 w^2 cos^2(wt)/2 = A h0^2 w^2 sin^2(wt)/2 and
    <T> = A h0^2 w^2 / 4."""
    x = np.linspace(0.0, LENGTH_M, 101)
    b = np.full_like(x, 0.025)
    t = sample_times(32)
    h = H0 * (x / LENGTH_M) ** 2 * np.sin(OMEGA * t)[:, None]
    history = thrust(x, b, h, 32)
    area = RHO * np.pi * 0.025**2
    amplitude = area * H0**2 * OMEGA**2 / 2
    assert history.mean_thrust_n == pytest.approx(amplitude / 2, rel=1e-2)
    assert np.abs(history.thrust_n - amplitude * np.sin(OMEGA * t) ** 2).max() < 1e-3 * amplitude


def test_rigid_heave_with_notch_at_fixed_head():
    """h = h0 sin(wt), h_x = 0, V = 0: the shrinking part gives <w^2>/2 (A(0) - A(a)), the trailing
    edge <w^2>/2 A(L), the fin nothing (w* = 0): <T> = h0^2 w^2 (A0 - Aa + AL) / 4."""
    x = np.linspace(0.0, LENGTH_M, 201)
    b = notch(x)
    h = H0 * np.sin(OMEGA * sample_times(16))[:, None] * np.ones_like(x)
    a0, aa, al = added_mass_per_length([0.0275, 0.01, 0.025], RHO)
    expected = H0**2 * OMEGA**2 * (a0 - aa + al) / 4
    history = thrust(x, b, h, 16)
    assert history.mean_thrust_n == pytest.approx(expected, rel=1e-2)
    assert np.all(history.wake_n == 0.0)


def test_rigid_heave_with_notch_and_forward_speed_includes_the_wake_term():
    """As above with V > 0: w* = w(t - tau(x)) with tau = (x - x*)/V, so the fin adds
    int (<w*^2>/2 - <w w*>) A' dx = h0^2 w^2 / 4 int (1 - 2 cos(w tau)) A' dx."""
    speed, a, b1, b2, b3 = 0.2, 0.14, 0.0275, 0.01, 0.025
    x = np.linspace(0.0, LENGTH_M, 1001)
    h = H0 * np.sin(OMEGA * sample_times(16))[:, None] * np.ones_like(x)
    gain = RHO * np.pi * H0**2 * OMEGA**2 / 4

    def fin_integrand(s):
        bs = b2 + (b3 - b2) * (s - a) / (LENGTH_M - a)
        x_star = a * (b1 - bs) / (b1 - b2)
        slope = 2 * bs * (b3 - b2) / (LENGTH_M - a)  # d(b^2)/dx
        return (1 - 2 * np.cos(OMEGA * (s - x_star) / speed)) * slope

    fin, _ = quad(fin_integrand, a, LENGTH_M, limit=200)
    expected = gain * (b1**2 - b2**2 + b3**2 + fin)
    history = thrust(x, notch(x), h, 16, speed_m_s=speed)
    assert history.mean_thrust_n == pytest.approx(expected, rel=1e-2)
    assert np.mean(history.wake_n) == pytest.approx(gain * fin, rel=1e-2)


def test_zero_amplitude_gives_zero_thrust():
    x = np.linspace(0.0, LENGTH_M, 21)
    history = thrust(x, notch(x), np.zeros((8, 21)), 8, speed_m_s=0.1)
    assert np.all(history.thrust_n == 0.0)


def smooth_motion(x, t):
    """A periodic tail-ward wave with growing amplitude and a third harmonic."""
    phase = OMEGA * t[:, None] - 4.0 * x / LENGTH_M
    envelope = H0 * (0.1 + (x / LENGTH_M) ** 2)
    return envelope * (np.sin(phase) + 0.2 * np.cos(3 * phase))


def test_sign_flip_and_time_reversal_leave_thrust_unchanged():
    """T is quadratic in h; at V = 0 every term is even under t -> -t, so the reversed motion
    has the reversed history T(-t)."""
    x = np.linspace(0.0, LENGTH_M, 81)
    t = sample_times(24)
    h = smooth_motion(x, t)
    forward = thrust(x, notch(x), h, 24)
    flipped = thrust(x, notch(x), -h, 24)
    reversed_ = thrust(x, notch(x), h[(-np.arange(24)) % 24], 24)
    scale = np.abs(forward.thrust_n).max()
    assert np.abs(flipped.thrust_n - forward.thrust_n).max() < 1e-12 * scale
    reordered = reversed_.thrust_n[(-np.arange(24)) % 24]
    assert np.abs(reordered - forward.thrust_n).max() < 1e-12 * scale
    assert forward.mean_thrust_n > 0  # V = 0: all mean terms are >= 0, pushing toward the head


@pytest.mark.parametrize("direction", [+1, -1])
def test_travelling_wave_thrust_changes_sign_at_the_wave_speed(direction):
    """h = a(x) sin(wt - s k x), s = +1 tail-ward, -1 head-ward, constant b. Lighthill's mean thrust
    A/4 [a^2 w^2 - V^2 (a'^2 + a^2 k^2)] at the tail depends on k^2 only: positive below the
    wave speed, negative above it, for either direction."""
    k = 2 * np.pi / LENGTH_M
    x = np.linspace(0.0, LENGTH_M, 401)
    t = sample_times(16)
    envelope = H0 * (0.2 + 0.8 * (x / LENGTH_M) ** 2)
    h = envelope * np.sin(OMEGA * t[:, None] - direction * k * x)
    b = np.full_like(x, 0.025)
    area = RHO * np.pi * 0.025**2
    slope = 1.6 * H0 / LENGTH_M  # a'(L)
    for speed in (0.5 * OMEGA / k, 1.5 * OMEGA / k):
        expected = area / 4 * (H0**2 * OMEGA**2 - speed**2 * (slope**2 + H0**2 * k**2))
        history = thrust(x, b, h, 16, speed_m_s=speed)
        assert history.mean_thrust_n == pytest.approx(expected, rel=1e-2)
        assert np.sign(history.mean_thrust_n) == (1 if speed < OMEGA / k else -1)


def test_convergence_with_time_samples():
    """h = h0 (x/L)^2 exp(beta cos wt): by hand <h_t(L)^2> = beta w^2 h0^2 I1(2 beta)/2 (from
    int_0^2pi sin^2 e^(a cos) = 2 pi I1(a)/a), <T> = A beta w^2 h0^2 I1(2 beta)/4. The motion is
    not band-limited; the spectral evaluation converges exponentially with samples per period."""
    beta = 1.0
    x = np.linspace(0.0, LENGTH_M, 41)
    b = np.full_like(x, 0.025)
    area = RHO * np.pi * 0.025**2
    expected = area * beta * OMEGA**2 * H0**2 * i1(2 * beta) / 4
    errors = []
    for n in (4, 8, 16, 32):
        t = sample_times(n)
        h = H0 * (x / LENGTH_M) ** 2 * np.exp(beta * np.cos(OMEGA * t))[:, None]
        errors.append(abs(thrust(x, b, h, n).mean_thrust_n / expected - 1))
    print(f"relative error of <T> for 4, 8, 16, 32 samples per period: {np.array(errors)}")
    assert errors[1] < 1e-2 and errors[3] < 1e-12
    assert np.all(np.diff(errors[:3]) < 0)


def test_shell_convenience_uses_the_last_whole_periods():
    """Shell output holds both ends of each period (41 samples per 40 steps): the last 40 are
    one period; the rest of the history (a transient here) is ignored."""
    x = np.linspace(0.0, LENGTH_M, 33)
    b = notch(x)
    t = np.arange(2 * 40 + 1) * PERIOD / 40
    h = smooth_motion(x, t)
    h[:40] *= 3.0  # a start-up transient before the last period
    mean = mean_thrust_from_shell(x, b, t, h, density_kg_m3=RHO, period_s=PERIOD)
    reference = thrust(x, b, smooth_motion(x, sample_times(40)), 40).mean_thrust_n
    assert mean == pytest.approx(reference, rel=1e-12)


def test_shell_convenience_with_tail_tip_only():
    t = np.arange(3 * 20 + 1) * PERIOD / 20
    tip = H0 * np.sin(OMEGA * t)
    x = np.linspace(0.0, LENGTH_M, 5)
    b = np.full_like(x, 0.025)
    mean = mean_thrust_from_shell(x, b, t, tip, density_kg_m3=RHO, period_s=PERIOD, periods=3)
    assert mean == pytest.approx(RHO * np.pi * 0.025**2 * H0**2 * OMEGA**2 / 4, rel=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"period_s": PERIOD * 1.013}, "must divide"),
        ({"period_s": PERIOD, "periods": 5}, "periods"),
        ({"period_s": PERIOD, "speed_m_s": -1.0}, "speed_m_s"),
        ({"period_s": PERIOD, "density_kg_m3": 0.0}, "density_kg_m3"),
    ],
)
def test_bad_inputs_name_the_problem(kwargs, match):
    x = np.linspace(0.0, LENGTH_M, 5)
    t = np.arange(21) * PERIOD / 20
    h = np.zeros((21, 5))
    args = {"density_kg_m3": RHO} | kwargs
    with pytest.raises(ValueError, match=match):
        mean_thrust_from_shell(x, np.full(5, 0.02), t, h, **args)


def test_inputs_are_not_changed():
    x = np.linspace(0.0, LENGTH_M, 21)
    b = notch(x)
    h = smooth_motion(x, sample_times(8))
    copies = x.copy(), b.copy(), h.copy()
    thrust(x, b, h, 8, speed_m_s=0.3)
    assert all(np.array_equal(a, c) for a, c in zip((x, b, h), copies, strict=True))
