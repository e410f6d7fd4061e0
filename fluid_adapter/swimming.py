"""Free swimming of the fish: self-propelled speed and turning rate (seed Sec. 4.4-4.5, 5.3-5.4).

Frame and midline as in :mod:`fluid_adapter.slender_body`: x from the nose (0) to the tail (L),
the fish swims toward -x at speed V, h(x, t) the lateral (z) displacement of the midline over
whole periods, b(x) the half-height, A = rho pi b^2 gamma (eq. 5-3), w = h_t + V h_x (eq. 5-4).
The motion is the free body's periodic response (its recoil included), either in still liquid
at every speed or, with :class:`SpeedLoads`, the response at the speed itself.

Motion at speed. Beyond the still liquid's added mass A h_tt (in the structure's inertia), the
sections' lateral load l = -D(A w)/Dt (-A Dw/Dt where A' < 0) holds, for a harmonic
h = Re(H e^{i w t}),

    l_V = -i w V (2 A H' + A'_+ H) - V^2 (A H'' + A'_+ H'),   A'_+ = max(A', 0),

a damping that grows with V (the wake's energy: Lighthill 1960's power A V <w h_t>(L) is its
work) and a stiffness that falls as -V^2 (the divergence load of a plate in axial flow).
Projected on the modes' midline shapes phi_j: Q_j = int phi_j l_V dx = -(i w V C + V^2 K) q.
This is the elongated-body load of a flexible plate in axial flow (e.g. Singh, Michelin & de
Langre 2012, Proc. R. Soc. A 468, 3620; Eloy, Kofman & Schouveiler 2012, J. Fluid Mech. 691,
583), on the 3D added mass's structure.

Speed. The mean thrust T(V) is Lighthill's elongated-body thrust at forward speed (eq. 5-12,
:func:`fluid_adapter.slender_body.slender_body_thrust`); it falls with V because the tail's
relative lateral velocity w shrinks. The drag

    D(V) = 1/2 rho V^2 (C_f(Re) S_wet + sum_k C_D,k S_k),   Re = V L / nu,

has the skin friction of the wetted plate (both faces, S_wet) on a flat-plate line and the
form drag of the parts that stand out of the plate (head weight, float; frontal areas S_k,
coefficients from the literature, see the case keys of [swimming]). The self-propelled speed
V* solves T(V*) = D(V*) (scipy.optimize.brentq); T(0) > 0 and D grows as V^2 while T falls,
so the root is unique.

Skin friction lines: ITTC 1957, C_f = 0.075 / (log10 Re - 2)^2 (fully turbulent, the
model-ship correlation line; held at its Re = 1e3 value below that), and Blasius' laminar plate,
C_f = 1.328 / sqrt(Re) (Schlichting, Boundary-Layer Theory, eq. 7.34).

Turning. The lateral force per length of the elongated body (eqs. 5-1, 5-2) is
l = -D(A w)/Dt on growing sections, -A Dw/Dt where vorticity is shed (A' < 0) and
-D(A w)/Dt + w* V A' on fin sections in the shed sheet. Over a period the d/dt parts vanish;
integrated over the body (the blunt nose cancels as for the thrust):

    F = -V A(L) <w>(L) + V int_{A'<0} <w> dA + V int_{fin} <w*> dA - A(L) <w^2 h_x>(L) / 2,
    N = -V (L - x_r) A(L) <w>(L) + V int A <w> dx + V int_{A'<0} (x - x_r) <w> dA
        + V int_{fin} (x - x_r) <w*> dA - (L - x_r) A(L) <w^2 h_x>(L) / 2,

with N = int (x - x_r) l dx the yaw moment about x_r (the centre of mass). The last terms are
the trailing edge's reactive force of Lighthill's large-amplitude theory (1971, Proc. R. Soc. B
179, 125), A (w (u.tau) n - w^2/2 tau) with u.tau = -V for an inextensible tail: its x part is
the thrust above, its z part tilts that thrust with the mean tail angle. A constant-height plate
at incidence a gives F = -rho pi b^2 V^2 a, Jones' slender-wing lift.

An asymmetric drive (one MFC with a larger mean voltage) bends the body on average; the body
then sideslips by the angle beta (a rigid rotation of h, beta (x - x_r)) that makes the mean
side force vanish, and the moment left turns it. Turning at the rate Omega about +y (positive:
to the left, the +z side, seen from above with the nose forward) adds the lateral velocity
-Omega (x - x_r) to w (Munk's yaw damping of the same theory) and the cross-flow drag
-1/2 rho C_D,cross 2 b |w_r| w_r of the plate's sections (w_r = -Omega (x - x_r)). The turning
rate solves N(beta(Omega), Omega) = 0. Left out: the centripetal force m V Omega (1 % of the
side forces here) and the change of the motion with the turn.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import trapezoid
from scipy.optimize import brentq

from .slender_body import (
    _shedding_points,
    _stieltjes,
    added_mass_per_length,
    periodic_derivative,
    slender_body_thrust,
)

SKIN_FRICTION_LINES = ("ittc-1957", "blasius")
ITTC_MIN_REYNOLDS = 1e3  # the ITTC line diverges at Re = 100
MAX_SPEED_M_S = 50.0  # no root below this: the motion or the drag is not physical
MAX_SLIP_RAD = 0.5


class SwimmingError(RuntimeError):
    """No balance: the thrust exceeds any drag, or no yaw damping balances the drive."""


def skin_friction_coefficient(reynolds: float, line: str = "ittc-1957") -> float:
    """Mean skin-friction coefficient of a flat plate at Re = V L / nu."""
    if line not in SKIN_FRICTION_LINES:
        raise ValueError(f"skin friction line must be one of {SKIN_FRICTION_LINES}, got {line!r}")
    if not reynolds > 0:
        raise ValueError(f"the Reynolds number must be > 0, got {reynolds}")
    if line == "blasius":
        return 1.328 / np.sqrt(reynolds)
    return 0.075 / (np.log10(max(reynolds, ITTC_MIN_REYNOLDS)) - 2.0) ** 2


@dataclass(frozen=True, kw_only=True)
class FormDrag:
    """A part standing out of the plate: frontal area (m^2) and drag coefficient."""

    name: str
    frontal_area_m2: float
    drag_coefficient: float


@dataclass(frozen=True, kw_only=True)
class BodyDrag:
    """D(V) = 1/2 rho V^2 (C_f(Re) S_wet + sum C_D S)."""

    density_kg_m3: float
    kinematic_viscosity_m2_s: float
    length_m: float
    wetted_area_m2: float
    skin_friction: str = "ittc-1957"
    form: tuple[FormDrag, ...] = ()

    def parts(self, speed_m_s: float) -> dict[str, float]:
        """Each term of the drag (N) at ``speed_m_s``: skin friction, then the form drags."""
        if speed_m_s == 0:
            return {"skin_friction": 0.0, **{p.name: 0.0 for p in self.form}}
        q = 0.5 * self.density_kg_m3 * speed_m_s**2
        re = abs(speed_m_s) * self.length_m / self.kinematic_viscosity_m2_s
        cf = skin_friction_coefficient(re, self.skin_friction)
        return {
            "skin_friction": q * cf * self.wetted_area_m2,
            **{p.name: q * p.drag_coefficient * p.frontal_area_m2 for p in self.form},
        }

    def total(self, speed_m_s: float) -> float:
        return float(sum(self.parts(speed_m_s).values()))


def mean_thrust(
    x: NDArray, half_height: NDArray, h: NDArray, dt_s: float, speed_m_s: float, **fluid
) -> float:
    """Lighthill's mean thrust (N) at forward speed ``speed_m_s`` (eq. 5-12)."""
    return slender_body_thrust(x, half_height, h, dt_s, speed_m_s=speed_m_s, **fluid).mean_thrust_n


def mean_pressure_thrust(
    x: NDArray,
    half_height: NDArray,
    h: NDArray,
    dt_s: float,
    speed_m_s: float,
    *,
    density_kg_m3: float,
    added_mass_coefficient: float = 1.0,
) -> float:
    """The part of the thrust (N) that the pressure on the inclined plate carries: the mean of
    the sections' reactive lateral force l(x, t) times the midline's slope, int <l h_x> dx, with
    l = -D(A w)/Dt where the sections grow and -A Dw/Dt where they shed vorticity (A' < 0),
    D/Dt = d/dt + V d/dx. Integrated by parts it is Lighthill's thrust less the suction that
    potential flow puts at the plate's sharp edges, 1/2 int_{A'>0} A' <w^2> dx and the nose's
    term: a sharp-edged plate sheds vortices there instead (the flume's CFD bears this out,
    docs/swimming.md). ``h``: (n_t, n_x) over whole periods."""
    x = np.asarray(x, dtype=float)
    h = np.asarray(h, dtype=float)
    area = added_mass_per_length(half_height, density_kg_m3, added_mass_coefficient)
    h_x = np.gradient(h, x, axis=1)
    w = periodic_derivative(h, dt_s) + speed_m_s * h_x

    def material(f: NDArray) -> NDArray:  # D/Dt
        return periodic_derivative(f, dt_s) + speed_m_s * np.gradient(f, x, axis=1)

    shedding = np.gradient(area, x) < 0
    force = np.where(shedding[None, :], -area[None, :] * material(w), -material(area[None, :] * w))
    return float(trapezoid(np.mean(force * h_x, axis=0), x))


@dataclass(frozen=True)
class SpeedLoads:
    """The modal matrices of the lateral load at forward speed (module docstring): the load
    on the modes is -(i w V damping_per_speed + V^2 stiffness_per_speed_squared) q."""

    damping_per_speed: NDArray  # C, (m, m)
    stiffness_per_speed_squared: NDArray  # K, (m, m)

    def damping(self, speed_m_s: float) -> NDArray:
        return speed_m_s * self.damping_per_speed

    def stiffness(self, speed_m_s: float) -> NDArray:
        return speed_m_s**2 * self.stiffness_per_speed_squared


def speed_loads(
    x: NDArray,
    half_height: NDArray,
    shapes: NDArray,
    *,
    density_kg_m3: float,
    added_mass_coefficient: float = 1.0,
) -> SpeedLoads:
    """SpeedLoads of modes whose midline lateral displacements at ``x`` are the rows of
    ``shapes`` (m, n_x); derivatives by finite differences, integrals by the trapezoid rule."""
    x = np.asarray(x, dtype=float)
    phi = np.asarray(shapes, dtype=float)
    area = added_mass_per_length(half_height, density_kg_m3, added_mass_coefficient)
    growing = np.maximum(np.gradient(area, x), 0.0)
    d1 = np.gradient(phi, x, axis=1)
    d2 = np.gradient(d1, x, axis=1)
    weights = np.zeros_like(x)
    weights[:-1] += np.diff(x) / 2
    weights[1:] += np.diff(x) / 2
    test = phi * weights
    # a blunt nose: A steps up from 0 there, A'_+ holds A(0) delta(x)
    nose = area[0] * phi[:, :1]
    return SpeedLoads(
        damping_per_speed=test @ (2 * area * d1 + growing * phi).T + nose @ phi[:, :1].T,
        stiffness_per_speed_squared=test @ (growing * d1 + area * d2).T + nose @ d1[:, :1].T,
    )


def divergence_speed(loads: SpeedLoads, omegas: NDArray, rigid: int) -> float:
    """The lowest speed (m/s) at which the load at speed's negative stiffness outgrows the
    elastic modes' own, w_j^2 + V^2 K (static divergence, elastic block); inf if none. Past
    it the linear periodic motion at that speed means nothing."""
    stiffness = loads.stiffness_per_speed_squared[rigid:, rigid:]
    elastic = np.asarray(omegas, dtype=float)[rigid:] ** 2
    if stiffness.size == 0:
        return float("inf")
    lam = np.linalg.eigvals(-stiffness / elastic[:, None])  # V^2 lam = 1 at divergence
    real = lam[(np.abs(lam.imag) <= 1e-9 * np.abs(lam).max()) & (lam.real > 0)].real
    return float(1 / np.sqrt(real.max())) if real.size else float("inf")


def self_propelled_speed(
    thrust, drag, tolerance_n: float = 1e-12, max_speed_m_s: float = MAX_SPEED_M_S
) -> float:
    """V* >= 0 with thrust(V*) = drag(V*); 0 when the motion gives no thrust at rest.
    ``max_speed_m_s``: no trial speed beyond it (the motion's divergence speed)."""
    if not thrust(0.0) > 0:
        return 0.0
    upper = min(0.05, max_speed_m_s)
    while thrust(upper) - drag(upper) > 0:
        if upper >= max_speed_m_s:
            why = (
                "the plate diverges there: the load at speed outgrows the stiffness of its "
                "modes, the plate's and its supports'; swimming.speed_coupling = false takes "
                "the still liquid's motion at every speed"
                if max_speed_m_s < MAX_SPEED_M_S
                else "is the motion finite?"
            )
            raise SwimmingError(
                f"the mean thrust exceeds the drag up to {max_speed_m_s:.3g} m/s: no "
                f"self-propelled speed ({why})"
            )
        upper = min(2 * upper, max_speed_m_s)
    # to 1e-10 m/s: each trial speed may cost a harmonic solve (the motion at that speed)
    return brentq(lambda v: thrust(v) - drag(v), 0.0, upper, xtol=1e-10, rtol=1e-10, maxiter=200)


@dataclass(frozen=True, kw_only=True)
class YawLoad:
    """Mean side force (N, +z) and yaw moment N = int (x - x_r) l dx (N m) over a period."""

    side_force_n: float
    yaw_moment_nm: float


def side_force_and_moment(
    x: NDArray,
    half_height: NDArray,
    h: NDArray,
    dt_s: float,
    *,
    speed_m_s: float,
    x_ref_m: float,
    density_kg_m3: float,
    added_mass_coefficient: float = 1.0,
    slip_rad: float = 0.0,
    yaw_rate_rad_s: float = 0.0,
    crossflow_drag_coefficient: float = 0.0,
    lateral_velocity_m_s: float = 0.0,
) -> YawLoad:
    """The mean side force and yaw moment of the module docstring, with the body slipped by
    ``slip_rad`` and turning at ``yaw_rate_rad_s`` about +y through ``x_ref_m``.
    ``lateral_velocity_m_s``: the body's own sway velocity (+z): at a forward speed V the
    slip v / V (the same stream met at an angle), at rest a cross flow (a start from rest)."""
    x, b, h = (np.asarray(v, dtype=float) for v in (x, half_height, h))
    v = float(speed_m_s)
    if v > 0:
        slip_rad, lateral_velocity_m_s = slip_rad + lateral_velocity_m_s / v, 0.0
    area = added_mass_per_length(b, density_kg_m3, added_mass_coefficient)
    r = x - x_ref_m
    w_turn = lateral_velocity_m_s - yaw_rate_rad_s * r
    h_x = np.gradient(h, x, axis=1, edge_order=2) + slip_rad
    w = periodic_derivative(h, dt_s) + v * h_x + w_turn
    w_mean = w.mean(axis=0)
    w_star = _mean_sheet_velocity(x, b, w_mean) if v > 0 else np.zeros_like(x)
    shrinking, growing = np.diff(area) < 0, np.diff(area) > 0

    def stieltjes(f: NDArray, intervals: NDArray) -> float:
        return float(_stieltjes(f[None, :], area, intervals)[0])

    tilt = -area[-1] * np.mean(w[:, -1] ** 2 * h_x[:, -1]) / 2
    force = (
        -v * area[-1] * w_mean[-1]
        + v * stieltjes(w_mean, shrinking)
        + v * stieltjes(w_star, growing)
        + tilt
    )
    moment = (
        -v * r[-1] * area[-1] * w_mean[-1]
        + v * trapezoid(area * w_mean, x)
        + v * stieltjes(r * w_mean, shrinking)
        + v * stieltjes(r * w_star, growing)
        + r[-1] * tilt
    )
    cross = -0.5 * density_kg_m3 * crossflow_drag_coefficient * 2 * b * np.abs(w_turn) * w_turn
    force += trapezoid(cross, x)
    moment += trapezoid(r * cross, x)
    return YawLoad(side_force_n=float(force), yaw_moment_nm=float(moment))


def _mean_sheet_velocity(x: NDArray, b: NDArray, w_mean: NDArray) -> NDArray:
    """<w*>: the mean of w where the sheet was shed (a time shift leaves a mean unchanged)."""
    w_star = np.zeros_like(x)
    for i, (_, j, frac) in _shedding_points(x, b).items():
        w_star[i] = (1 - frac) * w_mean[j] + frac * w_mean[j + 1]
    return w_star


def mirrored_over_half_a_period(h: NDArray, rtol: float = 1e-9) -> bool:
    """Whether the midline history ``h`` (one period of samples, n_t, n_x) is its own mirror
    image half a period later, h(t + T/2) = -h(t): a symmetric drive's motion. The side force
    and the yaw moment are odd in h and do not change with a shift in time, so they vanish."""
    h = np.asarray(h, dtype=float)
    if len(h) % 2:
        return False
    scale = float(np.abs(h).max())
    return scale == 0.0 or float(np.abs(h + np.roll(h, len(h) // 2, axis=0)).max()) <= rtol * scale


@dataclass(frozen=True, kw_only=True)
class Turning:
    yaw_rate_rad_s: float  # + to the left (+z side), about +y
    slip_rad: float  # the sideslip that cancels the mean side force
    drive_moment_nm: float  # N at Omega = 0 (after the slip): what turns the fish


def turning_rate(x, half_height, h, dt_s, **load) -> Turning:
    """The steady turning rate: N(beta(Omega), Omega) = 0, beta cancelling the side force.
    ``load``: the keywords of :func:`side_force_and_moment` other than slip and yaw rate."""

    def loads(slip: float, rate: float) -> YawLoad:
        return side_force_and_moment(
            x, half_height, h, dt_s, slip_rad=slip, yaw_rate_rad_s=rate, **load
        )

    def slip_of(rate: float) -> float:
        f = lambda s: loads(s, rate).side_force_n  # noqa: E731
        lo, hi = f(-MAX_SLIP_RAD), f(MAX_SLIP_RAD)
        if not lo * hi < 0:  # no side force to cancel (at rest, no lift)
            return 0.0
        return brentq(f, -MAX_SLIP_RAD, MAX_SLIP_RAD, xtol=1e-12)

    def moment(rate: float) -> float:
        return loads(slip_of(rate), rate).yaw_moment_nm

    if not load["speed_m_s"] > 0:  # no forward speed (a flume at 0 m/s): no path to turn
        # along, and no sideslip to speak of
        return Turning(
            yaw_rate_rad_s=0.0, slip_rad=0.0, drive_moment_nm=loads(0.0, 0.0).yaw_moment_nm
        )
    if mirrored_over_half_a_period(h):  # N = 0 exactly: what is left is round-off, and at a
        # low speed the yaw balance near 0 is unstable, so round-off would pick a far root
        return Turning(yaw_rate_rad_s=0.0, slip_rad=0.0, drive_moment_nm=0.0)
    drive = moment(0.0)
    if drive == 0.0:
        return Turning(yaw_rate_rad_s=0.0, slip_rad=slip_of(0.0), drive_moment_nm=0.0)
    # the damping grows with Omega: bracket on the side that opposes the drive
    step = -np.sign(drive) * 0.01
    while moment(step) * drive > 0:
        step *= 2
        if abs(step) > 1e3:
            raise SwimmingError("no yaw damping balances the drive's yaw moment")
    rate = brentq(moment, 0.0, step, xtol=1e-12, rtol=1e-12)
    return Turning(yaw_rate_rad_s=rate, slip_rad=slip_of(rate), drive_moment_nm=drive)
