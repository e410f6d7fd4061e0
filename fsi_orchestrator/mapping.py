"""Mapping between the shell mid-surface nodes and the fluid's interface points.

The two point clouds sample the same (initially flat) plate but do not match: the structure gives
the mid-surface nodes of its 9-node quads (z = 0), the fluid gives patch points on both faces of
the plate (z = +-h/2), on a zero-thickness baffle (z = 0) or on both sides of a potential-flow
surface. Both are mapped in the plate plane: only (x, y) enter, so the two faces of the plate get
the same row and move together.

Method: radial basis functions with a partition of unity (RBF-PU), the local variant of preCICE's
Wendland-RBF mapping (``rbf-pum-direct``, precice/precice PR #1483; Wendland, "Fast evaluation of
radial basis functions: methods based on partition of unity", Approximation Theory X, 2002).
Every structure node i is the centre of a patch of radius R_i (the distance to its ``neighbors``-th
nearest node, so the radius follows the local node spacing; or one given ``support_radius``). On
patch i the members x_j (nodes within R_i) carry a local interpolant with a linear polynomial

    s_i(x) = sum_j a_j phi(|x - x_j| / R_i) + b0 + b1 x + b2 y,   s_i(x_j) = f_j,
    sum_j a_j = sum_j a_j x_j = sum_j a_j y_j = 0,

with the Wendland C2 function phi(r) = (1 - r)^4 (4 r + 1) for r < 1, else 0 (preCICE's
``compact-polynomial-c2``; Wendland, Adv. Comput. Math. 4, 1995). The patches are blended with
Wendland weights w_i(x) = phi(|x - x_i| / R_i) / sum_k phi(|x - x_k| / R_k):

    f(x) = sum_i w_i(x) s_i(x)   ->   f_target = H f_source,   H sparse (n_target, n_source).

Why not one global RBF system: its inverse is dense, so H would be dense (applying a dense
5000 x 481 H to (n, 3) data costs 2-7 ms on the 2-core machine, against about 0.2 ms for this
sparse one; ``benchmarks/mapping_cost.py``). The partition of unity keeps H sparse (about 25
entries per row with the default 8 neighbours) and continuous: the blending weights vanish
smoothly at the patch edges, so neighbouring fluid points never see a jump.

Properties (tests in ``tests/test_mapping.py``):

- Consistent (displacement, structure -> fluid): every s_i reproduces linear fields and the
  weights sum to one, so constant and linear fields are mapped exactly (to rounding).
- Conservative (forces, fluid -> structure): F_source = H^T F_target. Since the rows of H
  reproduce 1, x and y, sum F_source = sum F_target and sum x F_source = sum x F_target (same
  for y): total force and moment are preserved with in-plane arms, and the virtual work of the
  two sides agrees, <H u, F> = <u, H^T F>.
- Accuracy: O(h^2) for smooth fields (fitted rate 2.07 for a quadratic field on five refined
  grids), max error about 0.2 h^2 max|D^2 f| with h the largest node spacing; 5e-4 of the tail
  value for a bending shape on the default fish mesh.

Thickness (the O(h/2) arms): the fluid faces lie at z = +-h/2 but are mapped with their (x, y)
only. (1) Moments: the true moment of the fluid forces about a point also holds
e_z x sum_t z_t F_t, which is not carried to the mid-surface. Only tangential forces contribute
(pressure on the flat plate is along z), and only through the difference of the two faces,
(h/2) (sum_top F_xy - sum_bottom F_xy): at most (h/2) |F_shear| = 0.4 mm times the shear force
for the 0.8 mm laminate. (2) Displacements: both faces get the mid-surface displacement; the
in-plane slide -+(h/2) theta of the faces of a bent plate (theta the slope) is not mapped. A
fluid adapter that needs it adds z (d - e_z) from the shell's directors d.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.spatial import cKDTree

from .participant import InterfaceMesh

DEFAULT_NEIGHBORS = 8  # patch radius: distance to the 8th nearest other structure node
_MIN_ASPECT = 1e-2  # smallest/largest principal second moment of a patch before it is grown
_GROWTH = 1.25  # radius factor applied to a degenerate (near-collinear) patch
_MAX_GROWTHS = 20


class MappingError(ValueError):
    """The point clouds cannot be mapped (bad shapes, duplicate nodes, uncovered points)."""


def wendland_c2(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wendland C2 function (1 - r)^4 (4 r + 1) of the scaled distance r, zero for r >= 1."""
    s = np.clip(1.0 - r, 0.0, None)
    return s**4 * (4.0 * r + 1.0)


@dataclass(frozen=True, eq=False)
class InterfaceMapping:
    """Precomputed sparse mapping ``values_target = matrix @ values_source``."""

    matrix: sparse.csr_array  # (n_target, n_source)
    _by_column: sparse.csc_array = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # The same matrix by columns: scipy's column scatter is faster for (n, 3) data.
        object.__setattr__(self, "_by_column", self.matrix.tocsc())

    @classmethod
    def from_points(
        cls,
        source_xy: ArrayLike,
        target_xy: ArrayLike,
        support_radius: float | None = None,
        *,
        neighbors: int = DEFAULT_NEIGHBORS,
    ) -> InterfaceMapping:
        """Build the mapping from structure nodes ``source_xy`` (n_s, 2) m to fluid points
        ``target_xy`` (n_t, 2) m (pass ``points[:, :2]``; the plate plane is z = 0).

        ``support_radius`` (m) fixes every patch radius; by default each patch reaches the
        ``neighbors``-th nearest structure node. Near-collinear patches are grown by 25 % steps.
        """
        src = _as_points("source_xy", source_xy)
        tgt = _as_points("target_xy", target_xy)
        tree = cKDTree(src)
        _check_distinct(tree, src)
        radii = _initial_radii(tree, src, support_radius, neighbors)
        radii, members = _grow_degenerate(tree, src, radii)
        covers = cKDTree(tgt).query_ball_point(src, radii)
        return cls(matrix=_assemble(src, tgt, radii, members, covers))

    @classmethod
    def from_interfaces(
        cls,
        source: InterfaceMesh,
        target: InterfaceMesh,
        support_radius: float | None = None,
        *,
        neighbors: int = DEFAULT_NEIGHBORS,
    ) -> InterfaceMapping:
        """:meth:`from_points` on the (x, y) of two participants' reference interfaces."""
        return cls.from_points(
            source.points[:, :2], target.points[:, :2], support_radius, neighbors=neighbors
        )

    @property
    def n_source(self) -> int:
        return int(self.matrix.shape[1])

    @property
    def n_target(self) -> int:
        return int(self.matrix.shape[0])

    def consistent(self, values: ArrayLike) -> NDArray[np.float64]:
        """Values at the target points from values at the source nodes, (n_s[, k]) -> (n_t[, k])
        (displacement, velocity: constant and linear fields are exact)."""
        mapped: NDArray[np.float64] = self._by_column @ _as_data("values", values, self.n_source)
        return mapped

    def conservative(self, forces_at_target: ArrayLike) -> NDArray[np.float64]:
        """Nodal forces on the source nodes from point forces at the targets, H^T F,
        (n_t[, k]) -> (n_s[, k]): total force and in-plane-arm moment are preserved."""
        data = _as_data("forces_at_target", forces_at_target, self.n_target)
        mapped: NDArray[np.float64] = self.matrix.T @ data
        return mapped


def _as_points(name: str, points: ArrayLike) -> NDArray[np.float64]:
    pts = np.array(points, dtype=float)  # a copy: the caller's array is never touched
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) == 0:
        raise MappingError(
            f"`{name}` must be an (n, 2) array of plate-plane coordinates (pass points[:, :2]), "
            f"got shape {pts.shape}"
        )
    if not np.isfinite(pts).all():
        raise MappingError(f"`{name}` holds non-finite coordinates")
    return pts


def _as_data(name: str, values: ArrayLike, n: int) -> NDArray[np.float64]:
    data = np.asarray(values, dtype=float)
    if data.ndim not in (1, 2) or data.shape[0] != n:
        raise MappingError(f"`{name}` must have shape ({n},) or ({n}, k), got {data.shape}")
    return data


def _check_distinct(tree: cKDTree, src: NDArray[np.float64]) -> None:
    if len(src) < 3:
        raise MappingError(f"`source_xy` needs at least 3 points, got {len(src)}")
    d, _ = tree.query(src, 2)
    scale = np.ptp(src, axis=0).max()
    if d[:, 1].min() <= 1e-12 * scale:
        i = int(np.argmin(d[:, 1]))
        raise MappingError(
            f"`source_xy` has coincident points (e.g. at {src[i].tolist()}); pass each structure "
            "node once (mid-surface nodes, not both faces)"
        )


def _initial_radii(
    tree: cKDTree, src: NDArray[np.float64], support_radius: float | None, neighbors: int
) -> NDArray[np.float64]:
    if support_radius is not None:
        if not support_radius > 0:
            raise MappingError(f"`support_radius` must be > 0 m, got {support_radius}")
        return np.full(len(src), float(support_radius))
    if not 3 <= neighbors < len(src):
        raise MappingError(f"`neighbors` must be in [3, {len(src) - 1}], got {neighbors}")
    d, _ = tree.query(src, neighbors + 1)
    radii: NDArray[np.float64] = d[:, -1] * (1.0 + 1e-9)
    return radii


def _degenerate(points: NDArray[np.float64]) -> bool:
    """Too few or nearly collinear points: the linear polynomial is not determined."""
    if len(points) < 3:
        return True
    lam = np.linalg.eigvalsh(np.cov(points.T))
    return bool(lam[0] <= _MIN_ASPECT * lam[1])


def _grow_degenerate(
    tree: cKDTree, src: NDArray[np.float64], radii: NDArray[np.float64]
) -> tuple[NDArray[np.float64], list[list[int]]]:
    radii = radii.copy()
    for _ in range(_MAX_GROWTHS):
        members = tree.query_ball_point(src, radii)
        bad = [i for i, m in enumerate(members) if _degenerate(src[m])]
        if not bad:
            return radii, list(members)
        radii[bad] *= _GROWTH
    raise MappingError(
        f"{len(bad)} source patches stay collinear (e.g. around {src[bad[0]].tolist()}); "
        "the source points must span the plate plane"
    )


def _patch_weights(
    src: NDArray[np.float64],
    tgt: NDArray[np.float64],
    center: int,
    radius: float,
    members: NDArray[np.intp],
    targets: NDArray[np.intp],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Blending weight times local cardinal weights, (n_targets, n_members), and the blending
    weights alone. Coordinates are shifted to the centre and scaled by the radius."""
    xm = (src[members] - src[center]) / radius
    xt = (tgt[targets] - src[center]) / radius
    phi = wendland_c2(np.linalg.norm(xm[:, None] - xm[None], axis=-1))
    poly = np.column_stack([np.ones(len(xm)), xm])
    system = np.block([[phi, poly], [poly.T, np.zeros((3, 3))]])
    rhs = np.column_stack(
        [wendland_c2(np.linalg.norm(xt[:, None] - xm[None], axis=-1)), np.ones(len(xt)), xt]
    )
    cardinal = np.linalg.solve(system, rhs.T)[: len(xm)].T
    blend = wendland_c2(np.linalg.norm(xt, axis=1))
    return blend[:, None] * cardinal, blend


def _assemble(
    src: NDArray[np.float64],
    tgt: NDArray[np.float64],
    radii: NDArray[np.float64],
    members: list[list[int]],
    covers: list[list[int]],
) -> sparse.csr_array:
    rows, cols, vals = [], [], []
    blend_sum = np.zeros(len(tgt))
    for i, (member_list, cover_list) in enumerate(zip(members, covers, strict=True)):
        if not cover_list:
            continue
        m, t = np.asarray(member_list), np.asarray(cover_list)
        w, blend = _patch_weights(src, tgt, i, radii[i], m, t)
        blend_sum[t] += blend
        rows.append(np.repeat(t, len(m)))
        cols.append(np.tile(m, len(t)))
        vals.append(w.ravel())
    _check_covered(tgt, blend_sum)
    rows_all = np.concatenate(rows)
    data = np.concatenate(vals) / blend_sum[rows_all]
    coo = sparse.coo_array((data, (rows_all, np.concatenate(cols))), shape=(len(tgt), len(src)))
    matrix = coo.tocsr()
    matrix.sum_duplicates()
    return matrix


def _check_covered(tgt: NDArray[np.float64], blend_sum: NDArray[np.float64]) -> None:
    uncovered = np.flatnonzero(blend_sum <= 0.0)
    if len(uncovered):
        raise MappingError(
            f"{len(uncovered)} target points (e.g. {tgt[uncovered[0]].tolist()}) lie outside "
            "every source patch; check that both point sets share frame and units, or pass a "
            "larger `support_radius` (m)"
        )
