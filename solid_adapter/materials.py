"""Layer materials and laminate section properties (classical lamination theory, SI units).

A section is the through-thickness integral of its layers about the reference surface z = 0
(the mid-plane of the CFRP core):

    A = sum Q t,  B = sum Q (z1^2 - z0^2)/2,  D = sum Q (z1^3 - z0^3)/3,
    S = 5/6 sum diag(G13, G23) t,   rho_k = sum rho (z1^(k+1) - z0^(k+1))/(k+1),

with Q the plane-stress reduced stiffness in Voigt order [11, 22, 12] (engineering shear).

Piezo driving (seed eqs. 3-9..3-11): an MFC layer driven at V has the free strain
eps0 = [d33, d31, 0] V / W along (fibre, electrode) = (x, y); its stress-free state is the
eigenstrain eps0, so the layer contributes the eigen-resultants N0 = Q eps0 t and
M0 = Q eps0 (z1^2 - z0^2)/2 per volt. Q eps0 is exactly eq. 3-10.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

SHEAR_CORRECTION = 5.0 / 6.0


@dataclass(frozen=True, kw_only=True)
class Material:
    """Orthotropic in the plate plane (1 = x, 2 = y); isotropic when e1 == e2."""

    name: str
    e1_pa: float
    e2_pa: float
    nu12: float
    g12_pa: float
    density_kg_m3: float
    source: str = ""

    @classmethod
    def isotropic(
        cls, name: str, e_pa: float, nu: float, density_kg_m3: float, source: str = ""
    ) -> Material:
        return cls(
            name=name,
            e1_pa=e_pa,
            e2_pa=e_pa,
            nu12=nu,
            g12_pa=e_pa / (2 * (1 + nu)),
            density_kg_m3=density_kg_m3,
            source=source,
        )

    @property
    def nu21(self) -> float:
        return self.nu12 * self.e2_pa / self.e1_pa

    def reduced_stiffness(self) -> NDArray:
        den = 1.0 - self.nu12 * self.nu21
        q11, q22 = self.e1_pa / den, self.e2_pa / den
        q12 = self.nu21 * self.e1_pa / den
        return np.array([[q11, q12, 0.0], [q12, q22, 0.0], [0.0, 0.0, self.g12_pa]])


# Table 3.1 (MFC M8528-P1, d33 type). nu21 = nu12 E2/E1 = 0.162 matches the table's 0.16.
MFC = Material(
    name="MFC M8528-P1",
    e1_pa=30.336e9,
    e2_pa=15.9e9,
    nu12=0.31,
    g12_pa=5.515e9,
    density_kg_m3=5440.0,
    source="Table 3.1, density Table 3.2",
)
# The package outside the active area is polyimide film and epoxy (Kapton HN datasheet values).
MFC_BORDER = Material.isotropic(
    "MFC border (polyimide/epoxy)", 2.5e9, 0.34, 1420.0, source="Kapton HN datasheet"
)
CFRP = {
    "fsi": Material.isotropic("CFRP (FSI model)", 29.5e9, 0.3, 1700.0, source="Table 3.9"),
    "acoustic": Material.isotropic(
        "CFRP (acoustic model)", 20.5e9, 0.3, 1643.0, source="Table 3.5"
    ),
    "beam": Material.isotropic("CFRP (beam model)", 20.05e9, 0.3, 1643.0, source="Table 3.2"),
}
# Tables 3.5 and 3.9 give 20 GPa for the steel weight (probably 200 GPa); 2.5 mm of either is
# rigid next to the 0.8 mm laminate, so the seed's value is kept.
STEEL_HEAD_WEIGHT = Material.isotropic(
    "steel head weight", 20e9, 0.3, 7850.0, source="Tables 3.5, 3.9"
)


@dataclass(frozen=True, kw_only=True)
class Layer:
    material: Material
    z0_m: float
    z1_m: float
    piezo_side: int | None = None  # 0: left (+z) actuator, 1: right (-z) actuator

    @property
    def thickness_m(self) -> float:
        return self.z1_m - self.z0_m


@dataclass(frozen=True)
class PiezoConstants:
    d33_m_per_v: float
    d31_m_per_v: float
    electrode_spacing_m: float

    def free_strain_per_volt(self) -> NDArray:
        """Eq. 3-9 with eq. 3-11: eps0 / V = [d33, d31, 0] / W."""
        return np.array([self.d33_m_per_v, self.d31_m_per_v, 0.0]) / self.electrode_spacing_m


@dataclass(frozen=True)
class Section:
    """Resultant stiffness, inertia and unit-voltage eigen-resultants of one laminate."""

    A: NDArray
    B: NDArray
    D: NDArray
    S: NDArray
    rho: NDArray  # [rho0, rho1, rho2]
    eigen_per_volt: NDArray  # (2 sides, 6): [N0; M0] per volt on the left / right actuator
    layers: tuple[Layer, ...]

    @classmethod
    def from_layers(cls, layers: tuple[Layer, ...], piezo: PiezoConstants | None) -> Section:
        A, B, D = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
        S = np.zeros((2, 2))
        rho = np.zeros(3)
        eigen = np.zeros((2, 6))
        for layer in layers:
            z0, z1 = layer.z0_m, layer.z1_m
            Q = layer.material.reduced_stiffness()
            A += Q * (z1 - z0)
            B += Q * (z1**2 - z0**2) / 2
            D += Q * (z1**3 - z0**3) / 3
            S += SHEAR_CORRECTION * layer.material.g12_pa * (z1 - z0) * np.eye(2)
            rho += layer.material.density_kg_m3 * np.array(
                [z1 - z0, (z1**2 - z0**2) / 2, (z1**3 - z0**3) / 3]
            )
            if layer.piezo_side is not None and piezo is not None:
                sigma0 = Q @ piezo.free_strain_per_volt()  # eq. 3-10 per volt
                eigen[layer.piezo_side, :3] += sigma0 * (z1 - z0)
                eigen[layer.piezo_side, 3:] += sigma0 * (z1**2 - z0**2) / 2
        return cls(A=A, B=B, D=D, S=S, rho=rho, eigen_per_volt=eigen, layers=tuple(layers))

    @property
    def abd(self) -> NDArray:
        return np.block([[self.A, self.B], [self.B, self.D]])

    @property
    def free_deformation_per_volt(self) -> NDArray:
        """(2, 6): [eps0; kappa0] = ABD^-1 [N0; M0] per volt, the stress-free state."""
        return np.linalg.solve(self.abd, self.eigen_per_volt.T).T


def stack(
    core: Material, core_thickness_m: float, outer: dict[int, list[tuple[Material, float, bool]]]
) -> tuple[Layer, ...]:
    """Core centred on z = 0, then per face (0: +z, 1: -z) the (material, thickness, piezo
    active) layers stacked outward, innermost first."""
    layers = [Layer(material=core, z0_m=-core_thickness_m / 2, z1_m=core_thickness_m / 2)]
    for side, entries in outer.items():
        sign = 1.0 if side == 0 else -1.0
        z = core_thickness_m / 2
        for material, t, active in entries:
            a, b = sign * z, sign * (z + t)
            layers.append(
                Layer(
                    material=material,
                    z0_m=min(a, b),
                    z1_m=max(a, b),
                    piezo_side=side if active else None,
                )
            )
            z += t
    return tuple(layers)
