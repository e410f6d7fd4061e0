"""Mapped quadrilateral mesh of the plate outline and the scikit-fem bases the shell uses.

Columns of elements follow x with element edges at every layout breakpoint (actuator, active
area, clamp line, ...); rows follow fractions of the local height, so any symmetric outline
h(x) maps onto the same structured grid. Fields are interpolated with 9-node Lagrange quads
(``ElementQuad2``); the geometry map is bilinear.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import skfem
from numpy.typing import NDArray

from fsi_orchestrator.case.schema import GeometryKind, MeshLevel

from .geometry import PlateLayout

# (elements along x, across y). The default fish level is chosen in benchmarks/shell_mesh.py.
MESH_LEVELS = {
    GeometryKind.FISH: {
        MeshLevel.COARSE: (8, 2),
        MeshLevel.DEFAULT: (16, 4),
        MeshLevel.FINE: (32, 8),
    },
    GeometryKind.BEAM: {
        MeshLevel.COARSE: (8, 1),
        MeshLevel.DEFAULT: (16, 2),
        MeshLevel.FINE: (32, 4),
    },
    GeometryKind.RECTANGLE: {
        MeshLevel.COARSE: (8, 1),
        MeshLevel.DEFAULT: (16, 2),
        MeshLevel.FINE: (32, 4),
    },
}

# scikit-fem integrates quads with tensor Gauss rules: intorder 3 -> 2 x 2, 5 -> 3 x 3 points.
REDUCED_INTORDER = 3
FULL_INTORDER = 5
# Mass and load integrals sample the region indicator (head-weight disk) densely: 8 x 8 points.
DENSE_INTORDER = 15


@dataclass(frozen=True)
class QuadratureData:
    """Shape functions at the quadrature points of every element, as plain arrays."""

    N: NDArray  # (nel, nqp, 9)
    dN: NDArray  # (nel, nqp, 9, 2)  d/dx, d/dy
    weights: NDArray  # (nel, nqp)  quadrature weight * Jacobian
    points: NDArray  # (nel, nqp, 2)  physical coordinates

    @classmethod
    def from_basis(cls, basis: skfem.CellBasis) -> QuadratureData:
        N = np.stack([np.asarray(phi[0]) for phi in basis.basis], axis=-1)
        dN = np.stack([phi[0].grad for phi in basis.basis], axis=-1)  # (2, nel, nqp, 9)
        dN = np.moveaxis(dN, 0, -1)  # (nel, nqp, 9, 2)
        pts = np.moveaxis(basis.mapping.F(basis.X), 0, -1)  # (nel, nqp, 2)
        return cls(N=N, dN=dN, weights=np.asarray(basis.dx), points=pts)


@dataclass(frozen=True)
class PlateMesh:
    mesh: skfem.MeshQuad1
    basis: skfem.CellBasis  # full (3 x 3) rule
    full: QuadratureData
    reduced: QuadratureData
    dense: QuadratureData
    nodes: NDArray  # (n, 2) reference coordinates of the 9-node DOF locations
    element_nodes: NDArray  # (nel, 9)
    shape: tuple[int, int]  # (elements along x, across y)

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    def nearest_node(self, x: float, y: float) -> int:
        return int(np.argmin((self.nodes[:, 0] - x) ** 2 + (self.nodes[:, 1] - y) ** 2))

    def edge_nodes(self, x: float, tol: float = 1e-9) -> NDArray:
        """Nodes on the straight edge at ``x`` ordered by y."""
        idx = np.flatnonzero(np.abs(self.nodes[:, 0] - x) <= tol * max(1.0, abs(x)))
        return idx[np.argsort(self.nodes[idx, 1])]

    def edge_weights(self, x: float) -> tuple[NDArray, NDArray]:
        """Nodes on the edge at ``x`` and the consistent weights of a uniform line load of
        unit total: Simpson weights (1, 4, 1)/6 per quadratic edge segment, scaled by length."""
        idx = self.edge_nodes(x)
        y = self.nodes[idx, 1]
        w = np.zeros(len(idx))
        for k in range(0, len(idx) - 2, 2):
            w[k : k + 3] += (y[k + 2] - y[k]) * np.array([1.0, 4.0, 1.0]) / 6.0
        return idx, w / w.sum()


def element_columns(layout: PlateLayout, n_target: int) -> NDArray:
    """x coordinates of element columns with edges at every layout breakpoint, spaced by the
    column density ``column_density`` (denser where the outline is narrow)."""
    breaks = np.array(sorted(layout.breakpoints_m))
    keep = np.concatenate([[True], np.diff(breaks) > 1e-9 * layout.length_m])
    breaks = breaks[keep & (breaks <= layout.length_m * (1 + 1e-12))]
    breaks[-1] = layout.length_m
    xf = np.unique(np.concatenate([breaks, np.linspace(0.0, layout.length_m, 2001)]))
    rho = column_density(layout, xf)
    mass = np.concatenate([[0.0], np.cumsum(np.diff(xf) * (rho[1:] + rho[:-1]) / 2)])
    at_breaks = np.interp(breaks, xf, mass)
    counts = np.maximum(1, np.round(n_target * np.diff(at_breaks) / mass[-1])).astype(int)
    xs = [
        np.interp(np.linspace(m0, m1, n + 1)[:-1], mass, xf)
        for m0, m1, n in zip(at_breaks[:-1], at_breaks[1:], counts, strict=True)
    ]
    return np.concatenate(xs + [breaks[-1:]])


GRADING_EXPONENT = 1.0


def column_density(layout: PlateLayout, x: NDArray) -> NDArray:
    """Relative density of element columns along x: (h_max / h(x)) ** GRADING_EXPONENT.

    A plate's bending stiffness goes with its local height, so a narrow waist (a 3 mm caudal
    peduncle between a 64 mm body and a 60 mm fin) concentrates the curvature where a uniform
    column spacing puts one element across the whole taper; a constant height gives uniform
    columns."""
    h = np.maximum(layout.height(x), 1e-12)
    return (h.max() / h) ** GRADING_EXPONENT


def row_coordinates(layout: PlateLayout, xs: NDArray, ny: int) -> NDArray:
    """y of the vertex rows at each column (ncol, nrows + 1), symmetric about y = 0, with rows
    on every ``layout.y_breaks`` line inside its x range (scaled with the outline outside)."""
    half = layout.height(xs) / 2
    h_ref = half.max()
    knots, fractions = [], []
    for b, x0, x1 in sorted(layout.y_breaks):
        inside = (xs >= x0 - 1e-12) & (xs <= x1 + 1e-12)
        h_min = half[inside].min() if inside.any() else h_ref
        frac = min(b / h_min, 0.95)
        knots.append(np.minimum(b, frac * half))
        fractions.append(b / h_ref)
    knots.append(half)
    fractions.append(1.0)
    widths = np.diff(np.concatenate([[0.0], fractions]))
    rows = np.maximum(1, np.round(widths * ny / 2)).astype(int)
    columns = [np.zeros(len(xs))]
    lower = np.zeros(len(xs))
    for upper, n in zip(knots, rows, strict=True):
        for k in range(1, n + 1):
            columns.append(lower + (upper - lower) * k / n)
        lower = upper
    top = np.array(columns).T  # (ncol, rows_half + 1), from 0 to h/2
    return np.concatenate([-top[:, :0:-1], top], axis=1)


def build_mesh(
    layout: PlateLayout, level: MeshLevel, nx: int | None = None, ny: int | None = None
) -> PlateMesh:
    nx_lvl, ny_lvl = MESH_LEVELS[layout.kind][level]
    nx, ny = nx or nx_lvl, ny or ny_lvl
    xs = element_columns(layout, nx)
    if layout.y_breaks:
        Yc = row_coordinates(layout, xs, ny)
    else:  # plain mapped rows (odd ny allowed)
        Yc = np.linspace(-0.5, 0.5, ny + 1)[None, :] * layout.height(xs)[:, None]
    nrow = Yc.shape[1]
    X = np.repeat(xs, nrow)
    Y = Yc.ravel()
    ncol = len(xs)
    idx = np.arange(ncol * nrow).reshape(ncol, nrow)
    t = np.array(
        [idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()]
    )
    mesh = skfem.MeshQuad1(np.array([X, Y]), t)
    element = skfem.ElementQuad2()
    full = skfem.CellBasis(mesh, element, intorder=FULL_INTORDER)
    reduced = skfem.CellBasis(mesh, element, intorder=REDUCED_INTORDER)
    dense = skfem.CellBasis(mesh, element, intorder=DENSE_INTORDER)
    nodes = full.doflocs.T.copy()
    element_nodes = full.element_dofs.T.copy()
    return PlateMesh(
        mesh=mesh,
        basis=full,
        full=QuadratureData.from_basis(full),
        reduced=QuadratureData.from_basis(reduced),
        dense=QuadratureData.from_basis(dense),
        nodes=nodes,
        element_nodes=element_nodes,
        shape=(ncol - 1, nrow - 1),
    )
