"""Strip-theory added mass: the liquid seen by each cross-section of the slender body.

Elongated-body theory (seed Sec. 5.1, eq. 5-3) gives each section of half-height b(x) the added
mass per length A33 = rho pi b^2 gamma for its heave. The pressure jump of a 2D plate section in
heave is elliptic across the height, so the section's heave is the elliptic-weighted mean of the
nodal normal accelerations, psi(y) = 2 sqrt(b^2 - y^2) / (pi b^2), and its force is spread back
with the same weight:

    M_a = sum_s A33(x_s) dx_s v_s v_s^T,   (v_s)_i = int N_i psi dy / int psi dy.

It needs no 3D mesh (milliseconds), gets heave-dominated bending right and ignores what strip
theory ignores: 3D end effects, torsion and chordwise flexibility of a section.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .potential.model import AddedMass


def strip_added_mass(shell_model, density_kg_m3: float, gamma: float = 1.0) -> AddedMass:
    q = shell_model.mesh.full
    x, y = q.points[..., 0].ravel(), q.points[..., 1].ravel()
    w = q.weights.ravel()
    N = q.N.reshape(-1, 9)
    nodes = np.repeat(shell_model.enodes, q.N.shape[1], axis=0)  # (nqp_total, 9)
    b = shell_model.layout.height(x) / 2
    psi = np.sqrt(np.clip(b**2 - y**2, 0.0, None))
    section = np.unique(np.round(x / shell_model.layout.length_m, 12), return_inverse=True)[1]
    n_sections, n = section.max() + 1, shell_model.n_nodes
    V = np.zeros((n_sections, n))
    np.add.at(V, (np.repeat(section, 9), nodes.ravel()), (N * (psi * w)[:, None]).ravel())
    norm = np.bincount(section, weights=psi * w, minlength=n_sections)
    V /= norm[:, None]
    area = np.bincount(section, weights=w, minlength=n_sections)
    b_s = np.bincount(section, weights=b * w, minlength=n_sections) / area
    dx = area / (2 * b_s)
    m_s = density_kg_m3 * np.pi * b_s**2 * gamma * dx
    matrix: NDArray = V.T @ (m_s[:, None] * V)
    return AddedMass(matrix=matrix, density_kg_m3=density_kg_m3, n_fluid_nodes=0)
