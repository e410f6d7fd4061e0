"""Shell director d(theta) of an initially flat plate and its first two derivatives.

The director starts as e3 and is rotated by the rotation vector (theta1, theta2, 0)
(Rodrigues): d = (s theta2, -s theta1, c) with phi = |theta|, s = sin(phi)/phi, c = cos(phi).
With s1 = s'(phi)/phi and s2 = s1'(phi)/phi, every derivative is a polynomial in theta times
s, s1, s2. These are evaluated as series in phi^2 near 0, where the closed forms cancel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

_SMALL = 0.05  # below: series (error ~ phi^10 / 10! < 1e-16)


def _scalar_functions(phi: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    p2 = phi * phi
    c = np.cos(phi)
    with np.errstate(divide="ignore", invalid="ignore"):
        sn = np.sin(phi)
        s_cf = sn / phi
        s1_cf = (phi * c - sn) / (phi * p2)
        s2_cf = (3 * sn - 3 * phi * c - p2 * sn) / (p2 * p2 * phi)
    s_se = 1 - p2 / 6 + p2**2 / 120 - p2**3 / 5040 + p2**4 / 362880
    s1_se = -1 / 3 + p2 / 30 - p2**2 / 840 + p2**3 / 45360 - p2**4 / 3991680
    s2_se = 1 / 15 - p2 / 210 + p2**2 / 7560 - p2**3 / 498960 + p2**4 / 51891840
    small = phi < _SMALL
    return (
        np.where(small, s_se, s_cf),
        np.where(small, s1_se, s1_cf),
        np.where(small, s2_se, s2_cf),
        c,
    )


def director(theta: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """For theta (n, 2): d (n, 3), dd/dtheta (n, 3, 2), d2d/dtheta2 (n, 3, 2, 2)."""
    t1, t2 = theta[:, 0], theta[:, 1]
    phi = np.hypot(t1, t2)
    s, s1, s2, c = _scalar_functions(phi)
    n = len(theta)
    d = np.stack([s * t2, -s * t1, c], axis=1)

    eye = np.eye(2)
    # d(s)/d(theta_j) = s1 theta_j ; d(s1)/d(theta_j) = s2 theta_j
    J = np.empty((n, 3, 2))
    J[:, 0, :] = s1[:, None] * theta * t2[:, None]
    J[:, 0, 1] += s
    J[:, 1, :] = -s1[:, None] * theta * t1[:, None]
    J[:, 1, 0] -= s
    J[:, 2, :] = -s[:, None] * theta

    # H_i,jk for d_i = s theta_m (m = 2 for i = 0, -theta_1 for i = 1):
    # s2 th_j th_k th_m + s1 (delta_jk th_m + th_j delta_km + th_k delta_jm)
    tt = theta[:, :, None] * theta[:, None, :]
    H = np.empty((n, 3, 2, 2))
    for i, (m, sign) in enumerate(((1, 1.0), (0, -1.0))):
        th_m = theta[:, m][:, None, None]
        e_m = eye[m]
        H[:, i] = sign * (
            s2[:, None, None] * tt * th_m
            + s1[:, None, None]
            * (
                eye[None] * th_m
                + theta[:, :, None] * e_m[None, None, :]
                + theta[:, None, :] * e_m[None, :, None]
            )
        )
    H[:, 2] = -(s1[:, None, None] * tt + s[:, None, None] * eye[None])
    return d, J, H
