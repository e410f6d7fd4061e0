"""Does the drive's mean voltage buckle the laminate? Linearized buckling about the flat plate.

The mean of the -500..+1500 V drive (+500 V on both MFCs) makes both active layers expand
together. With the induced-strain drive the passive plate around the active areas holds that
expansion back, so the laminate carries a self-equilibrated membrane prestress (compression in
and beside the active areas); with the seed-stress drive the same voltage pulls the plate from
the active areas' edges (tension). The load factor at which the prestress buckles the plate is
the smallest positive lambda of

    (K0 + lambda K1) phi = 0,   K1 = d K_sigma(lambda x1, lambda V) / d lambda at 0,

with x1 the linear response to the mean voltage and K_sigma the stress (geometric) part of the
tangent; lambda > 1 means the mean voltage is carried
without buckling (lambda < 0 only: the prestress stiffens the plate, no buckling at all).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from fsi_orchestrator.case import CaseError

from .shell import ShellModel
from .solvers import static_free_dofs

STEP = 1e-4  # load factor of the finite difference for K1 (K_T is smooth in lambda)


def buckling_factor(model: ShellModel, volts: NDArray, modes: int = 6) -> float:
    """Smallest positive load factor of ``volts`` (held as a constant voltage) at which the
    plate buckles; ``inf`` when no positive factor exists among the lowest ``modes``."""
    volts = np.asarray(volts, dtype=float)
    if not np.any(volts):
        return float("inf")
    zero = model.zero_state()
    r0, K0, _ = model.internal(zero, np.zeros(2))
    load = -(model.internal(zero, volts, tangent=False)[0] - r0)
    if not np.any(load):  # the mean voltage induces no strain (zero piezo constants)
        return float("inf")
    free = static_free_dofs(model)
    K0ff = sp.csc_matrix(K0[free][:, free])
    x1 = np.zeros(model.ndof)
    x1[free] = spla.spsolve(K0ff, load[free])
    # the stress part of the tangent only: the material part's change with the displacement
    # (B(u)) is no instability; a unimorph bends under its mean and that part is indefinite
    K_step = model.internal(STEP * x1, STEP * volts)[1] - model.material_stiffness(STEP * x1)
    if model.support is not None:
        K_step = K_step - model.support
    K1ff = sp.csc_matrix((K_step / STEP)[free][:, free])
    K1ff = 0.5 * (K1ff + K1ff.T)
    # -K1 phi = mu K0 phi with K0 positive definite; lambda = 1 / mu for mu > 0
    v0 = np.random.default_rng(0).standard_normal(K0ff.shape[0])
    mu = spla.eigsh(-K1ff, k=modes, M=K0ff, which="LA", v0=v0, return_eigenvectors=False)
    positive = mu[mu > 1e-12]
    return float(1.0 / positive.max()) if positive.size else float("inf")


def mean_voltage_buckling_factor(model: ShellModel, mean_volts: NDArray) -> float:
    """buckling_factor of the drive's mean voltage, cached on the model (one eigen-solve for
    fsi-modal's report and the equilibrium's check); inf for a zero mean."""
    mean = np.asarray(mean_volts, dtype=float)
    if not np.any(mean):
        return float("inf")
    cache = model.__dict__.setdefault("_buckling_factors", {})
    key = tuple(mean.round(9))
    if key not in cache:
        cache[key] = buckling_factor(model, mean)
    return cache[key]


def check_mean_voltage(model: ShellModel, mean_volts: NDArray) -> float:
    """The buckling factor of the drive's mean voltage (cached on the model); a one-line
    CaseError when the mean buckles the plate, since the flat laminate the drive oscillates
    about would not exist (Newton then diverges in the first steps)."""
    mean = np.asarray(mean_volts, dtype=float)
    factor = mean_voltage_buckling_factor(model, mean)
    if factor < 1.0:
        raise CaseError(
            f"actuation: the mean voltage {mean.tolist()} V buckles the plate at {factor:.2f} "
            "of its value (the active areas' mean expansion compresses the passive plate "
            "around them); set actuation.mean_strain_transfer below "
            f"{factor:.2f} (a creeping bond, docs/validation.md 'Drive model'), drive about "
            "0 V, or thicken the core (geometry.thickness_m)"
        )
    return factor
