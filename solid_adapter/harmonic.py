"""Linear periodic response of the (wet) shell to the piezo drive, about its static state.

Used twice: as the initial condition of a time-domain run (start on the periodic orbit instead
of at rest, so the first periods are already the steady state rather than a beating of the
forced response with an undamped free vibration), and as the fast frequency sweep.

The drive's oscillating part is [amp_L, -amp_R] s(t) with s = sin(w t) or the square wave
(4/pi) sum_{k odd} sin(k w t)/k. For each harmonic k:

    (K - (k w)^2 M + i k w C) X_k = F_V c_k,        x(t) = x_s + sum_k Im(X_k e^{i k w t}),

with F_V the piezo load per volt on each actuator, K the tangent of the unstressed plate, M the
inertia (structure plus added mass), C the damping, x_s the static state under the mean
voltages. K is not taken at x_s: equal mean voltages expand both MFCs in-plane, which
compresses the thin bare CFRP around them close to its buckling strain, and the prestressed
tangent can turn indefinite; the bending response does not feel that membrane prestress.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from fsi_orchestrator.case.schema import Waveform

from .piezo import DriveSignal
from .shell import NDOF, ShellModel


def piezo_load_per_volt(model: ShellModel, x: NDArray | None = None) -> NDArray:
    """(2, ndof): external-load equivalent of one volt on the left / right actuator at x."""
    x = model.zero_state() if x is None else x
    base = model.internal(x, np.zeros(2), tangent=False)[0]
    loads = []
    for side in range(2):
        volts = np.zeros(2)
        volts[side] = 1.0
        loads.append(base - model.internal(x, volts, tangent=False)[0])
    return np.array(loads)


def harmonic_amplitudes(drive: DriveSignal, n_harmonics: int) -> list[tuple[int, float]]:
    """(k, c_k) of the unit waveform s(t) = sum c_k sin(k w t)."""
    if drive.waveform is Waveform.SINE:
        return [(1, 1.0)]
    return [(k, 4 / (np.pi * k)) for k in range(1, 2 * n_harmonics, 2)]


@dataclass(frozen=True)
class PeriodicResponse:
    omega: float
    x_static: NDArray
    harmonics: list[tuple[int, NDArray]]  # (k, complex X_k)

    def at(self, t: float) -> tuple[NDArray, NDArray, NDArray]:
        """Displacement, velocity and acceleration at time t."""
        x, v, a = self.x_static.copy(), np.zeros_like(self.x_static), np.zeros_like(self.x_static)
        for k, X in self.harmonics:
            iw = 1j * k * self.omega
            phase = np.exp(iw * t)
            x += np.imag(X * phase)
            v += np.imag(iw * X * phase)
            a += np.imag(iw * iw * X * phase)
        return x, v, a

    def dof_history(self, dofs: NDArray, times: NDArray) -> NDArray:
        """(len(times), len(dofs)) displacement history of some DOFs."""
        out = np.broadcast_to(self.x_static[dofs], (len(times), len(dofs))).copy()
        for k, X in self.harmonics:
            out += np.imag(np.exp(1j * k * self.omega * times)[:, None] * X[dofs][None, :])
        return out


@dataclass(frozen=True)
class ModalCorrection:
    """A fluid force the inertia does not hold, driven by the motion along one unit shape e
    (full DOF vectors): f = -p s'' - d s', s = e . x. The damping part is proportional to the
    amplitude of s (the equivalent linear damping of a quadratic drag) when
    ``reference_amplitude_m`` is set: d(|S|) = d |S| / reference_amplitude_m."""

    shape: NDArray
    mass_force: NDArray  # p
    damping_force: NDArray  # d
    reference_amplitude_m: float | None = None


class NormalElimination:
    """Solves of a harmonic's operator A (on the free DOFs) by elimination onto the normal
    (u_z) DOFs. The potential flow's added mass couples every normal DOF with every other, and
    a sparse LU of the whole operator fills that block in (0.6 s per harmonic on the original
    fish's default shell). Eliminated instead, the rest is a sparse shell operator and the
    normal block a dense matrix of a fifth of the DOFs. Kept between calls while A changes
    only in its normal block, as it does from step to step of the fixed point that linearizes
    the edge drag (``linearized_damping_response``): each step then factors only that block.
    Each kept harmonic holds a dense (rest x normal) matrix: 83 MB on the fine shell level."""

    def __init__(self, A: sp.spmatrix, normal: NDArray) -> None:
        A = sp.csr_matrix(A)
        self.rest, self.z = np.flatnonzero(~normal), np.flatnonzero(normal)
        z, r = self.z, self.rest
        self.A_rr = A[r][:, r]
        self.A_rz = A[r][:, z]
        self.A_zr = A[z][:, r]
        self.solve_rr = spla.factorized(sp.csc_matrix(self.A_rr))
        self.W = self.solve_rr(self.A_rz.toarray())  # A_rr^-1 A_rz
        self.T = self.A_zr @ self.W
        self._factor(A)

    def holds(self, A: sp.spmatrix) -> bool:
        """Whether A differs from the eliminated operator only in its normal block."""
        A = sp.csr_matrix(A)
        r, z = self.rest, self.z
        if A.shape != (len(r) + len(z),) * 2:
            return False
        blocks = ((A[r][:, r], self.A_rr), (A[r][:, z], self.A_rz), (A[z][:, r], self.A_zr))
        return all((new - old).count_nonzero() == 0 for new, old in blocks)

    def _factor(self, A: sp.csr_matrix) -> None:
        z = self.z
        schur = A[z][:, z].toarray() - self.T
        self.lu = scipy.linalg.lu_factor(schur, check_finite=False)

    def refactor(self, A: sp.spmatrix) -> None:
        self._factor(sp.csr_matrix(A))

    def __call__(self, F: NDArray) -> NDArray:
        r, z = self.rest, self.z
        y_r0 = self.solve_rr(F[r])
        y = np.empty(len(F), dtype=np.result_type(F, self.W, complex))
        y[z] = scipy.linalg.lu_solve(self.lu, F[z] - self.A_zr @ y_r0, check_finite=False)
        y[r] = y_r0 - self.W @ y[z]
        return y


# the normal block's share of nonzeros above which it is eliminated as a dense matrix (an
# added mass fills it; a dry shell's holds 1-6 % and a plain sparse LU does better)
DENSE_NORMAL_BLOCK = 0.5


def harmonic_solver(A: sp.spmatrix, normal: NDArray, cache: dict | None, key: object):
    """A solve of A: the elimination onto its normal DOFs where an added mass fills their
    block, reused from ``cache[key]`` while it holds; otherwise a sparse LU."""
    A = sp.csr_matrix(A)
    z = np.flatnonzero(normal)
    if A[z][:, z].nnz < DENSE_NORMAL_BLOCK * len(z) ** 2:
        return spla.factorized(sp.csc_matrix(A))
    held = cache.get(key) if cache is not None else None
    if held is not None and held.holds(A):
        held.refactor(A)
        return held
    solver = NormalElimination(A, normal)
    if cache is not None:
        cache[key] = solver
    return solver


def periodic_response(
    model: ShellModel,
    drive: DriveSignal,
    x_static: NDArray,
    damping: sp.spmatrix | None = None,
    n_harmonics: int = 15,
    correction: ModalCorrection | None = None,
    prestressed: bool = False,
    cache: dict | None = None,
) -> PeriodicResponse:
    """Linear steady state about ``x_static`` (the equilibrium under the mean voltages). A
    ``correction`` adds the rank-one term (-w^2 p + i w d) e^T to each harmonic's operator
    (Sherman-Morrison); an amplitude-dependent damping is resolved for the fundamental.
    The operator is the unloaded flat plate's unless ``prestressed``: then the tangent and the
    piezo load are taken at x_static with the mean voltages (mean_voltage_tangent), and
    ``damping`` should be taken about that state too. The transient start keeps the flat
    operator, as the transient's Rayleigh damping keeps the flat tangent (docs/coupling.md).
    ``cache``: a dict kept between calls that change only the damping on the normal DOFs
    (NormalElimination)."""
    omega = 2 * np.pi * drive.frequency_hz
    if prestressed:
        K = mean_voltage_tangent(model, x_static, drive)
        load = harmonic_load(model, drive, x_static)
    else:
        K = model.internal(model.zero_state(), np.zeros(2))[1]
        load = harmonic_load(model, drive)
    free = model.free_dofs
    normal = (np.arange(model.ndof) % NDOF == 2)[free]
    solved = []  # (k, w, A^-1 F, A^-1 p, A^-1 d)
    for k, c in harmonic_amplitudes(drive, n_harmonics):
        w = k * omega
        A = K - w**2 * model.inertia
        if damping is not None:
            A = A + 1j * w * damping
        solve = harmonic_solver(sp.csr_matrix(A)[free][:, free], normal, cache, (k, w))
        y_p = solve(correction.mass_force[free]) if correction else None
        y_d = solve(correction.damping_force[free]) if correction else None
        solved.append((k, w, solve(c * load[free]), y_p, y_d))
    sigma = _damping_scale(correction, free, solved) if correction else 1.0
    harmonics = []
    for k, w, y_f, y_p, y_d in solved:
        X = np.zeros(model.ndof, dtype=complex)
        X[free] = y_f
        if correction is not None:
            assert y_p is not None and y_d is not None  # solved with the correction
            e = correction.shape[free]
            y_g = -(w**2) * y_p + 1j * w * sigma * y_d
            X[free] -= y_g * (e @ y_f) / (1 + e @ y_g)
        harmonics.append((k, X))
    return PeriodicResponse(omega=omega, x_static=x_static, harmonics=harmonics)


def _damping_scale(correction: ModalCorrection, free: NDArray, solved: list) -> float:
    """sigma = |S(sigma)| / S_ref for an amplitude-proportional damping, by bisection (|S|
    falls as the damping grows); S = e . X of the fundamental = s0 / (1 + e . A^-1 g)."""
    if correction.reference_amplitude_m is None:
        return 1.0
    _, w, y_f, y_p, y_d = solved[0]
    e = correction.shape[free]
    s0, s_p, s_d = e @ y_f, e @ y_p, e @ y_d

    def amplitude(sigma: float) -> float:
        return abs(s0 / (1 - w**2 * s_p + 1j * w * sigma * s_d))

    per_amplitude = 1.0 / correction.reference_amplitude_m
    lo, hi = 0.0, per_amplitude * amplitude(0.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid > per_amplitude * amplitude(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def mean_volts(drive: DriveSignal) -> NDArray:
    return drive.mean


def mean_voltage_tangent(model: ShellModel, x_static: NDArray, drive: DriveSignal) -> sp.spmatrix:
    """The tangent the drive oscillates about: at the equilibrium under the mean voltages,
    with their prestress. Where an active area is embedded in passive plate (the fish) its
    mean expansion is held by the plate around it, and that in-plane prestress changes the
    bending stiffness: the free original fish at 3 Hz swings 6.15 mm about this state and
    7.22 mm about the unloaded plate, the nonlinear transient 6.16 mm (docs/coupling.md).
    The linear sweep (fsi-sweep --method linear) oscillates about it."""
    return model.internal(x_static, mean_volts(drive))[1]


@dataclass(frozen=True)
class ModalSweep:
    """Frequency response by modal superposition with a static correction (the "modal
    acceleration" method): exact for Rayleigh damping, and after one eigen-solve each frequency
    costs a few vector operations.

        X(w) = sum_j phi_j (phi_j . F) [1/(w_j^2 - w^2 + 2 i zeta_j w_j w) - 1/w_j^2] + K^-1 F
    """

    omegas: NDArray  # (m,) rad/s
    shapes: NDArray  # (m, ndof), inertia-normalised
    zetas: NDArray  # (m,)
    static: NDArray  # K^-1 F (ndof,)
    modal_load: NDArray  # phi_j . F
    loss_factor: float = 0.0  # structural (hysteretic): w_j^2 (1 + i eta)
    # leading modes at zero frequency: a free body's rigid motions, kept where a load that is
    # not self-equilibrated moves them (the fluid's load at forward speed)
    rigid: int = 0

    @classmethod
    def build(
        cls,
        model: ShellModel,
        load: NDArray,
        n_modes: int,
        rayleigh: tuple[float, float] = (0.0, 0.0),
        stiffness: sp.spmatrix | None = None,
        loss_factor: float = 0.0,
        with_rigid: bool = False,
    ) -> ModalSweep:
        """``stiffness``: the tangent to oscillate about (mean_voltage_tangent; default the
        unloaded plate's). ``with_rigid``: a free plate's rigid modes lead the superposition."""
        from .solvers import modal_analysis, static_free_dofs

        K = stiffness
        if K is None:
            K = model.internal(model.zero_state(), np.zeros(2))[1]
        result = modal_analysis(model, n_modes, stiffness=K)
        omegas = 2 * np.pi * result.frequencies_hz
        alpha, beta = rayleigh
        # K^-1 F; a free plate: held by the reaction-free static support, then without the
        # rigid motion that support chose (the elastic modes are inertia-orthogonal to it)
        held = static_free_dofs(model)
        static = np.zeros(model.ndof)
        static[held] = spla.spsolve(sp.csc_matrix(K[held][:, held]), load[held])
        if result.rigid_shapes is not None:
            rigid = result.rigid_shapes
            static -= rigid.T @ (rigid @ (model.inertia @ static))
        shapes, zetas = result.shapes, alpha / (2 * omegas) + beta * omegas / 2
        n_rigid = 0
        if with_rigid and result.rigid_shapes is not None:
            n_rigid = len(result.rigid_shapes)
            shapes = np.vstack([result.rigid_shapes, shapes])
            omegas = np.concatenate([np.zeros(n_rigid), omegas])
            zetas = np.concatenate([np.zeros(n_rigid), zetas])  # no Rayleigh alpha there
        return cls(
            omegas=omegas,
            shapes=shapes,
            zetas=zetas,
            static=static,
            modal_load=shapes @ load,
            loss_factor=loss_factor,
            rigid=n_rigid,
        )

    def response(
        self,
        omega: float,
        modal_damping: NDArray | None = None,
        modal_mass: NDArray | None = None,
        modal_stiffness: NDArray | None = None,
    ) -> NDArray:
        """``modal_damping``: a damping beyond Rayleigh's in modal coordinates, phi^T C phi
        (m x m, it couples the modes), e.g. the fluid's edge drag linearized; ``modal_mass``
        likewise an extra inertia phi^T M phi (the edge inertia); ``modal_stiffness`` an extra
        stiffness (the fluid's load at forward speed). The rigid modes have no static part."""
        wj = self.omegas
        static_part = np.zeros_like(wj)  # 1 / w_j^2: the share the static correction holds
        static_part[self.rigid :] = 1.0 / wj[self.rigid :] ** 2
        stiffness = wj**2 * (1 + 1j * self.loss_factor)
        if modal_damping is None and modal_mass is None and modal_stiffness is None:
            dynamic = 1.0 / (stiffness - omega**2 + 2j * self.zetas * wj * omega) - static_part
            return self.static + (self.modal_load * dynamic) @ self.shapes
        A = np.diag(stiffness - omega**2 + 2j * self.zetas * wj * omega).astype(complex)
        if modal_damping is not None:
            A += 1j * omega * modal_damping
        if modal_mass is not None:
            A -= omega**2 * modal_mass
        if modal_stiffness is not None:
            A += modal_stiffness
        q = np.linalg.solve(A, self.modal_load) - self.modal_load * static_part
        return self.static + q @ self.shapes

    def modal_projection(self, matrix: sp.spmatrix) -> NDArray:
        """phi^T C phi of a damping (or mass) matrix."""
        return self.shapes @ (matrix @ self.shapes.T)


def harmonic_load(model: ShellModel, drive: DriveSignal, x: NDArray | None = None) -> NDArray:
    """Load vector of a unit oscillation s(t): F_V [amp_L, -amp_R] at x (default the flat
    plate)."""
    per_volt = piezo_load_per_volt(model, x)
    (lo_l, hi_l), (lo_r, hi_r) = drive.left_volts, drive.right_volts
    return per_volt[0] * (hi_l - lo_l) / 2 - per_volt[1] * (hi_r - lo_r) / 2


def sweep_response(
    sweep: ModalSweep,
    drive: DriveSignal,
    x_static: NDArray,
    n_harmonics: int = 15,
    modal_damping: NDArray | None = None,
    modal_mass: NDArray | None = None,
    modal_stiffness: NDArray | None = None,
) -> PeriodicResponse:
    omega = 2 * np.pi * drive.frequency_hz
    harmonics = [
        (k, c * sweep.response(k * omega, modal_damping, modal_mass, modal_stiffness))
        for k, c in harmonic_amplitudes(drive, n_harmonics)
    ]
    return PeriodicResponse(omega=omega, x_static=x_static, harmonics=harmonics)


def damped_sweep_response(
    sweep: ModalSweep,
    drive: DriveSignal,
    x_static: NDArray,
    damping_model,
    model: ShellModel,
    tip_dof: int,
    inertia_model=None,
    extra_damping: NDArray | None = None,
    extra_stiffness: NDArray | None = None,
) -> PeriodicResponse:
    """sweep_response with an amplitude-dependent damping (the fluid's edge drag), and
    optionally an amplitude-dependent extra inertia (the edge inertia), in modal coordinates,
    linearized about the response itself (linearized_damping_response). ``extra_damping`` and
    ``extra_stiffness``: fixed modal matrices beside them (the fluid's load at forward speed)."""
    m = len(sweep.omegas)
    fixed = np.zeros((m, m)) if extra_damping is None else extra_damping
    damped = linearized_damping_response(
        lambda modal: sweep_response(
            sweep, drive, x_static, modal_damping=modal + fixed, modal_stiffness=extra_stiffness
        ),
        lambda response: sweep.modal_projection(damping_model.linear(model, response)),
        np.zeros((m, m)),
        tip_dof,
    )
    if inertia_model is None:
        return damped

    def laws(response: PeriodicResponse) -> NDArray:
        return np.stack(
            [
                sweep.modal_projection(damping_model.linear(model, response)),
                sweep.modal_projection(inertia_model.linear(model, response)),
            ]
        )

    # both laws together, from the drag's own answer: from no damping the first response
    # overshoots near a resonance, and the mass then settles slowly
    return linearized_damping_response(
        lambda cm: sweep_response(
            sweep,
            drive,
            x_static,
            modal_damping=cm[0] + fixed,
            modal_mass=cm[1],
            modal_stiffness=extra_stiffness,
        ),
        laws,
        laws(damped),
        tip_dof,
        iterations=200,
        settled_steps=3,
    )


def linearized_damping_response(
    solve, linearize, damping, tip_dof: int, iterations: int = 60, settled_steps: int = 1
) -> PeriodicResponse:
    """The periodic response under an amplitude-dependent damping (or damping and mass),
    linearized about the response's own harmonics: fixed point on ``solve(damping)`` from
    ``damping``, half relaxed (the amplitude falls as the damping grows), until the tail's
    fundamental changes by less than 1e-4 in ``settled_steps`` steps in a row (one small step
    can fall at the turn of a slow oscillation)."""
    response = solve(damping)
    small = 0
    for _ in range(iterations):
        previous = abs(response.harmonics[0][1][tip_dof])
        damping = 0.5 * damping + 0.5 * linearize(response)
        response = solve(damping)
        if abs(abs(response.harmonics[0][1][tip_dof]) - previous) <= 1e-4 * previous:
            small += 1
            if small >= settled_steps:
                break
        else:
            small = 0
    return response


def periodic_response_from_samples(omega: float, samples: NDArray) -> PeriodicResponse:
    """The trigonometric interpolant of one period of states sampled at N equal steps, sample j
    at t = j T / N (T = 2 pi / omega): it passes through every sample and holds the harmonics
    up to N / 2 (the Nyquist one as a cosine)."""
    samples = np.asarray(samples, dtype=float)
    n = len(samples)
    c = np.fft.rfft(samples, axis=0) / n  # x_j = sum_k c_k e^(2 pi i j k / n), two-sided
    harmonics = []
    for k in range(1, n // 2 + 1):
        nyquist = 2 * k == n
        # 2 Re(c e^(i k w t)) = Im(2i c e^(i k w t)); at Nyquist c is real and counted once
        harmonics.append((k, (1j if nyquist else 2j) * c[k]))
    return PeriodicResponse(omega=omega, x_static=c[0].real.copy(), harmonics=harmonics)
