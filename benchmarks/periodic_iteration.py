"""Coupling by whole periods: the periodic state without the coupled start-up's beat.

The transient coupling integrates the structure from its start, so any start error rings the
coupled wet first mode for several periods (docs/coupling.md, "How early the periodic state is
known"). Here the unknown is the periodic motion itself, harmonic by harmonic. Each iteration
moves the CFD through one period of the current motion X_j(t) (prescribed motion, one fluid
solve per window, one pimpleFoam launch) and records the fluid's nodal forces F_j(t). The
periodic residual of the structure on that motion, for harmonic k of the drive's angular
frequency w,

    R_k = c_k F_V + F_k - (K - (k w)^2 M_s) X_k,

is solved with the fast model as the Jacobian (potential added mass M_a, the edge drag's
damping D linearized about X_j):

    (K - (k w)^2 (M_s + M_a) + i k w beta D) dX_k = R_k,      X_{j+1} = X_j + dX.

beta = 1 + p/2 is the drag law's incremental damping (f ~ |v|^p v) over its equivalent linear
one, averaged over a change in amplitude (1 + p) and in phase (1). At the fixed point R = 0:
the coupled periodic state. The structure is linear about the mean-voltage equilibrium and
holds the drive's harmonics up to --harmonics (the odd ones of a half-wave symmetric drive);
its tangent and piezo load are those at the equilibrium under the mean voltages (their
prestress moves the fixed point by 3 % on the main job's scene).
The start is the fast model's periodic orbit with the edge drag, after a one-period ramped
lead-in. With beta = 1 the step is the fast model's periodic response to the CFD's force
beyond it (a fixed-point iteration); ``--relaxation`` scales the step.

    .venv/bin/python benchmarks/periodic_iteration.py cases/fixed_head_3Hz \
        --set fluid.mesh_level=coarse --iterations 6
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fishfsi.cli.compose import build_coupled_run, openfoam_fluid_factory
from fluid_adapter.drag import edge_drag
from fsi_orchestrator.case.loader import load_case
from fsi_orchestrator.case.timing import windows_per_period
from fsi_orchestrator.lead_in import smoothstep
from solid_adapter.harmonic import (
    ModalSweep,
    PeriodicResponse,
    harmonic_amplitudes,
    harmonic_load,
    linearized_damping_response,
    mean_voltage_tangent,
)
from solid_adapter.piezo import DriveSignal
from solid_adapter.shell import NDOF


class PeriodicStructure:
    """The shell's linear periodic problem about the mean-voltage equilibrium, in the wet modes
    of the fast model (M_s + M_a) with a static correction."""

    def __init__(self, case, model, x_static, added_mass_z, harmonics: int, modes: int):
        self.model, self.x_static = model, x_static
        model.set_added_mass(added_mass_z)  # the fast model's inertia M_s + M_a
        self.drive = DriveSignal.from_case(case)
        self.omega = 2 * np.pi * case.actuation.frequency_hz
        # the tangent and the piezo load at the mean-voltage equilibrium: its prestress
        self.K = mean_voltage_tangent(model, x_static, self.drive)
        self.F_V = harmonic_load(model, self.drive, x_static)
        self.c = dict(harmonic_amplitudes(self.drive, harmonics))
        # equal voltage ranges: half-wave symmetric, x(t + T/2) = -x(t), odd harmonics only
        symmetric = self.drive.left_volts == self.drive.right_volts
        self.ks = list(range(1, harmonics + 1, 2 if symmetric else 1))
        self.drag = edge_drag(
            model,
            case.fluid.density_kg_m3,
            case.actuation.frequency_hz,
            frequency_exponent=case.fluid.edge_drag_frequency_exponent,
        )
        self.beta = 1 + self.drag.exponent / 2
        sweep = ModalSweep.build(model, self.F_V, modes, stiffness=self.K)
        self.Phi, self.wj = sweep.shapes, sweep.omegas
        self.free = model.free_dofs
        self._K = spla.factorized(sp.csc_matrix(self.K[self.free][:, self.free]))
        self.tip = model.mesh.nearest_node(*model.layout.tip_point) * NDOF + 2

    def solve(self, w: float, load: np.ndarray, damping: sp.spmatrix) -> np.ndarray:
        """(K - w^2 M + i w C)^-1 load: modal, with the static correction K^-1 load."""
        x = np.zeros(self.model.ndof, dtype=complex)
        f = load[self.free]
        x[self.free] = self._K(f.real) + 1j * self._K(f.imag)
        Fm = self.Phi @ load
        A = np.diag(self.wj**2 - w**2) + 1j * w * (self.Phi @ (damping @ self.Phi.T))
        return x + (np.linalg.solve(A, Fm) - Fm / self.wj**2) @ self.Phi

    def drive_load(self, k: int) -> np.ndarray:
        return self.c.get(k, 0.0) * self.F_V

    def damped_orbit(self, guess: PeriodicResponse) -> PeriodicResponse:
        """The periodic response to the drive with the edge drag linearized about itself."""

        def solve(D):
            harmonics = [(k, self.solve(k * self.omega, self.drive_load(k), D)) for k in self.ks]
            return PeriodicResponse(omega=self.omega, x_static=self.x_static, harmonics=harmonics)

        return linearized_damping_response(
            solve,
            lambda r: self.drag.linear(self.model, r),
            self.drag.linear(self.model, guess),
            self.tip,
        )

    def update(
        self, current: PeriodicResponse, fluid: dict, beta: float, relaxation: float
    ) -> PeriodicResponse:
        """The next motion from the fluid force's harmonics on the current one."""
        D = self.drag.linear(self.model, current)
        h = dict(current.harmonics)
        out = []
        for k in self.ks:
            w = k * self.omega
            X = h.get(k, np.zeros(self.model.ndof, dtype=complex))
            # c F_V + F - (K - w^2 M_s) X, with M = M_s + M_a the model's inertia
            R = self.drive_load(k) + fluid[k] - (self.K @ X - w**2 * (self.model.mass @ X))
            out.append((k, X + relaxation * self.solve(w, R, beta * D)))
        return PeriodicResponse(omega=self.omega, x_static=current.x_static, harmonics=out)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", type=Path)
    p.add_argument("--set", dest="overrides", action="append", default=[])
    p.add_argument("--iterations", type=int, default=6)
    p.add_argument("--harmonics", type=int, default=5, help="highest drive harmonic solved")
    p.add_argument("--modes", type=int, default=30)
    p.add_argument("--beta", type=float, help="the Jacobian's drag factor (default 1 + p/2)")
    p.add_argument("--relaxation", type=float, default=1.0)
    p.add_argument("--workdir", type=Path, default=Path("/tmp/periodic_iteration"))
    p.add_argument("--json", type=Path, help="write the rows here")
    p.add_argument(
        "--stand-in-drag",
        action="store_true",
        help="fast fluid only: add the edge drag on the followed motion (a check)",
    )
    p.add_argument("--blend", type=float, default=0.5, help="periods over which X_j -> X_j+1")
    args = p.parse_args()

    wall0 = time.perf_counter()
    case = load_case(args.case, [*args.overrides, f"time.periods={args.iterations + 2}"])
    cfd = case.fluid.model.value == "openfoam"
    factory = openfoam_fluid_factory(args.workdir, fresh=True) if cfd else None
    run = build_coupled_run(case, factory)
    solid, coupling = run.solid, run.coupling
    fluid, mapping, model = coupling.fluid, coupling.mapping, solid.model
    if coupling.added_mass_z is None or solid.orbit is None:
        raise SystemExit("needs an *-am scheme and a periodic start (the case's defaults)")
    n = windows_per_period(case)
    period = 1.0 / case.actuation.frequency_hz
    dt = period / n
    structure = PeriodicStructure(
        case, model, solid.orbit.x_static, coupling.added_mass_z, args.harmonics, args.modes
    )
    orbit = structure.damped_orbit(solid.orbit)
    setup_s = time.perf_counter() - wall0

    def motion_of(response):
        return lambda t: response.at(t)[0].reshape(model.n_nodes, NDOF)[:, :3].copy()

    def follow(motion, times):
        start = time.perf_counter()
        if cfd:  # one pimpleFoam launch for the period
            forces = fluid.follow([mapping.consistent(motion(t)) for t in times], dt)
        else:  # a fast fluid, window by window (a check: it converges to the fast orbit)
            forces = [coupling.start_up._prescribed_window(motion, t, dt) for t in times]
            if args.stand_in_drag:  # the fast fluid's edge drag on the followed motion
                hh = 1e-4 * dt
                for m, t in enumerate(times):
                    v = np.zeros(model.ndof)
                    v[2::NDOF] = (motion(t + hh)[:, 2] - motion(t - hh)[:, 2]) / (2 * hh)
                    fd = structure.drag.force(model, None, v)[0][2::NDOF]
                    forces[m] = forces[m].copy()
                    forces[m][:, 2] -= fd
        return [mapping.conservative(f) for f in forces], time.perf_counter() - start

    # lead-in: one period of the start orbit, ramped over its first half
    start_orbit = motion_of(orbit)
    times = [(k - n) * dt for k in range(1, n + 1)]

    def ramped(t, first=times[0]):
        return smoothstep((t - first + dt) / (period / 2)) * start_orbit(t)

    _, lead_s = follow(ramped, times)
    per_window = lead_s / n
    print(f"set-up {setup_s:.1f} s, lead-in {lead_s:.1f} s ({per_window:.3f} s per window)")
    current, previous = orbit, ramped
    rows = []
    for j in range(args.iterations):
        t0 = j * period
        times = [t0 + m * dt for m in range(1, n + 1)]
        new = motion_of(current)

        def followed(t, old=previous, new=new, t0=t0):  # blended over --blend periods
            r = smoothstep((t - t0) / (period * args.blend)) if args.blend > 0 else 1.0
            return (1 - r) * old(t) + r * new(t)

        forces, fluid_s = follow(followed, times)
        # the force on the followed motion, F = F_CFD + M_a (a_followed - a_current): the
        # blend's extra acceleration carried by the fast inertia
        h = 1e-4 * dt
        loads = np.zeros((n, model.ndof))
        for m, (t, f) in enumerate(zip(times, forces, strict=True)):
            extra = (followed(t + h) - 2 * followed(t) + followed(t - h)) / h**2 - (
                new(t + h) - 2 * new(t) + new(t - h)
            ) / h**2
            loads[m, 0::NDOF], loads[m, 1::NDOF] = f[:, 0], f[:, 1]
            loads[m, 2::NDOF] = f[:, 2] + coupling.added_mass_z @ extra[:, 2]
        # loads(t_m) = sum_k Im(F_k e^{i k w t_m}): F_k = i (2/n) sum_m loads_m e^{-i k w t_m}
        fluid_h = {
            k: 1j * (2.0 / n) * (np.exp(-1j * k * structure.omega * np.array(times)) @ loads)
            for k in structure.ks
        }
        beta = structure.beta if args.beta is None else args.beta
        updated = structure.update(current, fluid_h, beta, args.relaxation)
        tip_now = np.array([followed(t)[structure.tip // NDOF, 2] for t in times])
        tip_next = updated.dof_history(np.array([structure.tip]), np.array(times))[:, 0]
        tip_old = current.dof_history(np.array([structure.tip]), np.array(times))[:, 0]
        wall = time.perf_counter() - wall0
        row = {
            "iteration": j + 1,
            "tail_amplitude_mm": 1e3 * float(np.ptp(tip_now) / 2),
            "mean_thrust_mn": -1e3 * float(np.mean([f[:, 0].sum() for f in forces])),
            "next_tail_amplitude_mm": 1e3 * float(np.ptp(tip_next) / 2),
            "tail_update": float(np.max(np.abs(tip_next - tip_old)) / (np.ptp(tip_next) / 2)),
            "fluid_s": fluid_s,
            "wall_s": wall,
            "prescribed_periods": wall / (n * per_window),
        }
        rows.append(row)
        print(json.dumps(row))
        previous, current = followed, updated
    if args.json:
        summary = {"setup_s": setup_s, "lead_in_s": lead_s, "beta": beta, "rows": rows}
        args.json.write_text(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
