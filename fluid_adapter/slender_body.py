"""Thrust of the fish from Lighthill's elongated-body theory (seed Section 5.1, eqs. 5-1..5-12).

Frame: x along the body from the nose (x = 0) to the tail (x = L), h(x, t) the lateral
displacement of the midline (the shell's z displacement at y = 0), b(x) the local half-height of
the plate. The fish swims toward -x at speed V (V = 0: fixed head); the thrust T is positive when
it pushes the fish toward its head, i.e. along -x, as in the seed.

Added mass per length and lateral velocity relative to the water (eqs. 5-3, 5-4), SI units:

    A(x) = rho pi b(x)^2 gamma   [kg/m],      w(x, t) = dh/dt + V dh/dx   [m/s].

Lift per length l = -D(A w)/Dt with D/Dt = d/dt + V d/dx (5-1, 5-9), plus w* DA/Dt on fin
sections that meet the vortex sheet shed upstream (5-2); thrust T = int l dh/dx dx + T_s with the
leading-edge suction T_s of the sections whose height grows (5-10, 5-11). Integrating
int -D(A w)/Dt h_x dx by parts gives -d/dt int A w h_x dx + [A (w^2/2 - V w h_x)] - int w^2/2 A' dx.
Section by section:

- growing height, clean leading edge (head; fin parts higher than anything upstream): the suction
  int w^2/2 A' cancels the last term;
- shrinking height (A' < 0, vorticity shed): no suction; eq. 5-12 keeps -(w^2/2 - V w h_x) A'
  (the shed layer takes its momentum A w along, lift -A Dw/Dt); a sharp trailing edge is the limit
  of such a section and gives the trailing-edge term below;
- fin in the wake of a shrinking section (A' > 0 and the body was higher upstream): suction with
  the velocity relative to the sheet, (w - w*)^2 / 2 A', and lift w* V A' (5-2, 5-11);
- a blunt nose (A(0) > 0) is a sharp growth with full suction (eq. 5-5 takes A(nose) = 0): its
  terms cancel, no nose term.

Result, eq. 5-12 in this frame (what :func:`slender_body_thrust` evaluates):

    T(t) = - d/dt int_0^L A w h_x dx                                  unsteady (zero mean)
           + A(L) (w^2/2 - V w h_x)|_{x=L}                             trailing edge
           - int_{A'<0} (w^2/2 - V w h_x) A' dx                        shrinking sections
           + int_{A'>0} ((w - w*)^2/2 - w^2/2 + V w* h_x) A' dx        fin in the wake

w*(x, t) = w(x*, t - (x - x*)/V) (5-7, 5-8): the sheet met by the fin's leading edge at height
b(x) was shed at x*, the last point upstream where the body's half-height fell through b(x); the
fin term vanishes where no sheet exists (w* = 0).

Fixed head (V = 0): w = dh/dt and the sheet is not convected (t* of eq. 5-8 is undefined), so the
fin's leading edge sees undisturbed water like the head: w* = 0 and the fin term vanishes. Over
whole periods the unsteady term has zero mean, leaving

    <T> = A(L) <h_t(L)^2> / 2  -  1/2 int_{A'<0} <h_t^2> A' dx   (both terms >= 0).

For a constant height this is Lighthill's (1960, J. Fluid Mech. 9, 305) reactive thrust. At V = 0
the theory's assumption |dh/dt| << V (5-6) does not hold: read it as the V -> 0 reactive estimate.

Vortex shedding at small amplitude (``shedding_kc``): the reactive thrust assumes the vorticity
shed at the trailing edge leaves it. At small Keulegan-Carpenter numbers KC = 2 pi a / h_L (a the
trailing edge's amplitude, h_L its height) the shed vortices stay at the edge, and OpenFOAM's
thrust on the held fish's own motion is 0.43-0.86 of Lighthill's, growing with KC (1-25 Hz, two
mesh levels). :func:`mean_thrust_from_shell` with ``shedding_kc`` = KC0 weighs each harmonic's
share of the mean thrust (over whole periods the shares add up exactly: the thrust is quadratic
in h and harmonics are orthogonal) by KC / (KC + KC0) on that harmonic's own KC; KC0 is fitted
to OpenFOAM (SHEDDING_KC, benchmarks/fast_thrust_shedding.py). A square wave's higher harmonics
move the fin fast with little amplitude: small KC, little thrust.

Discretisation: samples at t0 + k dt, k = 0..n-1, spanning whole periods (the motion is periodic
with period n dt); time derivatives and the time shift of w* are spectral (exact for band-limited
motion), h_x is second order on the possibly non-uniform x grid, int dx is the trapezoidal rule,
int f dA sums interval means of f times the jump of A on each interval (exact at kinks and jumps
of the outline).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import trapezoid

# KC0 of the shedding efficiency KC / (KC + KC0): fitted to OpenFOAM's thrust on the held fish's
# own sine motion, 1-25 Hz, coarse and default levels (benchmarks/fast_thrust_shedding.py)
SHEDDING_KC = 0.61


def shedding_efficiency(kc: ArrayLike, kc0: float) -> NDArray:
    """The share KC / (KC + KC0) of the reactive thrust that a motion of Keulegan-Carpenter
    number KC makes (1 for KC0 = 0: Lighthill's thrust as it is)."""
    kc = np.asarray(kc, dtype=float)
    if kc0 == 0.0:
        return np.ones_like(kc)
    return kc / (kc + kc0)


@dataclass(frozen=True, kw_only=True)
class ThrustHistory:
    """Instantaneous thrust (N, + toward the head) and its parts at the sample times."""

    times_s: NDArray  # (n,)
    thrust_n: NDArray  # (n,) total
    unsteady_n: NDArray  # -d/dt int A w h_x dx
    trailing_edge_n: NDArray  # A(L) (w^2/2 - V w h_x) at x = L
    shrinking_n: NDArray  # -int_{A'<0} (w^2/2 - V w h_x) A' dx
    wake_n: NDArray  # fin sections meeting the shed sheet (0 for V = 0)

    @property
    def mean_thrust_n(self) -> float:
        """Mean over the sampled whole periods."""
        return float(np.mean(self.thrust_n))


def added_mass_per_length(
    half_height_m: ArrayLike, density_kg_m3: float, added_mass_coefficient: float = 1.0
) -> NDArray:
    """A33 = rho pi b^2 gamma (eq. 5-3), kg/m."""
    b = np.asarray(half_height_m, dtype=float)
    return density_kg_m3 * np.pi * b**2 * added_mass_coefficient


def slender_body_thrust(
    x_m: ArrayLike,
    half_height_m: ArrayLike,
    h_m: ArrayLike,
    dt_s: float,
    *,
    density_kg_m3: float,
    added_mass_coefficient: float = 1.0,
    speed_m_s: float = 0.0,
    t0_s: float = 0.0,
) -> ThrustHistory:
    """Thrust history from midline samples ``h_m`` (n_t, n_x) m at times t0 + k dt over whole
    periods, on the grid ``x_m`` (n_x,) from nose to tail with half-heights ``half_height_m``."""
    x, b, h = _check_inputs(x_m, half_height_m, h_m, dt_s, speed_m_s)
    _check_positive("density_kg_m3", density_kg_m3)
    _check_positive("added_mass_coefficient", added_mass_coefficient)
    v = float(speed_m_s)
    area = added_mass_per_length(b, density_kg_m3, added_mass_coefficient)
    h_x = np.gradient(h, x, axis=1, edge_order=2)
    w = periodic_derivative(h, dt_s) + v * h_x
    w_star = _sheet_velocity(x, b, w, dt_s, v)
    shed = w**2 / 2 - v * w * h_x
    unsteady = -periodic_derivative(trapezoid(area * w * h_x, x, axis=1), dt_s)
    trailing = area[-1] * shed[:, -1]
    shrinking = -_stieltjes(shed, area, np.diff(area) < 0)
    wake_integrand = (w - w_star) ** 2 / 2 - w**2 / 2 + v * w_star * h_x
    wake = _stieltjes(wake_integrand, area, np.diff(area) > 0)  # zero where w* = 0
    return ThrustHistory(
        times_s=t0_s + dt_s * np.arange(len(h)),
        thrust_n=unsteady + trailing + shrinking + wake,
        unsteady_n=unsteady,
        trailing_edge_n=trailing,
        shrinking_n=shrinking,
        wake_n=wake,
    )


def mean_thrust_from_shell(
    xs: ArrayLike,
    half_height: ArrayLike,
    times: ArrayLike,
    tip_or_midline_displacements: ArrayLike,
    *,
    density_kg_m3: float,
    period_s: float,
    periods: int = 1,
    added_mass_coefficient: float = 1.0,
    speed_m_s: float = 0.0,
    shedding_kc: float = 0.0,
) -> float:
    """Mean thrust (N, + toward the head) over the last ``periods`` periods of shell output;
    ``shedding_kc``: KC0 of the shedding efficiency (0: Lighthill's thrust as it is).

    ``times`` (m,) s uniformly spaced, the step dividing ``period_s``; the displacements are
    either the midline z displacements (m, n_x) at nodes ``xs`` (n_x,) m (nodes at y = 0, nose to
    tail), or the tail-tip history (m,) alone, which gives only the trailing-edge term
    A(L) <h_t^2>/2 (V = 0 only; a lower bound at V = 0, the other terms being >= 0).
    """
    t = np.asarray(times, dtype=float)
    disp = np.asarray(tip_or_midline_displacements, dtype=float)
    if disp.ndim not in (1, 2) or disp.shape[0] != len(t):
        raise ValueError(
            f"`tip_or_midline_displacements` must have shape ({len(t)},) or ({len(t)}, n_x) "
            f"to match `times`, got {disp.shape}"
        )
    dt, n_keep = _last_periods(t, period_s, periods)
    window = disp[-n_keep:]
    if shedding_kc < 0 or not np.isfinite(shedding_kc):
        raise ValueError(f"`shedding_kc` must be finite and >= 0, got {shedding_kc}")
    if disp.ndim == 2:

        def mean(h: NDArray) -> float:
            return slender_body_thrust(
                xs,
                half_height,
                h,
                dt,
                density_kg_m3=density_kg_m3,
                added_mass_coefficient=added_mass_coefficient,
                speed_m_s=speed_m_s,
            ).mean_thrust_n

        if shedding_kc == 0.0:
            return mean(window)
        tail_height = 2 * float(np.asarray(half_height, dtype=float)[-1])
        return sum(
            share * mean(h) for share, h in _shed_harmonics(window, tail_height, shedding_kc)
        )
    if speed_m_s != 0.0:
        raise ValueError("a tail-tip history alone needs `speed_m_s` = 0; pass the midline")
    b_tail = float(np.asarray(half_height, dtype=float)[-1])
    tail_area = added_mass_per_length(b_tail, density_kg_m3, added_mass_coefficient)
    return float(
        sum(
            share * tail_area * np.mean(periodic_derivative(h, dt) ** 2) / 2
            for share, h in _shed_harmonics(window, 2 * b_tail, shedding_kc)
        )
    )


def _shed_harmonics(h: NDArray, tail_height_m: float, kc0: float):
    """(shedding efficiency, samples) of each Fourier component of ``h`` (samples over whole
    periods along axis 0; the last column, or a 1-D history, is the trailing edge): the mean
    (weight 1) and every frequency with motion, on its own trailing-edge KC."""
    if not tail_height_m > 0:
        raise ValueError(f"the trailing edge's height must be > 0, got {tail_height_m}")
    n = h.shape[0]
    spectrum = np.fft.rfft(h, axis=0)
    tail = spectrum if h.ndim == 1 else spectrum[:, -1]
    size = np.abs(spectrum).reshape(len(spectrum), -1).max(axis=1)
    for j in range(len(spectrum)):
        if j and size[j] <= 1e-9 * size[1:].max(initial=0.0):  # roundoff: no motion there
            continue
        one = np.zeros_like(spectrum)
        one[j] = spectrum[j]
        # a component's amplitude: 2 |F_j| / n (the Nyquist bin and the mean |F_j| / n)
        amplitude = abs(tail[j]) / n * (1 if j == 0 or 2 * j == n else 2)
        share = (
            1.0
            if j == 0
            else float(shedding_efficiency(2 * np.pi * amplitude / tail_height_m, kc0))
        )
        yield share, np.fft.irfft(one, n, axis=0)


def periodic_derivative(f: ArrayLike, dt_s: float) -> NDArray:
    """d/dt along axis 0 of samples over whole periods (period n dt), by FFT."""
    f = np.asarray(f, dtype=float)
    n = f.shape[0]
    omega = 2 * np.pi * np.fft.rfftfreq(n, dt_s)
    spectrum = np.fft.rfft(f, axis=0) * _along_axis0(1j * omega, f.ndim)
    if n % 2 == 0:
        spectrum[-1] = 0.0  # the Nyquist mode has no defined derivative
    return np.fft.irfft(spectrum, n, axis=0)


def _along_axis0(v: NDArray, ndim: int) -> NDArray:
    return v.reshape((-1,) + (1,) * (ndim - 1))


def _stieltjes(f: NDArray, area: NDArray, intervals: NDArray) -> NDArray:
    """sum over the selected intervals of (mean of f at its ends) * (jump of A), per time."""
    f_mid = (f[:, 1:] + f[:, :-1]) / 2
    return (f_mid * np.where(intervals, np.diff(area), 0.0)).sum(axis=1)


def _sheet_velocity(x: NDArray, b: NDArray, w: NDArray, dt_s: float, v: float) -> NDArray:
    """w*(x, t) = w(x*, t - (x - x*)/V) where a shed sheet exists; 0 elsewhere and for V = 0."""
    w_star = np.zeros_like(w)
    if v == 0.0:
        return w_star
    for i, (x_star, j, frac) in _shedding_points(x, b).items():
        w_shed = (1 - frac) * w[:, j] + frac * w[:, j + 1]
        w_star[:, i] = _periodic_shift(w_shed, (x[i] - x_star) / v, dt_s)
    return w_star


def _shedding_points(x: NDArray, b: NDArray) -> dict[int, tuple[float, int, float]]:
    """For node i: the last point x* upstream where the half-height fell through b_i, as
    (x*, interval j, fraction in [x_j, x_j+1]); nodes with nothing higher upstream are left out."""
    points = {}
    for i in range(1, len(x)):
        higher = np.flatnonzero(b[:i] > b[i])
        if len(higher):
            j = int(higher[-1])  # b_j > b_i >= b_j+1
            frac = (b[j] - b[i]) / (b[j] - b[j + 1])
            points[i] = (x[j] + frac * (x[j + 1] - x[j]), j, frac)
    return points


def _periodic_shift(f: NDArray, delay_s: float, dt_s: float) -> NDArray:
    """f(t - delay) of periodic samples (period n dt), by FFT."""
    omega = 2 * np.pi * np.fft.rfftfreq(len(f), dt_s)
    return np.fft.irfft(np.fft.rfft(f) * np.exp(-1j * omega * delay_s), len(f))


def _last_periods(t: NDArray, period_s: float, periods: int) -> tuple[float, int]:
    """Time step and number of trailing samples covering ``periods`` whole periods."""
    _check_positive("period_s", period_s)
    if t.ndim != 1 or len(t) < 2:
        raise ValueError(f"`times` must be a 1-D array of at least 2 samples, got {t.shape}")
    steps = np.diff(t)
    dt = float(steps.mean())
    if not (dt > 0 and np.ptp(steps) <= 1e-6 * dt):
        raise ValueError("`times` must be increasing with a uniform step")
    per_period = period_s / dt
    if abs(per_period - round(per_period)) > 1e-6 * per_period:
        raise ValueError(
            f"the time step {dt:g} s must divide `period_s` = {period_s:g} s "
            f"({per_period:.4f} steps per period)"
        )
    n_keep = periods * round(per_period)
    if periods < 1 or n_keep > len(t):
        raise ValueError(
            f"`periods` = {periods} needs {n_keep} samples, `times` has {len(t)}; "
            "pass fewer periods or a longer history"
        )
    return dt, n_keep


def _check_positive(name: str, value: float) -> None:
    if not value > 0:
        raise ValueError(f"`{name}` must be > 0, got {value}")


def _check_inputs(
    x_m: ArrayLike, half_height_m: ArrayLike, h_m: ArrayLike, dt_s: float, speed_m_s: float
) -> tuple[NDArray, NDArray, NDArray]:
    x = np.asarray(x_m, dtype=float)
    b = np.asarray(half_height_m, dtype=float)
    h = np.asarray(h_m, dtype=float)
    if x.ndim != 1 or len(x) < 3 or not np.all(np.diff(x) > 0):
        raise ValueError("`x_m` must be at least 3 increasing positions from nose to tail")
    if b.shape != x.shape or np.any(b < 0):
        raise ValueError(f"`half_height_m` must be {x.shape} values >= 0, got shape {b.shape}")
    if h.ndim != 2 or h.shape[1] != len(x) or h.shape[0] < 4:
        raise ValueError(f"`h_m` must be (n_t >= 4, {len(x)}) samples, got shape {h.shape}")
    _check_positive("dt_s", dt_s)
    if speed_m_s < 0:
        raise ValueError(f"`speed_m_s` must be >= 0 (swimming toward the nose), got {speed_m_s}")
    return x, b, h
