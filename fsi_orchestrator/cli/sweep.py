"""``fsi-sweep CASE``: tail amplitude and slender-body thrust over driving frequencies.

``--method linear`` (default, seconds): the wet shell's linear periodic response per frequency
and harmonic (the added mass is computed once), thrust by Lighthill's theory on that motion.
``--method transient``: the nonlinear time-domain run per frequency (as ``fsi-run``); with
OpenFOAM and iqn-ils-am each point starts from the quasi-Newton Jacobian the previous point on
the same MPI rank learned (``coupling.jacobian_from``: fewer fluid solves, the same result to
the coupling tolerance).
Writes ``sweep.csv`` and ``sweep.json`` to the output folder and prints a table.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..case import Case, CaseError
from ..case.schema import FluidModel, Waveform
from .common import EXIT_FAILED, EXIT_OK, base_parser, emit, load, run_main, to_jsonable
from .compose import shell_with_fast_fluid, without_cfd

SAMPLES_PER_PERIOD = 64
MODES = 40  # wet modes in the superposition (with static correction), up to ~300 Hz


def parse_frequencies(text: str) -> list[float]:
    """ "1:25:2" -> 1, 3, ..., 25; "3,5,10" -> those."""
    usage = f"--frequencies {text!r}: use start:stop:step or a,b,c (Hz, all > 0)"
    try:
        if ":" in text:
            start, stop, step = (float(v) for v in text.split(":"))
            if not step > 0:
                raise ValueError
            frequencies = list(np.arange(start, stop + 0.5 * step, step))
        else:
            frequencies = [float(v) for v in text.split(",")]
    except ValueError:
        raise CaseError(usage) from None
    if not frequencies or not all(np.isfinite(f) and f > 0 for f in frequencies):
        raise CaseError(usage)
    return frequencies


def with_drive(case: Case, frequency_hz: float, waveform: Waveform) -> Case:
    actuation = dataclasses.replace(case.actuation, frequency_hz=frequency_hz, waveform=waveform)
    return dataclasses.replace(case, actuation=actuation)


def linear_sweep(case: Case, frequencies: list[float], waveforms: list[Waveform]) -> list[dict]:
    from fluid_adapter.slender_body import mean_thrust_from_shell
    from solid_adapter.build import mean_voltage_equilibrium, rayleigh_coefficients, static_loads
    from solid_adapter.harmonic import (
        ModalSweep,
        harmonic_load,
        mean_voltage_tangent,
        sweep_response,
    )
    from solid_adapter.piezo import DriveSignal

    model, _ = shell_with_fast_fluid(case)
    drive0 = DriveSignal.from_case(case)
    x_static = mean_voltage_equilibrium(case, model, drive0, static_loads(case, model))
    sweep = ModalSweep.build(
        model,
        harmonic_load(model, drive0, x_static),
        MODES,
        rayleigh_coefficients(case, model),
        stiffness=mean_voltage_tangent(model, x_static, drive0),
    )
    midline = _midline(model)
    xs = model.mesh.nodes[midline, 0]
    half_height = model.layout.height(xs) / 2
    tip = model.mesh.nearest_node(*model.layout.tip_point)
    rows = []
    for waveform in waveforms:
        for f in frequencies:
            drive = DriveSignal.from_case(with_drive(case, f, waveform))
            response = sweep_response(sweep, drive, x_static)
            times = np.arange(SAMPLES_PER_PERIOD + 1) / (SAMPLES_PER_PERIOD * f)
            h = response.dof_history(midline * 5 + 2, times)
            tip_z = response.dof_history(np.array([tip * 5 + 2]), times)[:, 0]
            thrust = mean_thrust_from_shell(
                xs,
                half_height,
                times,
                h,
                density_kg_m3=case.fluid.density_kg_m3,
                period_s=1.0 / f,
                added_mass_coefficient=case.fluid.added_mass_coefficient,
            )
            rows.append(
                {
                    "waveform": waveform.value,
                    "frequency_hz": float(f),
                    "tip_amplitude_m": float(np.ptp(tip_z) / 2),
                    "slender_body_mean_thrust_n": float(thrust),
                }
            )
    return rows


def transient_sweep(
    case: Case, frequencies: list[float], waveforms: list[Waveform], output: Path
) -> list[dict]:
    """One nonlinear run per (waveform, frequency). Under ``mpiexec`` (mpi4py) the runs are
    dealt round-robin to the ranks and gathered on rank 0; other ranks return []."""
    from solid_adapter.solvers import SolverError

    from .run import run_dynamic

    jobs = [(w, f) for w in waveforms for f in frequencies]
    comm = mpi_world()
    rank, size = (comm.Get_rank(), comm.Get_size()) if comm is not None else (0, 1)
    mine = []
    learned = None  # the last finished point's output: its quasi-Newton Jacobian
    for index in range(rank, len(jobs), size):
        waveform, f = jobs[index]
        folder = output / f"{waveform.value}_{f:g}Hz"
        point = with_drive(case, f, waveform)
        if learned is not None:
            point = chained(point, learned)
        try:  # one failed frequency (a CFD crash near resonance) must not lose the others
            summary = run_dynamic(point, folder, resume=False, show_progress=False)
            status = "ok" if "start_from_rest" not in summary else "ok (started from rest)"
            learned = folder
        except (SolverError, RuntimeError) as err:
            summary, status = {}, f"failed: {err}".splitlines()[0]
            print(f"{waveform.value} {f:g} Hz {status} (output kept in {folder})", file=sys.stderr)
        nan = float("nan")
        mine.append(
            (
                index,
                {
                    "waveform": waveform.value,
                    "frequency_hz": float(f),
                    "tip_amplitude_m": summary.get("tip_amplitude_m", nan),
                    "mean_thrust_n": summary.get("mean_thrust_n", nan),
                    "thrust_source": summary.get("thrust_source", ""),
                    "slender_body_mean_thrust_n": summary.get("slender_body_mean_thrust_n", nan),
                    "mean_fluid_solves_per_window": summary.get(
                        "mean_fluid_solves_per_window", 1.0 if summary else nan
                    ),
                    # a start-up not yet settled (fsi-run's note): the point's figures are
                    # its last period's, not the periodic state's
                    "tip_amplitude_change_last_period": summary.get(
                        "tip_amplitude_change_last_period", nan
                    ),
                    "status": status,
                },
            )
        )
    gathered = comm.gather(mine, root=0) if comm is not None else [mine]
    if rank != 0:
        return []
    return [row for _, row in sorted(item for part in gathered for item in part)]


def chained(case: Case, previous: Path) -> Case:
    """The next point of a sweep starts its quasi-Newton Jacobian from the one the previous
    point learned (same shell, another drive: coarse fish, 3 -> 5 Hz, 3.53 -> 3.20 fluid
    solves per window in period 1), unless the case names its own coupling.jacobian_from.
    The results agree to the coupling tolerance with a cold start."""
    from ..case.schema import CouplingScheme
    from ..results import CHECKPOINT_FILE

    c = case.coupling
    chainable = (
        c.scheme is CouplingScheme.IQN_ILS_AM
        and not c.jacobian_from
        and case.fluid.model is FluidModel.OPENFOAM
        and (previous / CHECKPOINT_FILE).is_file()
    )
    if not chainable:
        return case
    coupling = dataclasses.replace(c, jacobian_from=str(previous.resolve()))
    return dataclasses.replace(case, coupling=coupling)


def mpi_world():
    """MPI.COMM_WORLD when launched by mpiexec/srun with more than one rank, else None."""
    import os

    if not any(
        k in os.environ for k in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "SLURM_NTASKS")
    ):
        return None
    try:
        from mpi4py import MPI
    except ImportError:
        return None
    return MPI.COMM_WORLD if MPI.COMM_WORLD.Get_size() > 1 else None


def _midline(model) -> np.ndarray:
    nodes = model.mesh.nodes
    on_axis = np.flatnonzero(np.abs(nodes[:, 1]) < 1e-12 * model.layout.length_m)
    return on_axis[np.argsort(nodes[on_axis, 0])]


def write_tables(rows: list[dict], output: Path) -> None:
    output.mkdir(parents=True, exist_ok=True)
    with open(output / "sweep.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (output / "sweep.json").write_text(json.dumps(to_jsonable(rows), indent=1))


def print_table(rows: list[dict]) -> None:
    print(f"{'waveform':>8} {'f [Hz]':>7} {'tip amplitude [mm]':>19} {'thrust [mN]':>12}")
    for r in rows:
        thrust = r.get("mean_thrust_n", r["slender_body_mean_thrust_n"])
        print(
            f"{r['waveform']:>8} {r['frequency_hz']:7.2f} {1e3 * r['tip_amplitude_m']:19.2f} "
            f"{1e3 * thrust:12.2f}  {r.get('status', '')}"
        )


def _body(args: argparse.Namespace) -> int:
    case = load(args)
    frequencies = parse_frequencies(args.frequencies)
    names = "sine,square" if args.waveforms.strip() == "both" else args.waveforms
    try:
        waveforms = [Waveform(w.strip()) for w in names.split(",")]
    except ValueError:
        raise CaseError(
            f"--waveforms {args.waveforms!r}: use sine, square, sine,square or both"
        ) from None
    output = Path(args.output) if args.output else case.directory / "output" / "sweep"
    start = time.perf_counter()
    if args.method == "linear":
        case = without_cfd(case)
        if case.fluid.model is not FluidModel.NONE and case.fluid.damping_ratio == 0:
            print(
                "note: fluid.damping_ratio = 0: the linear sweep has no damping, so near the "
                "wet resonances its amplitudes grow without bound; e.g. --set "
                "fluid.damping_ratio=0.05",
                file=sys.stderr,
            )
        rows = linear_sweep(case, frequencies, waveforms)
    else:
        rows = transient_sweep(case, frequencies, waveforms, output)
        if not rows:  # an MPI rank other than 0: rank 0 writes and prints
            return EXIT_OK
    write_tables(rows, output)
    if args.json:
        emit({"rows": rows, "wall_s": time.perf_counter() - start, "output": str(output)}, True)
    else:
        print_table(rows)
        print(f"wrote {output / 'sweep.csv'} ({time.perf_counter() - start:.1f} s)")
    failed = any(r.get("status", "ok").startswith("failed") for r in rows)
    return EXIT_FAILED if failed else EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    parser = base_parser("fsi-sweep", "Tail amplitude and thrust versus driving frequency.")
    parser.add_argument("--frequencies", default="1:25:2", help="start:stop:step or a,b,c Hz")
    parser.add_argument("--waveforms", default="sine,square", help="sine, square or both")
    parser.add_argument(
        "--method",
        choices=("linear", "transient"),
        default="linear",
        help="linear: modal superposition about the mean-voltage equilibrium, no CFD (an "
        "OpenFOAM case uses the potential model in its tank; seconds); transient: a run per "
        "frequency with the case's own fluid (MPI: one frequency per rank)",
    )
    parser.add_argument("--output", help="output folder (default: CASE/output/sweep)")
    return run_main(_body, parser, argv)


if __name__ == "__main__":
    raise SystemExit(main())
