"""Stability stress harness: the seed's beam (Table 3.2, piezo-driven) in a potential-flow liquid
run as a separate participant, over structure/fluid density ratios and time steps, for every
coupling scheme: fluid solves per window, or the detected divergence.

The fluid density is scaled so that rho_s/rho_f spans 1e-2..1e2 (rho_s: the laminate's mean
density). The *-am schemes are preconditioned with a coarser potential-flow added mass than
the one that plays the fluid (as the potential model differs from OpenFOAM's discrete added
mass).

    .venv/bin/python benchmarks/stability.py [--quick] [--json] [--cfd-like 1.0]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.compose import coupled_setup  # noqa: E402
from fluid_adapter.fast import fast_added_mass  # noqa: E402
from fluid_adapter.potential.participant import PotentialParticipant  # noqa: E402
from fsi_orchestrator.case.loader import case_from_dict  # noqa: E402
from fsi_orchestrator.convergence import CouplingDivergenceError  # noqa: E402
from fsi_orchestrator.loop import OutputSettings, Schedule, WindowLoop  # noqa: E402
from fsi_orchestrator.participant import DISPLACEMENT, PAST_DISPLACEMENT, VELOCITY  # noqa: E402
from solid_adapter.build import build_shell_model  # noqa: E402
from solid_adapter.solvers import AddedMassAsForce  # noqa: E402

SCHEMES = ("explicit", "constant", "aitken", "iqn-ils", "iqn-ils-am", "explicit-am")
# the fluid's and the preconditioner's potential-flow meshes: a different discretisation plays
# the model error a real fluid has (fine vs default is closer; coarse vs default is cheaper)
FLUID_LEVEL, PRECONDITIONER_LEVEL = "default", "coarse"
DRIVE_HZ = 5.0  # below the beam's first wet mode in FC-3283 (10.1 Hz)
BDF2_OF_BDF2 = (2.25, -6.0, 5.5, -2.0, 0.25)  # OpenFOAM backward: mesh flux, then ddt(U)
BEAM_MEAN_DENSITY = 3919.0  # kg/m^3: (1643 x 0.2 + 5440 x 0.3 x 7/8) mm / 0.5 mm, Table 3.2


def beam_case(
    density_ratio: float,
    steps_per_period: int,
    scheme: str,
    relaxation: float | None,
    max_iterations: int,
    tolerance_rel: float = 1e-4,
    periods: float = 0.5,
    explicit_periods: int = 0,
):
    coupling = {
        "scheme": scheme,
        "partitioned": True,
        "tolerance_rel": tolerance_rel,
        "max_iterations": max_iterations,
        "added_mass_model": "potential",
        "added_mass_mesh_level": PRECONDITIONER_LEVEL,
    }
    if relaxation is not None:
        coupling["relaxation"] = relaxation
    if explicit_periods:
        coupling["explicit_periods"] = explicit_periods
    return case_from_dict(
        {
            "geometry": {"kind": "beam"},
            "actuation": {"frequency_hz": DRIVE_HZ},
            "time": {"periods": periods, "steps_per_period": steps_per_period},
            "fluid": {
                "model": "potential",
                "density_kg_m3": BEAM_MEAN_DENSITY / density_ratio,
                "mesh_level": FLUID_LEVEL,
                "domain_diameter_m": 0.2,
            },
            "coupling": coupling,
            "mesh": {"level": "coarse"},
            "output": {"vtk": False},
        },
        Path("."),
    )


def cfd_like_fluid(mass_factor: float):
    """A fluid factory for coupled_setup: the potential liquid with ``mass_factor`` times the
    added mass, differentiating the displacements it is given like OpenFOAM's backward scheme
    (BDF2 of BDF2), its history started on the structure's initial motion."""

    def factory(case, solid):
        true = fast_added_mass(case, build_shell_model(case))
        true = dataclasses.replace(true, matrix=mass_factor * true.matrix)
        fluid = PotentialParticipant(true, solid.interface(), stencil=BDF2_OF_BDF2)
        dt = 1 / (case.actuation.frequency_hz * case.time.steps_per_period)
        motion = solid.write_data()
        past = [motion[DISPLACEMENT] - k * dt * motion[VELOCITY] for k in range(len(BDF2_OF_BDF2))]
        fluid.initialize_history({PAST_DISPLACEMENT: np.array(past)})
        return fluid

    return factory


def run(
    density_ratio: float,
    steps: int,
    scheme: str,
    relaxation: float | None = None,
    max_iterations: int = 100,
    windows: int | None = None,
    tolerance_rel: float = 1e-4,
    fluid_factory=None,
    structure_stencil: bool = True,
    explicit_periods: int = 0,
) -> dict:
    """One period of the beam driven at DRIVE_HZ (``windows`` to shorten it). ``fluid_factory``:
    another fluid (cfd_like_fluid); ``structure_stencil`` False: the added mass weighted with
    the structure's own acceleration even where the fluid differentiates otherwise;
    ``explicit_periods``: iqn-ils-am's one-solve-per-window start-up."""
    n_windows = windows or steps
    case = beam_case(
        density_ratio,
        steps,
        scheme,
        relaxation,
        max_iterations,
        tolerance_rel,
        periods=max(0.5, n_windows / steps),
        explicit_periods=explicit_periods,
    )
    solid, coupling = coupled_setup(case, fluid_factory)
    if not structure_stencil and solid.integrator.added_mass_as_force is not None:
        solid.integrator.added_mass_as_force = AddedMassAsForce(stencil=None)
    schedule = Schedule(dt=1 / (DRIVE_HZ * steps), n_windows=n_windows)
    with tempfile.TemporaryDirectory() as tmp:
        loop = WindowLoop(
            solid,
            schedule,
            OutputSettings(directory=Path(tmp), vtk=False, checkpoint_every=10**6),
            None,
            coupling,
        )
        start = time.perf_counter()
        try:
            path = loop.run()
        except CouplingDivergenceError as err:
            return {
                "diverged": True,
                "window": err.window,
                "message": str(err)[:120],
                "wall_s": time.perf_counter() - start,
            }
        with h5py.File(path) as h5:
            solves = h5["coupling/fluid_solves"][:, 0]
            converged = h5["coupling/converged"][:, 0]
            iterated = h5["coupling/iterated"][:, 0] > 0
            tip_z = h5["shell/tip_displacement_m"][:, 2]
    return {
        "diverged": False,
        "mean_solves": float(solves.mean()),
        "max_solves": int(solves.max()),
        "unconverged": int((converged[iterated] == 0).sum()),
        "solves": solves.tolist(),
        "wall_s": time.perf_counter() - start,
        "tip_z_m": tip_z.tolist(),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", action="store_true")
    parser.add_argument(
        "--cfd-like",
        type=float,
        metavar="FACTOR",
        help="the fluid differentiates displacements like OpenFOAM (BDF2 of BDF2) with FACTOR "
        "times the added mass (cfd_like_fluid)",
    )
    args = parser.parse_args()
    factory = cfd_like_fluid(args.cfd_like) if args.cfd_like else None
    ratios = (1e-2, 1.0, 1e2) if args.quick else (1e-2, 1e-1, 1.0, 1e1, 1e2)
    steps_list = (20,) if args.quick else (20, 80)
    table = []
    for ratio in ratios:
        for steps in steps_list:
            for scheme in SCHEMES:
                result = run(ratio, steps, scheme, fluid_factory=factory)
                table.append(
                    {"density_ratio": ratio, "steps_per_period": steps, "scheme": scheme, **result}
                )
                r = table[-1]
                status = (
                    f"DIVERGED (detected, window {r['window']})"
                    if r["diverged"]
                    else f"{r['mean_solves']:6.2f} mean, {r['max_solves']:3d} max, "
                    f"{r['unconverged']} unconverged"
                )
                print(
                    f"rho_s/rho_f {ratio:7.0e}  steps/period {steps:3d}  {scheme:12s} "
                    f"{status}  ({r['wall_s']:.1f} s)",
                    flush=True,
                )
    if args.json:
        print(json.dumps(table))


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
