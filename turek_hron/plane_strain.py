"""Geometrically nonlinear St. Venant-Kirchhoff solid in plane strain: the elastic flag of the
Turek & Hron (2006) FSI/CSM benchmarks, as a coupling participant.

Total Lagrangian, reference coordinates X, displacement u (m), per unit depth:

    F = I + grad u,   E = (F^T F - I) / 2,   S = lambda tr(E) I + 2 mu E   (Pa)
    W = lambda/2 tr(E)^2 + mu E:E                     (J/m3, stored energy density)
    P = F S                                           (first Piola-Kirchhoff stress)

Weak form (per unit depth, so forces are N/m, energies J/m):

    int rho0 u''.w dA + int P : grad w dA = int rho0 b.w dA + sum_a f_a.w_a

with lambda = 2 mu nu / (1 - 2 nu), E = 2 mu (1 + nu) and, for beam checks, the plane-strain
modulus E' = E / (1 - nu^2). Tangent: dP_iI/dF_jJ = delta_ij S_IJ + lambda F_iI F_jJ
+ mu ((F F^T)_ij delta_IJ + F_iJ F_jI).

Discretisation: 9-node Lagrange quads (``skfem.ElementQuad2``) on a structured nx x ny grid
mapped onto the flag, 3 x 3 Gauss points, vectorised numpy kernels over (element, point)
arrays assembled into one fixed CSR pattern; consistent mass.

Geometry (Turek & Hron 2006): flag y in [0.19, 0.21], free end x = 0.6, clamped where it meets
the cylinder of radius 0.05 centred at (0.2, 0.2). By default the clamped edge follows that arc
(x from 0.24899 at the corners to 0.25 at mid-height; the grid's left column is mapped onto it,
so the arc is resolved piecewise linearly between vertex rows); ``curved_clamp=False`` gives the
straight clamp at x = 0.2 + sqrt(0.05^2 - 0.01^2) = 0.24899.

Time integration: generalized-alpha (Chung & Hulbert 1993) in the form of
:mod:`solid_adapter.solvers`, with Newton on the displacements; loads are dead within a window.

Units for coupling: the 2D problem is per unit depth. A caller with a 3D force on the flag of a
one-cell-thick OpenFOAM channel of depth d (m) passes ``force_N / d`` (N/m); a caller with a
traction t (Pa) on the wetted boundary passes it as ``"traction"`` (N/m2 = N/m per m of edge).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem
from numpy.typing import NDArray

from fsi_orchestrator.participant import (
    ACCELERATION,
    DISPLACEMENT,
    FORCE,
    VELOCITY,
    InterfaceMesh,
    State,
)
from solid_adapter.mesh import QuadratureData
from solid_adapter.shell import SparsePattern
from solid_adapter.solvers import (
    AlphaParameters,
    DynamicState,
    NewtonSettings,
    SolverError,
    solve_linear,
)

TRACTION = "traction"  # (n, 3) N/m2 on the interface points, per unit depth: N/m per m of edge
DIM = 2
DEFAULT_NEWTON = NewtonSettings()
INTORDER = 5  # 3 x 3 Gauss points (exact mass and linear stiffness of 9-node rectangles)
# Turek & Hron (2006), Section 2: cylinder centre (0.2, 0.2), radius 0.05; flag end x = 0.6,
# thickness 0.02; point A = (0.6, 0.2).
TUREK_HRON_CYLINDER = ((0.2, 0.2), 0.05)
TUREK_HRON_TIP_X, TUREK_HRON_HALF_HEIGHT = 0.6, 0.01


# --------------------------------------------------------------------------- configuration


@dataclass(frozen=True, kw_only=True)
class SvkMaterial:
    """St. Venant-Kirchhoff material (rho0 kg/m3, mu Pa, nu)."""

    density_kg_m3: float
    shear_modulus_pa: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        if not self.density_kg_m3 > 0:
            raise ValueError(f"`density_kg_m3` must be > 0, got {self.density_kg_m3}")
        if not self.shear_modulus_pa > 0:
            raise ValueError(f"`shear_modulus_pa` must be > 0, got {self.shear_modulus_pa}")
        if not -1.0 < self.poisson_ratio < 0.5:
            raise ValueError(f"`poisson_ratio` must be in (-1, 0.5), got {self.poisson_ratio}")

    @property
    def lame_lambda_pa(self) -> float:
        """lambda = 2 mu nu / (1 - 2 nu)."""
        return 2 * self.shear_modulus_pa * self.poisson_ratio / (1 - 2 * self.poisson_ratio)

    @property
    def youngs_modulus_pa(self) -> float:
        """E = 2 mu (1 + nu)."""
        return 2 * self.shear_modulus_pa * (1 + self.poisson_ratio)

    @property
    def plane_strain_modulus_pa(self) -> float:
        """E' = E / (1 - nu^2), the bending modulus of a plane-strain beam."""
        return self.youngs_modulus_pa / (1 - self.poisson_ratio**2)


@dataclass(frozen=True, kw_only=True)
class FlagGeometry:
    """The rectangle [x_clamp, x_tip] x [y_bottom, y_top] (m), clamped on its left end.

    ``cylinder_radius_m``: if given, the clamped end is the arc of that circle through the two
    left corners, centred at mid-height to their left (the flag attached to the cylinder).
    """

    x_clamp_m: float
    x_tip_m: float
    y_bottom_m: float
    y_top_m: float
    cylinder_radius_m: float | None = None

    def __post_init__(self) -> None:
        if not self.x_tip_m > self.x_clamp_m:
            raise ValueError(f"`x_tip_m` must exceed `x_clamp_m`, got {self.x_tip_m}")
        if not self.y_top_m > self.y_bottom_m:
            raise ValueError(f"`y_top_m` must exceed `y_bottom_m`, got {self.y_top_m}")
        r = self.cylinder_radius_m
        if r is not None and not r >= 0.5 * self.height_m:
            raise ValueError(f"`cylinder_radius_m` must be >= half the height, got {r}")

    @classmethod
    def turek_hron(cls, curved_clamp: bool = True) -> FlagGeometry:
        """The benchmark flag: y in [0.19, 0.21], free end at x = 0.6, clamped on the cylinder
        (arc, or the straight line x = 0.2 + sqrt(0.05^2 - 0.01^2) between its ends)."""
        (xc, yc), r = TUREK_HRON_CYLINDER
        h = TUREK_HRON_HALF_HEIGHT
        return cls(
            x_clamp_m=xc + np.sqrt(r**2 - h**2),
            x_tip_m=TUREK_HRON_TIP_X,
            y_bottom_m=yc - h,
            y_top_m=yc + h,
            cylinder_radius_m=r if curved_clamp else None,
        )

    @property
    def height_m(self) -> float:
        return self.y_top_m - self.y_bottom_m

    @property
    def length_m(self) -> float:
        """Length of the top and bottom edges."""
        return self.x_tip_m - self.x_clamp_m

    @property
    def tip_point(self) -> tuple[float, float]:
        """Middle of the free end (Turek & Hron's point A)."""
        return self.x_tip_m, 0.5 * (self.y_bottom_m + self.y_top_m)

    def x_left(self, y: NDArray) -> NDArray:
        """x of the clamped end at height y."""
        if self.cylinder_radius_m is None:
            return np.full_like(y, self.x_clamp_m)
        r, half = self.cylinder_radius_m, 0.5 * self.height_m
        xc = self.x_clamp_m - np.sqrt(r**2 - half**2)
        return xc + np.sqrt(r**2 - (y - self.tip_point[1]) ** 2)


# --------------------------------------------------------------------------- mesh


@dataclass(frozen=True)
class FlagMesh:
    """Nodes of the 9-node quads and the index sets the model and the coupling need."""

    mesh: skfem.MeshQuad1
    quad: QuadratureData  # 3 x 3 Gauss points
    nodes: NDArray  # (n, 2) reference coordinates
    element_nodes: NDArray  # (nel, 9), scikit-fem ElementQuad2 order
    clamped_nodes: NDArray
    interface_nodes: NDArray  # wetted boundary: bottom (clamp -> tip), free end, top (tip -> clamp)
    interface_cells: NDArray  # (m, 3) "line3" cells (ends, middle) in interface numbering
    tip_node: int


def build_flag_mesh(geometry: FlagGeometry, elements: tuple[int, int]) -> FlagMesh:
    """Structured nx x ny grid, uniform along the flag and across it, mapped onto ``geometry``
    (parameter xi in [0, 1] from the clamped end to the free end)."""
    nx, ny = elements
    if nx < 1 or ny < 1:
        raise ValueError(f"`elements` must be two positive integers, got {elements}")
    g = geometry
    param = skfem.MeshQuad.init_tensor(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1))
    xi, eta = param.p
    y = g.y_bottom_m + eta * g.height_m
    x_left = g.x_left(y)
    mesh = skfem.MeshQuad1(np.array([x_left + xi * (g.x_tip_m - x_left), y]), param.t)
    basis = skfem.CellBasis(mesh, skfem.ElementQuad2(), intorder=INTORDER)
    # classify the nodes by their grid parameters (same topology, so the same DOF numbering)
    s_xi, s_eta = skfem.CellBasis(param, skfem.ElementQuad2(), intorder=1).doflocs
    nodes = basis.doflocs.T.copy()
    interface, cells = _interface(param, s_xi, s_eta)
    tip = int(np.argmin(np.sum((nodes - np.array(g.tip_point)) ** 2, axis=1)))
    assert np.allclose(nodes[tip], g.tip_point, atol=1e-12 * g.length_m)
    return FlagMesh(
        mesh=mesh,
        quad=QuadratureData.from_basis(basis),
        nodes=nodes,
        element_nodes=basis.element_dofs.T.copy(),
        clamped_nodes=np.flatnonzero(np.isclose(s_xi, 0.0)),
        interface_nodes=interface,
        interface_cells=cells,
        tip_node=tip,
    )


def _interface(param: skfem.MeshQuad1, xi: NDArray, eta: NDArray) -> tuple[NDArray, NDArray]:
    """Wetted nodes ordered along the contour (arc parameter s: bottom 0..1, end 1..2, top 2..3)
    and the boundary facets not on the clamp as line3 cells oriented along s."""
    bottom, top, end = np.isclose(eta, 0), np.isclose(eta, 1), np.isclose(xi, 1)
    s = np.where(bottom, xi, np.where(end, 1 + eta, 3 - xi))
    wet = np.flatnonzero(bottom | top | end)
    wet = wet[np.argsort(s[wet], kind="stable")]
    local = np.full(len(xi), -1)
    local[wet] = np.arange(len(wet))
    facets = param.boundary_facets()
    v0, v1 = param.facets[:, facets]
    keep = ~(np.isclose(xi[v0], 0) & np.isclose(xi[v1], 0))
    v0, v1, mid = v0[keep], v1[keep], param.nvertices + facets[keep]
    flip = s[v0] > s[v1]
    v0, v1 = np.where(flip, v1, v0), np.where(flip, v0, v1)
    cells = np.column_stack([local[v0], local[v1], local[mid]])
    assert cells.min() >= 0
    return wet, cells[np.argsort(s[mid])]


# --------------------------------------------------------------------------- model


class PlaneStrainModel:
    """Internal forces, tangent, mass and loads of the flag (DOFs: u_x, u_y per node, node-major).

    ``gravity_m_s2``: body-force acceleration along -y (Turek & Hron CSM: g = 2 m/s^2).
    """

    def __init__(
        self, material: SvkMaterial, geometry: FlagGeometry, mesh: FlagMesh, gravity_m_s2: float
    ) -> None:
        self.material, self.geometry, self.mesh = material, geometry, mesh
        self.n_nodes = len(mesh.nodes)
        self.ndof = DIM * self.n_nodes
        enodes = mesh.element_nodes
        self.edofs = (enodes[:, :, None] * DIM + np.arange(DIM)).reshape(len(enodes), -1)
        self.pattern = SparsePattern(self.edofs, self.ndof)
        fixed = np.zeros((self.n_nodes, DIM), dtype=bool)
        fixed[mesh.clamped_nodes] = True
        self.fixed_dofs, self.free_dofs = fixed.ravel(), ~fixed.ravel()
        self._weights = mesh.quad.weights  # (nel, nqp) Gauss weight x Jacobian
        self._B = self._gradient_operator()
        self._Bt = np.swapaxes(self._B, -1, -2).copy()
        self.mass = self._mass_matrix()
        self.gravity_load = self._gravity_load(gravity_m_s2)
        self.interface_dofs = (mesh.interface_nodes[:, None] * DIM + np.arange(DIM)).ravel()
        self.edge_matrix = _edge_matrix(mesh.nodes[mesh.interface_nodes], mesh.interface_cells)

    def zero_state(self) -> NDArray:
        return np.zeros(self.ndof)

    # ------------------------------------------------------------------ internal forces
    def _kinematics(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Deformation gradient F, Green-Lagrange strain E and second Piola-Kirchhoff stress S
        at every point, each (nel, nqp, 2, 2)."""
        ue = x.reshape(-1, DIM)[self.mesh.element_nodes]
        F = np.einsum("eqbJ,ebi->eqiJ", self.mesh.quad.dN, ue) + np.eye(DIM)
        E = 0.5 * (np.swapaxes(F, -1, -2) @ F - np.eye(DIM))
        lam, mu = self.material.lame_lambda_pa, self.material.shear_modulus_pa
        S = lam * np.trace(E, axis1=-2, axis2=-1)[..., None, None] * np.eye(DIM) + 2 * mu * E
        return F, E, S

    def internal(self, x: NDArray, tangent: bool = True) -> tuple[NDArray, sp.csr_matrix | None]:
        """f_int = int B^T P dA (N/m) and K = int B^T A B dA, with B the constant map from the
        element DOFs to grad u (rows iI) and A = dP/dF."""
        F, _, S = self._kinematics(x)
        nel, nqp = F.shape[:2]
        wP = (self._weights[..., None, None] * (F @ S)).reshape(nel, nqp, 1, DIM * DIM)
        fe = (wP @ self._B).sum(axis=1)
        r = np.bincount(self.edofs.ravel(), weights=fe.ravel(), minlength=self.ndof)
        if not tangent:
            return r, None
        wA = self._weights[..., None, None, None, None] * _tangent_moduli(F, S, self.material)
        Ke = (self._Bt @ wA.reshape(nel, nqp, DIM * DIM, DIM * DIM) @ self._B).sum(axis=1)
        return r, self.pattern.assemble(Ke)

    def strain_energy(self, x: NDArray) -> float:
        """Pi = int W dA (J/m), W = S:E / 2 = lambda/2 tr(E)^2 + mu E:E."""
        _, E, S = self._kinematics(x)
        return 0.5 * float(np.einsum("eq,eqIJ,eqIJ->", self._weights, S, E))

    def _gradient_operator(self) -> NDArray:
        """B (nel, nqp, 4, 18): (grad u)_iI = dN_a/dX_I u_ai, rows iI = 2 i + I, columns 2 a + i."""
        dN = self.mesh.quad.dN  # (nel, nqp, 9, 2)
        B = np.zeros((*dN.shape[:2], DIM, DIM, dN.shape[2], DIM))
        for i in range(DIM):
            B[:, :, i, :, :, i] = np.swapaxes(dN, -1, -2)
        return B.reshape(*dN.shape[:2], DIM * DIM, -1)

    # ------------------------------------------------------------------ mass and loads
    def _scalar_mass(self) -> NDArray:
        q = self.mesh.quad
        return self.material.density_kg_m3 * np.einsum("eq,eqa,eqb->eab", q.weights, q.N, q.N)

    def _mass_matrix(self) -> sp.csr_matrix:
        """Consistent mass M_aibj = delta_ij int rho0 N_a N_b dA (kg/m)."""
        Me = np.einsum("eab,ij->eaibj", self._scalar_mass(), np.eye(DIM))
        return self.pattern.assemble(Me.reshape(len(Me), DIM * 9, DIM * 9))

    def _gravity_load(self, g: float) -> NDArray:
        """f_a = -g e_y int rho0 N_a dA (N/m)."""
        q = self.mesh.quad
        fa = -g * self.material.density_kg_m3 * np.einsum("eq,eqa->ea", q.weights, q.N)
        f = np.zeros((self.n_nodes, DIM))
        np.add.at(f[:, 1], self.mesh.element_nodes.ravel(), fa.ravel())
        return f.ravel()

    def total_mass_kg_m(self) -> float:
        return float(self._scalar_mass().sum())

    def interface_load(self, force: NDArray, traction: NDArray) -> NDArray:
        """Load vector of nodal forces (n_if, 2) N/m plus a traction (n_if, 2) N/m2 integrated
        over the reference wetted edges (dead load: f_a = int N_a t ds)."""
        f = np.zeros(self.ndof)
        f[self.interface_dofs] = (force + self.edge_matrix @ traction).ravel()
        return f


def _tangent_moduli(F: NDArray, S: NDArray, material: SvkMaterial) -> NDArray:
    """A_iIjJ = dP_iI/dF_jJ = delta_ij S_IJ + lambda F_iI F_jJ + mu ((F F^T)_ij delta_IJ
    + F_iJ F_jI), shape (nel, nqp, 2, 2, 2, 2) with axes (i, I, j, J)."""
    lam, mu = material.lame_lambda_pa, material.shear_modulus_pa
    eye = np.eye(DIM)
    FFt = F @ np.swapaxes(F, -1, -2)
    Ft = np.swapaxes(F, -1, -2)
    return (
        eye[:, None, :, None] * S[..., None, :, None, :]
        + lam * F[..., :, :, None, None] * F[..., None, None, :, :]
        + mu * FFt[..., :, None, :, None] * eye[None, :, None, :]
        + mu * F[..., :, None, None, :] * Ft[..., None, :, :, None]
    )


def _edge_matrix(points: NDArray, cells: NDArray) -> sp.csr_matrix:
    """Consistent line "mass" int N_a N_b ds of the straight line3 cells (m): per cell
    length/30 [[4, -1, 2], [-1, 4, 2], [2, 2, 16]] in (end, end, middle) order."""
    length = np.linalg.norm(points[cells[:, 1]] - points[cells[:, 0]], axis=1)
    ref = np.array([[4.0, -1.0, 2.0], [-1.0, 4.0, 2.0], [2.0, 2.0, 16.0]]) / 30.0
    data = length[:, None, None] * ref
    rows = np.repeat(cells, 3, axis=1).ravel()
    cols = np.tile(cells, (1, 3)).ravel()
    n = len(points)
    return sp.csr_matrix((data.ravel(), (rows, cols)), shape=(n, n))


# --------------------------------------------------------------------------- solvers

ResidualFn = Callable[[NDArray, bool], tuple[NDArray, sp.spmatrix | None]]


def newton(
    residual: ResidualFn,
    x0: NDArray,
    model: PlaneStrainModel,
    settings: NewtonSettings,
    where: str,
) -> tuple[NDArray, int]:
    """Solve residual(x) = 0 on the free DOFs; converged when max |dx| / L falls below
    ``settings.tolerance`` times the first increment of this solve (or below 1e-15)."""
    x = x0.copy()
    length = model.geometry.length_m
    first = None
    size = np.inf
    for it in range(1, settings.max_iterations + 1):
        r, K = residual(x, True)
        if not np.all(np.isfinite(r)):
            raise SolverError(f"flag: NaN in the residual {where} (Newton iteration {it})")
        dx = solve_linear(K, -r, model.free_dofs)
        x += dx
        size = float(np.max(np.abs(dx))) / length
        first = size if first is None else first
        if size <= settings.tolerance * first or size < 1e-15:
            return x, it
    raise SolverError(
        f"flag: Newton did not converge {where} in {settings.max_iterations} iterations (last "
        f"increment {size:.2e} of the length); use more load steps or a smaller time step"
    )


def solve_static(
    model: PlaneStrainModel,
    load: NDArray,
    steps: int = 4,
    settings: NewtonSettings = DEFAULT_NEWTON,
) -> NDArray:
    """Static equilibrium f_int(x) = lambda f for lambda = 1/steps, 2/steps, ... 1."""
    if steps < 1:
        raise ValueError(f"`steps` must be >= 1, got {steps}")
    x = model.zero_state()
    for k in range(1, steps + 1):
        f = load * (k / steps)

        def residual(xx: NDArray, tangent: bool, f: NDArray = f):
            r, K = model.internal(xx, tangent)
            return r - f, K

        x, _ = newton(residual, x, model, settings, f"in load step {k}/{steps}")
    return x


def natural_frequencies_hz(model: PlaneStrainModel, count: int) -> NDArray:
    """Lowest ``count`` frequencies of K0 phi = omega^2 M phi (linearised about the reference)."""
    K = model.internal(model.zero_state())[1]
    assert K is not None
    free = model.free_dofs
    Kff, Mff = sp.csc_matrix(K[free][:, free]), sp.csc_matrix(model.mass[free][:, free])
    v0 = np.random.default_rng(0).standard_normal(Kff.shape[0])  # reproducible to the digit
    w2 = spla.eigsh(Kff, k=count, M=Mff, sigma=0.0, which="LM", v0=v0)[0]
    return np.sqrt(np.sort(w2)) / (2 * np.pi)


class FlagIntegrator:
    """Generalized-alpha steps with dead loads (the caller owns the state):

        M a_{n+1-am} + (1-af) f_int(x_{n+1}) + af f_int(x_n) = (1-af) f_{n+1} + af f_n

    with Newmark updates of v and a (parameters from rho_inf, see
    :class:`~solid_adapter.solvers.AlphaParameters`); rho_inf = 1 is the trapezoidal rule.
    """

    max_halvings = 4  # a step whose Newton fails is retried as 2, 4, ... 16 sub-steps

    def __init__(
        self,
        model: PlaneStrainModel,
        rho_inf: float = 1.0,
        settings: NewtonSettings = DEFAULT_NEWTON,
    ) -> None:
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"`rho_inf` must be in [0, 1], got {rho_inf}")
        self.model, self.settings = model, settings
        self.p = AlphaParameters.generalized_alpha(rho_inf)
        self.newton_iterations = 0

    def initial_state(
        self, t0: float, load: NDArray, x0: NDArray | None = None, v0: NDArray | None = None
    ) -> DynamicState:
        """State at t0 (undeformed and at rest unless x0 / v0 given), with the acceleration
        M a0 = f - f_int(x0) that balances it."""
        m = self.model
        x = m.zero_state() if x0 is None else np.array(x0, dtype=float)
        v = m.zero_state() if v0 is None else np.array(v0, dtype=float)
        f_int = m.internal(x, tangent=False)[0]
        a = m.zero_state()
        free = m.free_dofs
        a[free] = spla.spsolve(sp.csc_matrix(m.mass[free][:, free]), (load - f_int)[free])
        return DynamicState(t0, x, v, a, f_int, load.copy(), np.zeros_like(x))

    def step(self, s: DynamicState, dt: float, load: NDArray, depth: int = 0) -> DynamicState:
        """Advance by dt under the window-end load; if Newton fails, retry with halved steps
        (the load then ramps linearly over the sub-steps)."""
        try:
            return self._step(s, dt, load)
        except SolverError:
            if depth >= self.max_halvings:
                raise
            half = self.step(s, dt / 2, 0.5 * (s.f_ext + load), depth + 1)
            return self.step(half, dt / 2, load, depth + 1)

    def _kinematics(self, s: DynamicState, dt: float, x1: NDArray) -> tuple[NDArray, NDArray]:
        p = self.p
        a1 = (x1 - s.x - dt * s.v) / (p.beta * dt * dt) - (1 - 2 * p.beta) / (2 * p.beta) * s.a
        v1 = s.v + dt * ((1 - p.gamma) * s.a + p.gamma * a1)
        return v1, a1

    def _step(self, s: DynamicState, dt: float, load: NDArray) -> DynamicState:
        p, m = self.p, self.model
        c_a = (1 - p.alpha_m) / (p.beta * dt * dt)
        old = p.alpha_f * (s.f_int - s.f_ext) + p.alpha_m * (m.mass @ s.a)

        def residual(x1: NDArray, tangent: bool):
            a1 = self._kinematics(s, dt, x1)[1]
            f_int, K = m.internal(x1, tangent)
            r = (1 - p.alpha_m) * (m.mass @ a1) + (1 - p.alpha_f) * (f_int - load) + old
            if K is None:
                return r, None
            return r, c_a * m.mass + (1 - p.alpha_f) * K

        x1, its = newton(residual, s.x, m, self.settings, f"at t = {s.t + dt:.6g} s")
        self.newton_iterations += its
        v1, a1 = self._kinematics(s, dt, x1)
        f_int = m.internal(x1, tangent=False)[0]
        return DynamicState(s.t + dt, x1, v1, a1, f_int, load.copy(), np.zeros_like(x1))

    def energy(self, s: DynamicState) -> float:
        """Kinetic plus strain energy minus the potential of the current (dead) load (J/m)."""
        m = self.model
        return 0.5 * float(s.v @ (m.mass @ s.v)) + m.strain_energy(s.x) - float(s.f_ext @ s.x)


class StaticFlagIntegrator(FlagIntegrator):
    """Quasi-static "steps": equilibrium f_int(x) = f under the window-end load, no inertia
    (v = a = 0). For steady FSI (Turek & Hron FSI1), where only the end state counts and the
    windows are pseudo-time toward it."""

    def __init__(self, model: PlaneStrainModel, settings: NewtonSettings = DEFAULT_NEWTON):
        super().__init__(model, 1.0, settings)

    def _step(self, s: DynamicState, dt: float, load: NDArray) -> DynamicState:
        m = self.model

        def residual(x1: NDArray, tangent: bool):
            f_int, K = m.internal(x1, tangent)
            return f_int - load, K

        x1, its = newton(residual, s.x, m, self.settings, f"at t = {s.t + dt:.6g} s")
        self.newton_iterations += its
        f_int = m.internal(x1, tangent=False)[0]
        zero = np.zeros_like(x1)
        return DynamicState(s.t + dt, x1, zero, zero.copy(), f_int, load.copy(), zero.copy())


# --------------------------------------------------------------------------- participant


class FlagParticipant:
    """The flag as a coupling participant (implements fsi_orchestrator.participant.Participant).

    Interface: the wetted boundary (bottom, free end, top; the clamped end excluded) as points
    with z = 0 and "line3" cells. Reads "force" (n, 3) nodal forces in N/m and/or "traction"
    (n, 3) in N/m2, z ignored, dead within a window; each read replaces the fields it carries.
    Writes window-end displacement, velocity and acceleration (n, 3) with z = 0. The two
    interface points on the clamp (the first and last) are fixed: loads there go to the support.
    Per unit depth: a 3D solver's forces on a channel of depth d (m) enter as force / d.
    """

    name = "flag"

    def __init__(
        self,
        model: PlaneStrainModel,
        integrator: FlagIntegrator,
        t0: float = 0.0,
        x0: NDArray | None = None,
        v0: NDArray | None = None,
    ) -> None:
        self.model, self.integrator = model, integrator
        n = len(model.mesh.interface_nodes)
        self._force, self._traction = np.zeros((n, DIM)), np.zeros((n, DIM))
        self.state = integrator.initial_state(t0, self.external_load(), x0, v0)
        self._checkpoint: tuple[DynamicState, NDArray, NDArray, int] | None = None

    def external_load(self) -> NDArray:
        """Gravity plus the coupling loads read (N/m per DOF)."""
        return self.model.gravity_load + self.model.interface_load(self._force, self._traction)

    # --------------------------------------------------------------- Participant protocol
    @property
    def time(self) -> float:
        return self.state.t

    def interface(self) -> InterfaceMesh:
        m = self.model.mesh
        xy = m.nodes[m.interface_nodes]
        return InterfaceMesh(
            points=np.column_stack([xy, np.zeros(len(xy))]),
            cells=m.interface_cells.copy(),
            cell_type="line3",
        )

    def read_data(self, data: Mapping[str, NDArray]) -> None:
        if FORCE in data:
            self._force = self._in_plane(data[FORCE], FORCE)
        if TRACTION in data:
            self._traction = self._in_plane(data[TRACTION], TRACTION)

    def _in_plane(self, values: NDArray, field: str) -> NDArray:
        n = len(self.model.mesh.interface_nodes)
        arr = np.asarray(values, dtype=float)
        if arr.shape != (n, 3):
            raise ValueError(f"flag: `{field}` must have shape ({n}, 3), got {arr.shape}")
        return arr[:, :DIM].copy()

    def solve(self, dt: float) -> None:
        if not dt > 0:
            raise ValueError(f"flag: the window size dt must be > 0, got {dt}")
        self.state = self.integrator.step(self.state, dt, self.external_load())

    def write_data(self) -> dict[str, NDArray]:
        s = self.state
        return {
            DISPLACEMENT: self._on_interface(s.x),
            VELOCITY: self._on_interface(s.v),
            ACCELERATION: self._on_interface(s.a),
        }

    def _on_interface(self, field: NDArray) -> NDArray:
        xy = field.reshape(-1, DIM)[self.model.mesh.interface_nodes]
        return np.column_stack([xy, np.zeros(len(xy))])

    def monitor(self) -> dict[str, NDArray | float]:
        """Displacement of point A (middle of the free end) and the Newton count so far."""
        tip = self.state.x.reshape(-1, DIM)[self.model.mesh.tip_node]
        return {
            "tip_displacement_m": np.array([tip[0], tip[1], 0.0]),
            "newton_iterations": float(self.integrator.newton_iterations),
        }

    def store_checkpoint(self) -> None:
        self._checkpoint = self._copies(
            self.state, self._force, self._traction, self.integrator.newton_iterations
        )

    def restore_checkpoint(self) -> None:
        if self._checkpoint is None:
            raise RuntimeError("flag: restore_checkpoint called before store_checkpoint")
        state, force, traction, its = self._copies(*self._checkpoint)
        self.state, self._force, self._traction = state, force, traction
        self.integrator.newton_iterations = its

    @staticmethod
    def _copies(state: DynamicState, force: NDArray, traction: NDArray, its: int) -> tuple:
        return state.copy(), force.copy(), traction.copy(), its

    def save_state(self) -> dict[str, NDArray | float | int]:
        s = self.state
        out: dict[str, NDArray | float | int] = {"t": s.t}
        out |= {k: getattr(s, k).copy() for k in ("x", "v", "a", "f_int", "f_ext")}
        out |= {"force": self._force.copy(), "traction": self._traction.copy()}
        out["newton_iterations"] = self.integrator.newton_iterations
        return out

    def load_state(self, state: State) -> None:
        x, v, a, f_int, f_ext = (
            np.array(state[k], dtype=float) for k in ("x", "v", "a", "f_int", "f_ext")
        )
        self.state = DynamicState(float(state["t"]), x, v, a, f_int, f_ext, np.zeros_like(x))
        self._force = np.array(state["force"], dtype=float)
        self._traction = np.array(state["traction"], dtype=float)
        self.integrator.newton_iterations = int(state["newton_iterations"])

    def finalize(self) -> None:
        pass


# --------------------------------------------------------------------------- factories


def build_flag_model(
    *,
    density_kg_m3: float,
    shear_modulus_pa: float,
    poisson_ratio: float,
    gravity_m_s2: float = 0.0,
    elements: tuple[int, int] = (40, 4),
    geometry: FlagGeometry | None = None,
) -> PlaneStrainModel:
    """The flag's model (default geometry: Turek & Hron with the arc clamp)."""
    geometry = geometry if geometry is not None else FlagGeometry.turek_hron()
    material = SvkMaterial(
        density_kg_m3=density_kg_m3, shear_modulus_pa=shear_modulus_pa, poisson_ratio=poisson_ratio
    )
    return PlaneStrainModel(material, geometry, build_flag_mesh(geometry, elements), gravity_m_s2)


def build_flag_participant(
    *,
    density_kg_m3: float,
    shear_modulus_pa: float,
    poisson_ratio: float,
    gravity_m_s2: float = 0.0,
    elements: tuple[int, int] = (40, 4),
    rho_inf: float = 1.0,
    geometry: FlagGeometry | None = None,
    newton: NewtonSettings = DEFAULT_NEWTON,
    t0: float = 0.0,
    static: bool = False,
) -> FlagParticipant:
    """The flag as a participant, undeformed and at rest at t0 (Turek & Hron's start);
    ``static``: quasi-static windows (StaticFlagIntegrator, ``rho_inf`` unused)."""
    model = build_flag_model(
        density_kg_m3=density_kg_m3,
        shear_modulus_pa=shear_modulus_pa,
        poisson_ratio=poisson_ratio,
        gravity_m_s2=gravity_m_s2,
        elements=elements,
        geometry=geometry,
    )
    integrator = (
        StaticFlagIntegrator(model, newton) if static else FlagIntegrator(model, rho_inf, newton)
    )
    return FlagParticipant(model, integrator, t0)


def solve_csm(
    *,
    density_kg_m3: float,
    shear_modulus_pa: float,
    poisson_ratio: float,
    gravity_m_s2: float,
    elements: tuple[int, int] = (40, 4),
    geometry: FlagGeometry | None = None,
    load_steps: int = 4,
) -> NDArray:
    """Static deflection under gravity (Turek & Hron CSM1/CSM2): displacement (2,) of point A."""
    model = build_flag_model(
        density_kg_m3=density_kg_m3,
        shear_modulus_pa=shear_modulus_pa,
        poisson_ratio=poisson_ratio,
        gravity_m_s2=gravity_m_s2,
        elements=elements,
        geometry=geometry,
    )
    x = solve_static(model, model.gravity_load, load_steps)
    return x.reshape(-1, DIM)[model.mesh.tip_node].copy()
