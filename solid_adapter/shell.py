"""Geometrically exact 5-parameter Reissner-Mindlin shell of a flat laminate (total Lagrangian).

Kinematics (reference plate z = 0, in-plane coordinates X_alpha, nodal unknowns u (3) and the
rotation vector theta (2) of the director d = R(theta) e3, see director.py):

    a_alpha = e_alpha + u_,alpha
    membrane  E_ab = (a_a . a_b - delta_ab) / 2
    bending   K_ab = (a_a . d_,b + a_b . d_,a) / 2
    shear     g_a  = a_a . d

Directors are interpolated from nodal directors, so the strains are exact quadratic forms in the
nodal "q" unknowns (u, d): their second derivatives are constant, and the geometric stiffness is
a few scalar products of shape-function gradients. The chain rule d -> theta is applied per node.

Energy per unit area with the laminate resultant law [N; M] = [[A, B], [B, D]] [e; k] about the
piezo stress-free state (e = E - E0(V), k = K - K0(V), see materials.py) is split so that each
part is positive and locking-free with 9-node quads:

    W = 1/2 (e + G k)^T A (e + G k)   (2 x 2 Gauss: membrane, coupling; G = A^-1 B)
      + 1/2 g^T S g                   (2 x 2 Gauss: transverse shear)
      + 1/2 k^T (D - B A^-1 B) k      (3 x 3 Gauss: bending)

Reduced integration of membrane and shear is what removes membrane and shear locking at large
rotation (see shared/notes/scikit-fem-shell.md); bending keeps the full rule so that no
spurious bending mechanisms appear.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, Protocol, overload

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from .director import director
from .geometry import PlateLayout
from .materials import Section
from .mesh import PlateMesh, QuadratureData

MIP = True
STABILISATION = 1e-3  # share of membrane/shear energy integrated with the full rule
NDOF = 5  # u_x, u_y, u_z, theta_1, theta_2 per node
# Director derivative at theta = 0: d' = (theta2, -theta1, 0).
J_REFERENCE = np.array([[0.0, 1.0], [-1.0, 0.0], [0.0, 0.0]])


class StrainRate:
    """A Kelvin-Voigt damping stress beta C eps_dot within one time step, with the strain rate
    of the step, eps_dot = (eps(x) - eps(x_n)) / dt: ``coefficient`` = beta / dt and
    ``reference`` = x_n. The stress is a function of x alone, so the internal force and its
    tangent (material and geometric) stay exact, and like the strains it is blind to rigid
    rotation. beta K_mat(x) v instead has a tangent that misses d K_mat / dx v, and on thin
    plates (CFRP 0.1-0.2 mm) Newton then converges linearly or diverges."""

    def __init__(self, coefficient: float, reference: NDArray) -> None:
        self.coefficient, self.reference = coefficient, reference
        self._strains: tuple[tuple[float, ...], list[NDArray]] | None = None

    def reference_strains(self, model: ShellModel, volts: NDArray) -> list[NDArray]:
        """The energy parts' strains at x_n under ``volts`` (the actuation's free strain then
        drops out of the difference), computed once per voltage."""
        key = tuple(np.asarray(volts, dtype=float).ravel())
        if self._strains is None or self._strains[0] != key:
            self._strains = (key, model.part_strains(self.reference, volts))
        return self._strains[1]


@dataclass(frozen=True)
class SectionField:
    """Laminate data at every quadrature point of one rule."""

    A: NDArray  # (nel, nqp, 3, 3)
    G: NDArray  # A^-1 B
    Dstar: NDArray  # D - B A^-1 B
    S: NDArray  # (nel, nqp, 2, 2)
    rho: NDArray  # (nel, nqp, 3)
    free_per_volt: NDArray  # (nel, nqp, 2 sides, 6): stress-free [E0; K0] per volt

    @classmethod
    def build(cls, sections: tuple[Section, ...], codes: NDArray) -> SectionField:
        A = np.array([s.A for s in sections])
        B = np.array([s.B for s in sections])
        D = np.array([s.D for s in sections])
        G = np.linalg.solve(A, B)
        return cls(
            A=A[codes],
            G=G[codes],
            Dstar=(D - B @ G)[codes],
            S=np.array([s.S for s in sections])[codes],
            rho=np.array([s.rho for s in sections])[codes],
            free_per_volt=np.array([s.free_deformation_per_volt for s in sections])[codes],
        )

    def free_deformation(self, volts: NDArray) -> tuple[NDArray, NDArray]:
        """Stress-free membrane strain and curvature (nel, nqp, 3) for [V_left, V_right]."""
        f = np.einsum("eqsk,s->eqk", self.free_per_volt, volts)
        return f[..., :3], f[..., 3:]


class SparsePattern:
    """Assembly of element matrices into one fixed CSR pattern with bincount (no COO sort)."""

    def __init__(self, element_dofs: NDArray, ndof: int) -> None:
        nel, k = element_dofs.shape
        rows = np.repeat(element_dofs, k, axis=1).ravel()
        cols = np.tile(element_dofs, (1, k)).ravel()
        keys = rows.astype(np.int64) * ndof + cols
        unique, self.inverse = np.unique(keys, return_inverse=True)
        self.indices = (unique % ndof).astype(np.int32)
        counts = np.bincount(unique // ndof, minlength=ndof)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.ndof, self.nnz = ndof, len(unique)
        self.rows_of_data = np.repeat(np.arange(ndof), counts)

    def assemble(self, element_matrices: NDArray) -> sp.csr_matrix:
        data = np.bincount(self.inverse, weights=element_matrices.ravel(), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.ndof, self.ndof))


class ShellModel:
    """Shell discretisation of one plate: internal forces, tangent, mass, load vectors."""

    def __init__(
        self, layout: PlateLayout, mesh: PlateMesh, stabilisation: float = STABILISATION
    ) -> None:
        self.layout, self.mesh = layout, mesh
        self.stabilisation = stabilisation
        self.n_nodes = mesh.n_nodes
        self.ndof = NDOF * self.n_nodes
        self.enodes = mesh.element_nodes  # (nel, 9)
        self.edofs = (self.enodes[:, :, None] * NDOF + np.arange(NDOF)).reshape(
            len(self.enodes), -1
        )
        self.pattern = SparsePattern(self.edofs, self.ndof)
        self.sec_full = SectionField.build(
            layout.sections, layout.region(mesh.full.points[..., 0], mesh.full.points[..., 1])
        )
        self.sec_reduced = SectionField.build(
            layout.sections, layout.region(mesh.reduced.points[..., 0], mesh.reduced.points[..., 1])
        )
        self.fixed_nodes = (
            np.flatnonzero(mesh.nodes[:, 0] <= layout.clamp_x_m + 1e-12)
            if layout.clamp_x_m is not None
            else np.array([], dtype=int)
        )
        fixed = np.zeros(self.ndof, dtype=bool)
        fixed[(self.fixed_nodes[:, None] * NDOF + np.arange(NDOF)).ravel()] = True
        if layout.pin_x_m is not None:  # a hinge: the line's translations, not its turning
            pinned = np.flatnonzero(
                np.abs(mesh.nodes[:, 0] - layout.pin_x_m) <= 1e-9 * max(layout.length_m, 1.0)
            )
            if len(pinned) < 2:  # the mesh puts a column of nodes on every breakpoint
                raise ValueError(f"no column of shell nodes on the hinge x = {layout.pin_x_m} m")
            fixed[(pinned[:, None] * NDOF + np.arange(3)).ravel()] = True
        self.fixed_dofs = fixed
        self.free_dofs = ~fixed
        self.reference_points = np.column_stack([mesh.nodes, np.zeros(self.n_nodes)])
        self.area_matrix = self._scalar_mass(np.ones_like(mesh.full.weights))
        self.support = self._support_springs()
        self.mass = self._mass_matrix()
        # a fluid's added mass in the inertia (in partitioned *-am coupling the integrator
        # takes it as part of the exchanged force: solvers.AddedMassAsForce)
        self.added_mass: sp.csr_matrix | None = None
        self.inertia = self.mass  # structural mass plus any fluid added mass
        # a fast fluid's damping (force(model, x, v), linear(model, orbit)) beside its added
        # mass: the edge drag of fluid_adapter.drag; None: none
        self.fluid_damping: Damping | None = None
        # seed-stress drive (seed Sec. 3.5.2.1): eq. 3-10's stress applied as dead loads, the
        # internal force of the flat plate under each actuator's unit voltage (2, ndof);
        # None: the induced strain (eigenstrain) of the MFC layers
        self.dead_drive_per_volt: NDArray | None = None
        if layout.drive_model == "seed-stress":
            zero = self.zero_state()
            self.dead_drive_per_volt = np.array(
                [self._internal(zero, np.eye(2)[s], tangent=False)[0] for s in range(2)]
            )

    def set_added_mass(self, matrix_z: NDArray | None) -> None:
        """Add a fluid added-mass operator acting on the nodal normal (z) accelerations
        (n_nodes x n_nodes, dense) to the inertia; None removes it."""
        if matrix_z is None:
            self.added_mass, self.inertia = None, self.mass
            return
        rows = np.arange(self.n_nodes) * NDOF + 2
        coo = sp.coo_matrix(matrix_z)
        self.added_mass = sp.csr_matrix(
            (coo.data, (rows[coo.row], rows[coo.col])), shape=(self.ndof, self.ndof)
        )
        self.inertia = sp.csr_matrix(self.mass + self.added_mass)

    # ------------------------------------------------------------------ state helpers
    def zero_state(self) -> NDArray:
        return np.zeros(self.ndof)

    def nodal(self, x: NDArray) -> NDArray:
        return x.reshape(self.n_nodes, NDOF)

    def displacement(self, x: NDArray) -> NDArray:
        return self.nodal(x)[:, :3]

    def directors(self, x: NDArray) -> NDArray:
        return director(self.nodal(x)[:, 3:])[0]

    # ------------------------------------------------------------------ internal forces
    @overload
    def internal(
        self,
        x: NDArray,
        volts: NDArray,
        tangent: Literal[True] = True,
        mixed: list[NDArray] | None = None,
        rate: StrainRate | None = None,
    ) -> tuple[NDArray, sp.csr_matrix, Linearization]: ...

    @overload
    def internal(
        self,
        x: NDArray,
        volts: NDArray,
        tangent: bool,
        mixed: list[NDArray] | None = None,
        rate: StrainRate | None = None,
    ) -> tuple[NDArray, sp.csr_matrix | None, Linearization | None]: ...

    def internal(
        self,
        x: NDArray,
        volts: NDArray,
        tangent: bool = True,
        mixed: list[NDArray] | None = None,
        rate: StrainRate | None = None,
    ) -> tuple[NDArray, sp.csr_matrix | None, Linearization | None]:
        """Internal force, tangent stiffness and the linearization at state x.

        ``mixed``: stresses (one array per energy part) to build the geometric part of the
        tangent with instead of the stresses of x (mixed-integration-point Newton, see
        :class:`MixedNewtonInternal`). The force always uses the stresses of x. With the
        seed-stress drive the voltages enter as dead loads (minus the applied force).
        ``rate``: add the strain-rate (Kelvin-Voigt) damping of a time step to the stresses.
        """
        dead = self.dead_drive_per_volt
        own = volts if dead is None else np.zeros(2)
        r, K, lin = self._internal(x, own, tangent, mixed, rate)
        if dead is not None:
            r = r + np.asarray(volts) @ dead
        if self.support is not None:
            r = r + self.support @ x
            K = K + self.support if K is not None else None
        return r, K, lin

    def _support_springs(self) -> sp.csr_matrix | None:
        """Diagonal springs on u_x, u_y, u_z of the held region's nodes (elastic head
        support), the total stiffness spread by lumped nodal area."""
        if self.layout.support_x_m is None:
            return None
        held = self.mesh.nodes[:, 0] <= self.layout.support_x_m + 1e-12
        area = np.asarray(self.area_matrix.sum(axis=1)).ravel() * held
        k = np.zeros((self.n_nodes, NDOF))
        k[:, :3] = (self.layout.support_stiffness_n_per_m * area / area.sum())[:, None]
        return sp.diags(k.ravel()).tocsr()

    def _internal(
        self,
        x: NDArray,
        volts: NDArray,
        tangent: bool = True,
        mixed: list[NDArray] | None = None,
        rate: StrainRate | None = None,
    ) -> tuple[NDArray, sp.csr_matrix | None, Linearization | None]:
        X = self.nodal(x)
        d, J, H = director(X[:, 3:])
        ue, de = X[self.enodes, :3], d[self.enodes]
        parts = self._parts(ue, de, volts)
        if rate is not None:
            reference = rate.reference_strains(self, volts)
            parts = [
                p.with_rate(rate.coefficient, ref) for p, ref in zip(parts, reference, strict=True)
            ]
        fq = sum((p.force() for p in parts), start=np.zeros(())).reshape(-1, 9, 6)
        nel = len(self.enodes)
        Je = np.zeros((nel, 9, 6, NDOF))
        Je[:, :, 0, 0] = Je[:, :, 1, 1] = Je[:, :, 2, 2] = 1.0
        Je[:, :, 3:, 3:] = J[self.enodes]
        fx = np.einsum("eaic,eai->eac", Je, fq).reshape(-1)
        r = np.bincount(self.edofs.ravel(), weights=fx, minlength=self.ndof)
        if not tangent:
            return r, None, None
        sig = mixed if mixed is not None else [p.sigma for p in parts]
        Kq = sum(
            p.material_tangent() + p.geometric_tangent(s) for p, s in zip(parts, sig, strict=True)
        )
        Jb = _block_diag(Je)  # (nel, 54, 45)
        Kx = np.transpose(Jb, (0, 2, 1)) @ Kq @ Jb
        K = self.pattern.assemble(Kx)
        # chain rule d(theta): (dPi/dd_a) . d2d/dtheta2 per node, with the same stresses
        fq_geo = (
            fq
            if mixed is None
            else sum(
                (p.force(s) for p, s in zip(parts, sig, strict=True)), start=np.zeros(())
            ).reshape(-1, 9, 6)
        )
        rq_d = np.zeros((self.n_nodes, 3))
        np.add.at(rq_d, self.enodes.ravel(), fq_geo[:, :, 3:].reshape(-1, 3))
        Hn = np.einsum("ni,nijk->njk", rq_d, H)
        K = K + sp.csr_matrix(
            (
                Hn.ravel(),
                (
                    np.broadcast_to(self._h_rows, Hn.shape).ravel(),
                    np.broadcast_to(self._h_cols, Hn.shape).ravel(),
                ),
            ),
            shape=K.shape,
        )
        return r, K, Linearization(parts, J, self.enodes)

    def material_stiffness(self, x: NDArray) -> sp.csr_matrix:
        """The material part of the tangent at x (B^T C B, no stress terms): the objective
        stiffness a strain-rate (Kelvin-Voigt) damping uses."""
        X = self.nodal(x)
        d, J, _ = director(X[:, 3:])
        parts = self._parts(X[self.enodes, :3], d[self.enodes], np.zeros(2))
        Kq = sum(p.material_tangent() for p in parts)
        Je = np.zeros((len(self.enodes), 9, 6, NDOF))
        Je[:, :, 0, 0] = Je[:, :, 1, 1] = Je[:, :, 2, 2] = 1.0
        Je[:, :, 3:, 3:] = J[self.enodes]
        Jb = _block_diag(Je)
        return self.pattern.assemble(np.transpose(Jb, (0, 2, 1)) @ Kq @ Jb)

    @property
    def _h_rows(self) -> NDArray:
        return np.arange(self.n_nodes)[:, None, None] * NDOF + 3 + np.arange(2)[None, :, None]

    @property
    def _h_cols(self) -> NDArray:
        return np.arange(self.n_nodes)[:, None, None] * NDOF + 3 + np.arange(2)[None, None, :]

    def _parts(self, ue, de, volts, with_b: bool = True) -> list[EnergyPart]:
        """Membrane-coupling-shear energy at 2 x 2 points (plus a share STABILISATION at 3 x 3
        points, which removes the spurious zero-energy modes of the 2 x 2 rule: 3 in-plane and
        1 out-of-plane on a free plate, at a locking cost far below 0.1 %), and bending at
        3 x 3 points."""
        eps = self.stabilisation
        reduced, full = self.mesh.reduced, self.mesh.full
        kin_r, kin_f = _kinematics(reduced, ue, de), _kinematics(full, ue, de)
        B_r = _b_matrices(reduced, kin_r) if with_b else None
        B_f = _b_matrices(full, kin_f) if with_b else None
        parts = [_membrane_shear_part(reduced, self.sec_reduced, 1.0 - eps, kin_r, B_r, volts)]
        if eps > 0:
            parts.append(_membrane_shear_part(full, self.sec_full, eps, kin_f, B_f, volts))
        parts.append(_bending_part(full, self.sec_full, kin_f, B_f, volts))
        return parts

    def part_strains(self, x: NDArray, volts: NDArray) -> list[NDArray]:
        """The strain measures of each energy part at x (no B matrices)."""
        X = self.nodal(x)
        d = director(X[:, 3:])[0]
        return [p.strain for p in self._parts(X[self.enodes, :3], d[self.enodes], volts, False)]

    def strain_energy(self, x: NDArray, volts: NDArray) -> float:
        """Stored energy, integrated exactly as the internal forces are."""
        X = self.nodal(x)
        d = director(X[:, 3:])[0]
        dead = self.dead_drive_per_volt
        own = volts if dead is None else np.zeros(2)
        parts = self._parts(X[self.enodes, :3], d[self.enodes], own, with_b=False)
        energy = float(sum(p.energy() for p in parts))
        if dead is not None:
            energy += float(np.asarray(volts) @ dead @ x)
        if self.support is not None:
            energy += 0.5 * float(x @ (self.support @ x))
        return energy

    # ------------------------------------------------------------------ mass and loads
    def _scalar_mass(self, density: NDArray, q: QuadratureData | None = None) -> sp.csr_matrix:
        """Node-by-node matrix int density N_a N_b dA (n_nodes x n_nodes)."""
        q = q if q is not None else self.mesh.full
        Me = np.einsum("eq,eq,eqa,eqb->eab", q.weights, density, q.N, q.N)
        rows = np.repeat(self.enodes, 9, axis=1).ravel()
        cols = np.tile(self.enodes, (1, 9)).ravel()
        return sp.csr_matrix((Me.ravel(), (rows, cols)), shape=(self.n_nodes, self.n_nodes))

    def _mass_matrix(self) -> sp.csr_matrix:
        """Constant consistent mass: translation rho0, coupling rho1, rotary inertia rho2,
        with the director velocity linearised at the reference (d' = J_REFERENCE theta')."""
        rho = self._dense_density()
        m0, m1, m2 = (self._scalar_mass(rho[..., k], self.mesh.dense) for k in range(3))
        T = np.zeros((6, NDOF))
        T[:3, :3] = np.eye(3)
        T[3:, 3:] = J_REFERENCE
        eye3 = np.eye(3)
        blocks = np.zeros((3, 6, 6))
        blocks[0, :3, :3] = eye3
        blocks[1, :3, 3:] = eye3
        blocks[1, 3:, :3] = eye3
        blocks[2, 3:, 3:] = eye3
        M = sum(sp.kron(m, sp.csr_matrix(T.T @ blocks[k] @ T)) for k, m in enumerate((m0, m1, m2)))
        return sp.csr_matrix(M)

    def _dense_density(self) -> NDArray:
        pts = self.mesh.dense.points
        codes = self.layout.region(pts[..., 0], pts[..., 1])
        return np.array([s.rho for s in self.layout.sections])[codes]

    def total_mass_kg(self) -> float:
        return float(np.sum(self._dense_density()[..., 0] * self.mesh.dense.weights))

    def edge_load(self, x_edge: float, force_z_n: float = 0.0, moment_nm: float = 0.0) -> NDArray:
        """Generalised load of a total force along +z and a total moment about the width axis
        (positive bends toward +z) spread uniformly over the edge at ``x_edge``."""
        idx, w = self.mesh.edge_weights(x_edge)
        f = np.zeros(self.ndof)
        f[idx * NDOF + 2] += force_z_n * w
        # bending toward +z rotates the director toward -x: theta_2 < 0
        f[idx * NDOF + 4] -= moment_nm * w
        return f

    def nodal_force_load(self, forces: NDArray) -> NDArray:
        """Generalised load of dead nodal forces (n, 3) on the translations."""
        f = np.zeros((self.n_nodes, NDOF))
        f[:, :3] = forces
        return f.ravel()

    def pressure_load(
        self, x: NDArray, pressure: NDArray, tangent: bool = True
    ) -> tuple[NDArray, sp.csr_matrix | None]:
        """Follower pressure p (nodal values, Pa) acting along a_1 x a_2 (the current +z-side
        normal times the area change): load vector and its derivative dF/dx."""
        q = self.mesh.full
        X = self.nodal(x)
        ue = X[self.enodes, :3]
        a = _tangents(q, ue)
        pq = np.einsum("eqa,ea->eq", q.N, pressure[self.enodes])
        n = np.cross(a[..., 0, :], a[..., 1, :])
        fe = np.einsum("eq,eq,eqa,eqi->eai", q.weights, pq, q.N, n)
        F = np.zeros((self.n_nodes, NDOF))
        np.add.at(F[:, :3], self.enodes.ravel(), fe.reshape(-1, 3))
        if not tangent:
            return F.ravel(), None
        # d(a1 x a2)/du_b = dN_b1 (e_k x a2) + dN_b2 (a1 x e_k)
        skew1, skew0 = _skew(a[..., 1, :]), _skew(a[..., 0, :])
        dn = np.einsum("eqb,eqij->eqbij", q.dN[..., 0], -skew1) + np.einsum(
            "eqb,eqij->eqbij", q.dN[..., 1], skew0
        )
        Ke = np.einsum("eq,eq,eqa,eqbij->eaibj", q.weights, pq, q.N, dn)
        Kx = np.zeros((len(self.enodes), 9, NDOF, 9, NDOF))
        Kx[:, :, :3, :, :3] = Ke
        return F.ravel(), self.pattern.assemble(Kx.reshape(len(self.enodes), 45, 45))


@dataclass(frozen=True)
class _Kinematics:
    a: NDArray  # (nel, nqp, 2, 3)
    d: NDArray  # (nel, nqp, 3)
    gd: NDArray  # (nel, nqp, 2, 3)
    N: NDArray
    dN: NDArray

    @property
    def eps(self) -> NDArray:
        a0, a1 = self.a[..., 0, :], self.a[..., 1, :]
        return np.stack(
            [0.5 * (np.sum(a0 * a0, -1) - 1), 0.5 * (np.sum(a1 * a1, -1) - 1), np.sum(a0 * a1, -1)],
            axis=-1,
        )

    @property
    def kap(self) -> NDArray:
        a0, a1 = self.a[..., 0, :], self.a[..., 1, :]
        g0, g1 = self.gd[..., 0, :], self.gd[..., 1, :]
        return np.stack(
            [np.sum(a0 * g0, -1), np.sum(a1 * g1, -1), np.sum(a0 * g1, -1) + np.sum(a1 * g0, -1)],
            axis=-1,
        )

    @property
    def gam(self) -> NDArray:
        return np.einsum("eqai,eqi->eqa", self.a, self.d)


class Damping(Protocol):
    """A damping force on the structure (solvers: Rayleigh, structural; the fast fluid's edge
    drag, fluid_adapter.drag.EdgeDrag)."""

    @property
    def amplitude_dependent(self) -> bool: ...

    def force(self, model: ShellModel, x: NDArray, v: NDArray) -> tuple[NDArray, sp.spmatrix]: ...

    def linear(self, model: ShellModel, orbit: Any = None) -> sp.spmatrix: ...


# the stresses C s -> the conjugates of the raw strains (membrane N, bending M, shear Q)
RawStresses = Callable[[NDArray], tuple[NDArray | None, NDArray, NDArray | None]]


class EnergyPart:
    """One quadratic energy 1/2 s^T C s of strain measures s at the points of one rule, with
    ds/dq = B (q: element nodal u and d). ``raw`` maps stresses C s to the conjugates of the raw
    strains (membrane, bending, shear) the geometric stiffness is built from."""

    def __init__(
        self,
        q: QuadratureData,
        weights: NDArray,
        C: NDArray,
        strain: NDArray,
        B: NDArray | None,
        raw: RawStresses,
    ) -> None:
        self.q, self.w, self.C, self.strain, self.B, self.raw = q, weights, C, strain, B, raw
        self.sigma = np.einsum("eqij,eqj->eqi", C, strain)

    def energy(self) -> float:
        return 0.5 * float(np.einsum("eq,eqi,eqi->", self.w, self.sigma, self.strain))

    def with_rate(self, c: float, reference: NDArray) -> EnergyPart:
        """This part with the damping stress c C (s - s_ref) added (see StrainRate): stress
        C (s + c (s - s_ref)), material tangent (1 + c) B^T C B."""
        strain = (self.strain + c * (self.strain - reference)) / (1.0 + c)
        return EnergyPart(self.q, self.w, (1.0 + c) * self.C, strain, self.B, self.raw)

    @property
    def ds_dq(self) -> NDArray:
        assert self.B is not None, "a part built for its energy only has no ds/dq"
        return self.B

    def force(self, sigma: NDArray | None = None) -> NDArray:
        s = self.sigma if sigma is None else sigma
        return np.einsum("eq,eqkm,eqk->em", self.w, self.ds_dq, s)

    def material_tangent(self) -> NDArray:
        B = self.ds_dq
        return np.einsum("eq,eqkm,eqkl,eqln->emn", self.w, B, self.C, B, optimize=True)

    def geometric_tangent(self, sigma: NDArray) -> NDArray:
        return _geometric(self.q, *self.raw(sigma), self.w)

    def predict(self, dq_e: NDArray) -> NDArray:
        """Stresses of the linearized strain s + B dq."""
        return np.einsum(
            "eqij,eqj->eqi", self.C, self.strain + np.einsum("eqkm,em->eqk", self.ds_dq, dq_e)
        )


class Linearization:
    """The energy parts at a state, able to predict their stresses for an increment dx."""

    def __init__(self, parts: list[EnergyPart], J: NDArray, enodes: NDArray) -> None:
        self.parts, self.J, self.enodes = parts, J, enodes

    def predict(self, dx: NDArray) -> list[NDArray]:
        D = dx.reshape(-1, NDOF)
        dq = np.concatenate([D[:, :3], np.einsum("nij,nj->ni", self.J, D[:, 3:])], axis=1)
        dq_e = dq[self.enodes].reshape(len(self.enodes), 54)
        return [p.predict(dq_e) for p in self.parts]


class MixedNewtonInternal:
    """``internal`` for one Newton solve, building each tangent with the stresses predicted
    linearly from the previous tangent's state instead of the stresses of the current state:
    the mixed-integration-point (MIP) Newton of Magisano, Leonetti & Garcea (IJNME 2017). It
    converges to the same solution; thin shells at large rotation steps need far fewer
    iterations because the spurious membrane/shear stress spike of the first iterates never
    enters the geometric stiffness."""

    def __init__(self, model: ShellModel, rate: StrainRate | None = None) -> None:
        self.model, self.rate = model, rate
        self.last: tuple[NDArray, Linearization] | None = None

    def __call__(
        self, x: NDArray, volts: NDArray, tangent: bool = True
    ) -> tuple[NDArray, sp.csr_matrix | None]:
        if not tangent:
            return self.model.internal(x, volts, False, rate=self.rate)[:2]
        mixed = self.last[1].predict(x - self.last[0]) if (self.last is not None and MIP) else None
        r, K, lin = self.model.internal(x, volts, True, mixed, self.rate)
        assert lin is not None
        self.last = (x.copy(), lin)
        return r, K


def _membrane_shear_part(
    q, sec: SectionField, factor: float, kin: _Kinematics, B, volts
) -> EnergyPart:
    E0, K0 = sec.free_deformation(volts)
    m = kin.eps - E0 + np.einsum("eqij,eqj->eqi", sec.G, kin.kap - K0)
    strain = np.concatenate([m, kin.gam], axis=-1)
    C = np.zeros((*m.shape[:2], 5, 5))
    C[..., :3, :3] = sec.A
    C[..., 3:, 3:] = sec.S
    Bp = None
    if B is not None:
        Bm, Bb, Bs = B
        Bp = np.concatenate([Bm + sec.G @ Bb, Bs], axis=2)
    G = sec.G

    def raw(sigma: NDArray) -> tuple[NDArray | None, NDArray, NDArray | None]:
        N = sigma[..., :3]
        return N, np.einsum("eqji,eqj->eqi", G, N), sigma[..., 3:]

    return EnergyPart(q, factor * q.weights, C, strain, Bp, raw)


def _bending_part(q, sec: SectionField, kin: _Kinematics, B, volts) -> EnergyPart:
    _, K0 = sec.free_deformation(volts)
    return EnergyPart(
        q,
        q.weights,
        sec.Dstar,
        kin.kap - K0,
        B[1] if B is not None else None,
        lambda sigma: (None, sigma, None),
    )


def _tangents(q: QuadratureData, ue: NDArray) -> NDArray:
    a = np.einsum("eqba,ebi->eqai", q.dN, ue)
    a[..., 0, 0] += 1.0
    a[..., 1, 1] += 1.0
    return a


def _kinematics(q: QuadratureData, ue: NDArray, de: NDArray) -> _Kinematics:
    return _Kinematics(
        a=_tangents(q, ue),
        d=np.einsum("eqb,ebi->eqi", q.N, de),
        gd=np.einsum("eqba,ebi->eqai", q.dN, de),
        N=q.N,
        dN=q.dN,
    )


def _b_matrices(q: QuadratureData, kin: _Kinematics) -> tuple[NDArray, NDArray, NDArray]:
    """Strain derivatives w.r.t. the element q unknowns (9 nodes x [u, d]), shape
    (nel, nqp, ncomp, 54)."""
    nel, nqp = q.weights.shape
    dN0, dN1 = q.dN[..., 0][..., None], q.dN[..., 1][..., None]  # (nel, nqp, 9, 1)
    a0, a1 = kin.a[..., None, 0, :], kin.a[..., None, 1, :]  # (nel, nqp, 1, 3)
    g0, g1 = kin.gd[..., None, 0, :], kin.gd[..., None, 1, :]
    Bb: NDArray = np.zeros((nel, nqp, 3, 9, 6))
    Bb[..., 0, :, :3] = dN0 * g0
    Bb[..., 0, :, 3:] = dN0 * a0
    Bb[..., 1, :, :3] = dN1 * g1
    Bb[..., 1, :, 3:] = dN1 * a1
    Bb[..., 2, :, :3] = dN0 * g1 + dN1 * g0
    Bb[..., 2, :, 3:] = dN1 * a0 + dN0 * a1
    Bb = Bb.reshape(nel, nqp, 3, 54)
    Bm = np.zeros((nel, nqp, 3, 9, 6))
    Bm[..., 0, :, :3] = dN0 * a0
    Bm[..., 1, :, :3] = dN1 * a1
    Bm[..., 2, :, :3] = dN0 * a1 + dN1 * a0
    Bs = np.zeros((nel, nqp, 2, 9, 6))
    d = kin.d[..., None, :]
    Nn = q.N[..., None]
    Bs[..., 0, :, :3] = dN0 * d
    Bs[..., 0, :, 3:] = Nn * a0
    Bs[..., 1, :, :3] = dN1 * d
    Bs[..., 1, :, 3:] = Nn * a1
    return Bm.reshape(nel, nqp, 3, 54), Bb, Bs.reshape(nel, nqp, 2, 54)


def _voigt_tensor(v: NDArray) -> NDArray:
    """[v11, v22, v12] -> symmetric 2 x 2."""
    return np.stack(
        [np.stack([v[..., 0], v[..., 2]], -1), np.stack([v[..., 2], v[..., 1]], -1)], -2
    )


def _geometric(
    q: QuadratureData, N: NDArray | None, M: NDArray, Q: NDArray | None, w: NDArray
) -> NDArray:
    """Stress resultants times the (constant) second derivatives of the strains, integrated
    with weights w: (nel, 54, 54)."""
    nel = len(w)
    K = np.zeros((nel, 9, 6, 9, 6))
    eye = np.eye(3)
    Gud = np.einsum("eq,eqai,eqij,eqbj->eab", w, q.dN, _voigt_tensor(M), q.dN)
    if Q is not None:
        Gud += np.einsum("eq,eqai,eqi,eqb->eab", w, q.dN, Q, q.N)
    K[:, :, :3, :, 3:] = Gud[:, :, None, :, None] * eye[None, None, :, None, :]
    K[:, :, 3:, :, :3] = (
        np.transpose(Gud, (0, 2, 1))[:, :, None, :, None] * eye[None, None, :, None, :]
    )
    if N is not None:
        Guu = np.einsum("eq,eqai,eqij,eqbj->eab", w, q.dN, _voigt_tensor(N), q.dN)
        K[:, :, :3, :, :3] = Guu[:, :, None, :, None] * eye[None, None, :, None, :]
    return K.reshape(nel, 54, 54)


def _block_diag(Je: NDArray) -> NDArray:
    """(nel, 9, 6, 5) nodal Jacobians -> (nel, 54, 45) block-diagonal element Jacobian."""
    nel = len(Je)
    out = np.zeros((nel, 9, 6, 9, NDOF))
    idx = np.arange(9)
    out[:, idx, :, idx, :] = np.transpose(Je, (1, 0, 2, 3))
    return out.reshape(nel, 54, 9 * NDOF)


def _skew(v: NDArray) -> NDArray:
    """[v]_x such that [v]_x w = v x w."""
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )
