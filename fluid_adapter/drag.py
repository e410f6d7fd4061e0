"""The fast model's fluid damping: separated flow at the plate's edges, fitted to OpenFOAM.

Potential flow has no damping. A flat plate swinging across a still liquid sheds vortices
from its edges. At the low Keulegan-Carpenter numbers of the fish (KC = 2 pi A / h: 0.1-3
here) the drag coefficient of a sharp-edged plate falls as a power of KC (Graham 1980,
J. Fluid Mech. 97, C_D ~ KC^-1/3 as KC -> 0). Per unit plate area:

    f = -1/2 rho C_D(KC) |v| v,   C_D = C0 KC^-q,   KC = 2 pi |v| / (omega h),

with h the local plate height and omega the drive's angular frequency. Written with the
instantaneous normal velocity this is a power law, f = -kappa |v|^(1-q) v with
kappa = 1/2 rho C0 (omega h / 2 pi)^q. Its equivalent linear damping over a sine of velocity
amplitude V is kappa F V^(1-q), where F = (1/pi) int_0^2pi |sin|^(3-q) is the harmonic-balance
factor (8 / 3 pi for a quadratic drag).

C0 and q are fitted to OpenFOAM (benchmarks/fast_fluid_damping.py). The data are the lateral
force on the clamped original fish moving in its first mode at 3 Hz, k-omega SST, coarse level.
They come from benchmarks/openfoam_added_mass.py, with the damping per tail velocity at tail
amplitudes of 1, 7.8 and 17.8 mm.

One frequency cannot tell how the coefficient changes with it at a fixed KC. On the coupled
curves of the same scene (1-25 Hz) the 3 Hz law damps the held fish's second mode away, where
OpenFOAM keeps its resonance: ``frequency_exponent`` r scales C0 by (f / 3 Hz)^-r
(``fluid.edge_drag_frequency_exponent``). Fitted to those curves r is 0.4
(benchmarks/fast_fluid_accuracy.py --fit-exponent), between a drag of separated flow alone
(r = 0) and the Stokes layer's, whose coefficient at a fixed KC goes as beta^-1/2 with the
frequency parameter beta = h^2 f / nu (Wang 1968, r = 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.special import gamma

# benchmarks/fast_fluid_damping.py fits these to the OpenFOAM measurements (docs/validation.md)
DRAG_C0 = 9.82
DRAG_Q = 0.224
DRAG_FIT_HZ = 3.0  # the drive frequency of the fitted motion
# r, fitted to OpenFOAM's coupled 1-25 Hz curves (fluid.edge_drag_frequency_exponent's default)
DRAG_FREQUENCY_EXPONENT = 0.4
NDOF = 5  # the shell's DOFs per node (u_x, u_y, u_z, theta_1, theta_2)
# below this normal speed the power law is smoothed (0.02 % of the force at 0.05 m/s)
SMOOTH_SPEED_M_S = 1e-3


def harmonic_balance_factor(p: float) -> float:
    """F(p) = (1/pi) int_0^2pi |sin t|^(p+2) dt: the equivalent linear damping of
    f = k |v|^p v over v = V sin(t) is k F V^p."""
    n = p + 2
    return 4 / np.pi * np.sqrt(np.pi) * gamma((n + 1) / 2) / (2 * gamma(n / 2 + 1))


@dataclass(frozen=True)
class EdgeDrag:
    """f_i = k_i |v_i|^p v_i on each node's normal (z) velocity; the damping interface of
    solid_adapter.solvers (force, linear)."""

    coefficients: NDArray  # k_i (N (s/m)^(1+p))
    exponent: float  # p = 1 - q
    omega: float  # rad/s, the drive's
    # linearize on every harmonic's velocity (rms, as an equivalent sine), as the law acts on
    # the whole motion: on the fundamental's alone a square wave's harmonics ring the fin at
    # its own modes nearly undamped (18 Hz, held fish: 3.2 mm, where the nonlinear transient
    # swings 2.1 mm and the rms linearization gives 2.1 mm)
    all_harmonics: bool = True

    amplitude_dependent = True

    def force(self, model, x: NDArray, v: NDArray) -> tuple[NDArray, sp.spmatrix]:
        """|v|^p smoothed below SMOOTH_SPEED_M_S, (v^2 + v0^2)^(p/2): the law's second
        derivative is unbounded at v = 0, and Newton stalled on the nodes near a clamp."""
        vz = v[2::NDOF]
        s2 = vz**2 + SMOOTH_SPEED_M_S**2
        speed = s2 ** (self.exponent / 2)
        f = np.zeros_like(v)
        f[2::NDOF] = self.coefficients * speed * vz
        tangent = np.zeros_like(v)
        tangent[2::NDOF] = self.coefficients * speed * (1 + self.exponent * vz**2 / s2)
        return f, sp.diags(tangent).tocsr()

    def linear(self, model, orbit=None) -> sp.spmatrix:
        """Equivalent linear damping about the fundamental of ``orbit`` (a periodic response;
        None: no motion yet, no damping)."""
        c = np.zeros(model.ndof)
        if orbit is not None:
            parts = orbit.harmonics if self.all_harmonics else orbit.harmonics[:1]
            velocity = np.sqrt(sum(np.abs(k * orbit.omega * X[2::NDOF]) ** 2 for k, X in parts))
            c[2::NDOF] = (
                harmonic_balance_factor(self.exponent) * self.coefficients * velocity**self.exponent
            )
        return sp.diags(c).tocsr()


# gamma of the edge inertia, m_i = gamma rho A_i |a_i|: benchmarks/fast_fluid_inertia.py fits it
# to OpenFOAM's lateral-force inertia on the same first-mode motion at 1, 7.8 and 17.8 mm tail
EDGE_INERTIA_GAMMA = 1.17


@dataclass(frozen=True)
class EdgeInertia:
    """The extra inertia of separated flow: the vortices a plate sheds from its edges carry
    liquid with it, and OpenFOAM's lateral force on the same motion carries more inertia than
    potential flow, growing linearly with the amplitude (1.13 / 1.27 / 1.48 times the converged
    potential added mass at 1 / 7.8 / 17.8 mm tail; docs/coupling.md). Per unit area a layer
    of liquid gamma |a| thick, a the local normal amplitude: m_i = k_i |a_i|, k_i = gamma rho
    A_i. For a flat plate the added-mass coefficient grows with KC = 2 pi a / h at low KC
    (Keulegan & Carpenter 1958); per unit area rho (pi h / 4) C_a(KC), linear in KC, is this
    law, in which h drops out."""

    coefficients: NDArray  # k_i (kg/m)

    def linear(self, model, orbit=None) -> sp.spmatrix:
        """Nodal extra masses on the normal (z) DOFs about ``orbit``'s amplitude, every
        harmonic's as an equivalent sine (rms); None: no motion yet, no extra mass."""
        m = np.zeros(model.ndof)
        if orbit is not None:
            amplitude = np.sqrt(sum(np.abs(X[2::NDOF]) ** 2 for _, X in orbit.harmonics))
            m[2::NDOF] = self.coefficients * amplitude
        return sp.diags(m).tocsr()


def edge_inertia(model, density_kg_m3: float, gamma: float = EDGE_INERTIA_GAMMA) -> EdgeInertia:
    area = np.asarray(model.area_matrix.sum(axis=1)).ravel()
    return EdgeInertia(coefficients=gamma * density_kg_m3 * area)


def edge_drag(
    model,
    density_kg_m3: float,
    frequency_hz: float,
    c0: float = DRAG_C0,
    q: float = DRAG_Q,
    all_harmonics: bool = True,
    frequency_exponent: float = DRAG_FREQUENCY_EXPONENT,
) -> EdgeDrag:
    """The drag law on a shell model's nodes (lumped nodal areas, local plate height), its
    coefficient scaled by (f / DRAG_FIT_HZ)^-frequency_exponent away from the fit's 3 Hz."""
    omega = 2 * np.pi * frequency_hz
    area = np.asarray(model.area_matrix.sum(axis=1)).ravel()
    height = model.layout.height(model.mesh.nodes[:, 0])
    c0 = c0 * (frequency_hz / DRAG_FIT_HZ) ** -frequency_exponent
    kappa = 0.5 * density_kg_m3 * c0 * (omega * height / (2 * np.pi)) ** q
    return EdgeDrag(
        coefficients=kappa * area, exponent=1.0 - q, omega=omega, all_harmonics=all_harmonics
    )
