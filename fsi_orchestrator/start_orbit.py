"""A start on the CFD's periodic orbit rather than the fast model's.

The structure starts on the periodic orbit of the fast fluid (potential flow: added mass, no
damping). A real liquid around a plate that swings by a sizeable fraction of its height also
separates at the edges: more inertia and a large, amplitude-dependent damping (measured on the
fixed-head fish at 3 Hz, coarse mesh, lateral force against tail acceleration: 1.21 / 1.36 /
1.59 times the potential added mass and 0.12 / 0.51 / 0.86 of omega m in damping at 1 / 7.8 /
17.8 mm). Started on the potential orbit (17.8 mm), the coupled run settles near 8 mm only
after a beat with the heavily damped wet first mode that lasts several periods.

So during the fluid-only lead-in, while the fluid follows the fast orbit, the fluid's force
beyond the fast model along the orbit's shape e is fitted as

    f + M~ u'' = -p s'' - d s' + b,      s = e . u,

per node (p, d: where the extra force acts per unit modal acceleration and velocity), and the
structure restarts on the orbit with that extra force (d scaled with the amplitude, as a
quadratic drag's equivalent linear damping). A second lead-in period
carries the fluid from the old orbit to the new one. The loop knows the structure's side only
through :class:`StartOrbit`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

# The fit holds along the shape it was made on: a corrected orbit whose shape turns further
# from it than this |cos| (5 Hz, near the second wet mode) is not used.
MIN_SHAPE_ALIGNMENT = 0.9


@dataclass(frozen=True)
class LeadInSamples:
    """Interface z data on the structure's nodes at the end of lead-in windows."""

    times_s: NDArray[np.float64]  # (n,)
    displacement_z: NDArray[np.float64]  # (n, n_nodes)
    velocity_z: NDArray[np.float64]
    acceleration_z: NDArray[np.float64]
    force_z: NDArray[np.float64]  # the fluid's force on the nodes


@dataclass(frozen=True)
class ModalFit:
    """The fluid's force beyond the fast model, per node, as -p s'' - d s' + b along the
    motion s = e . u of a unit shape e."""

    mass_z: NDArray[np.float64] = field(repr=False)  # (n_nodes,) p, N per m/s2 of s
    # (n_nodes,) d, N per m/s of s, at amplitude_m
    damping_z: NDArray[np.float64] = field(repr=False)
    amplitude_m: float  # amplitude of s over the samples
    residual: float  # rms misfit / rms of the fitted force (all nodes)
    alignment: float = float("nan")  # |cos| between corrected and fitted orbit shapes
    applied: bool = False  # the structure restarted on the corrected orbit

    def summary(self, shape_z: NDArray[np.float64]) -> dict[str, float]:
        """Modal values along e: the extra inertia e . p and damping e . d."""
        return {
            "applied": self.applied,
            "shape_alignment": self.alignment,
            "added_mass_kg": float(shape_z @ self.mass_z),
            "damping_ns_m": float(shape_z @ self.damping_z),
            "amplitude_m": self.amplitude_m,
            "fit_residual": self.residual,
        }


def fit_modal_force(
    samples: LeadInSamples, shape_z: NDArray[np.float64], added_mass_z: NDArray[np.float64]
) -> ModalFit:
    """Least-squares fit of each node's f + M~ a = -p s'' - d s' + b over the samples."""
    e = shape_z / np.linalg.norm(shape_z)
    extra = samples.force_z + samples.acceleration_z @ added_mass_z.T  # (n_t, n_nodes)
    s = samples.displacement_z @ e
    A = np.column_stack([-(samples.acceleration_z @ e), -(samples.velocity_z @ e), np.ones(len(s))])
    coef = np.linalg.lstsq(A, extra, rcond=None)[0]  # (3, n_nodes)
    misfit = extra - A @ coef
    scale = max(float(np.sqrt(np.mean((extra - extra.mean(axis=0)) ** 2))), 1e-300)
    return ModalFit(
        mass_z=coef[0],
        damping_z=coef[1],
        amplitude_m=float(np.ptp(s) / 2),
        residual=float(np.sqrt(np.mean(misfit**2)) / scale),
    )


class StartOrbit(Protocol):
    """The structure's side of the start correction (built by the composition root)."""

    @property
    def shape_z(self) -> NDArray[np.float64]:
        """(n_nodes,) the orbit's shape on the interface nodes' z."""
        ...

    @property
    def added_mass_z(self) -> NDArray[np.float64]:
        """(n_nodes, n_nodes) the fast model's added mass the orbit was computed with."""
        ...

    def restart(self, fit: ModalFit, min_alignment: float) -> float:
        """Put the structure at t = 0 on the orbit with the fitted extra force, unless that
        orbit's shape strays from the fitted one (|cos| < min_alignment); returns |cos|."""
        ...
