"""Drivers on a small moving-mesh case (real OpenFOAM): restart fidelity, persistent = relaunch,
checkpoints, resume.

Exact-behaviour references: a continuous pimpleFoam run of N windows (one launch) for the
relaunch driver's N one-window launches (issue 4: same force to 1e-3 relative), the relaunch
driver for the persistent one (same force history to 1e-3), and the straight history for
windows solved three times (implicit coupling: persistent and relaunch, with and without
prelaunch, to 1e-9).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli.prescribed import mode_motion
from fluid_adapter.openfoam import build_openfoam_participant, runner
from fluid_adapter.openfoam.build import prepare_case
from fluid_adapter.openfoam.drivers import run_batch
from fluid_adapter.openfoam.fishmesh import FISH_PATCHES
from fluid_adapter.openfoam.foamrun import FoamRun, numeric_dirs
from fluid_adapter.openfoam.interface import read_interface
from fluid_adapter.openfoam.tankcase import flow_settings
from fsi_orchestrator.case.loader import case_from_dict
from fsi_orchestrator.case.schema import FluidDriver
from fsi_orchestrator.participant import DISPLACEMENT, FORCE

pytestmark = [
    pytest.mark.openfoam,
    pytest.mark.skipif(shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed"),
]

SCALE = 1.5  # coarse level x 1.5 cell size: about 9k cells
DT, N = 1 / 120, 8  # 3 Hz, 40 windows per period


@pytest.fixture(scope="module")
def setup():
    # World-searchable: as root the persistent driver runs OpenFOAM as `nobody`.
    root = Path(tempfile.mkdtemp(prefix="fishfsi-drivers-"))
    root.chmod(0o755)
    yield from _setup(root)
    shutil.rmtree(root, ignore_errors=True)


def _setup(root: Path):
    case = case_from_dict({"fluid": {"model": "openfoam", "mesh_level": "coarse"}}, root)
    template = root / "template"
    prepare_case(case, template, dt=DT, mesh_scale=SCALE, processes=1, reuse=False)
    interface = read_interface(template, FISH_PATCHES)
    FoamRun(template, interface, flow_settings(case)).init_samples()
    motion = mode_motion(case, interface.points0, 0.02, 3.0, ramp_periods=0.5)
    yield case, template, motion


def copy_of(template: Path, name: str) -> Path:
    target = template.parent / name
    shutil.copytree(template, target, symlinks=True)
    return target


def participant(setup, name: str, driver: FluidDriver):
    case, template, _ = setup
    folder = copy_of(template, name)
    return build_openfoam_participant(
        case, folder, dt=DT, n_windows=N, mesh_scale=SCALE, driver=driver
    )


def drive(p, motion, windows):
    forces = []
    for k in windows:
        p.read_data({DISPLACEMENT: motion.displacement(k * DT)})
        p.solve(DT)
        forces.append(p.monitor()["force_n"])
    return np.array(forces)


def relative(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.fixture(scope="module")
def relaunch_history(setup):
    p = participant(setup, "relaunch", FluidDriver.RELAUNCH)
    forces = drive(p, setup[2], range(1, N + 1))
    folders = [name for _, name in numeric_dirs(p.run.path)]
    p.finalize()
    return forces, folders, p.run.time_folder(N * DT, DT)


def test_one_window_relaunches_reproduce_a_continuous_run(setup, relaunch_history):
    case, template, motion = setup
    folder = copy_of(template, "continuous")
    run = FoamRun(folder, read_interface(folder, FISH_PATCHES), flow_settings(case))
    continuous = np.array([s.force for s in run_batch(run, motion.displacement, DT, N)])
    assert relative(relaunch_history[0], continuous) < 1e-3


def test_relaunch_keeps_only_the_restart_folder(relaunch_history):
    assert relaunch_history[1] == ["0", relaunch_history[2]]
    assert float(relaunch_history[2]) == pytest.approx(N * DT, rel=1e-13)


def test_persistent_driver_gives_the_relaunch_history(setup, relaunch_history):
    p = participant(setup, "persistent", FluidDriver.PERSISTENT)
    try:
        forces = drive(p, setup[2], range(1, N + 1))
        p.store_checkpoint()
        p.restore_checkpoint()  # same time: allowed
    finally:
        p.finalize()
    assert relative(forces, relaunch_history[0]) < 1e-3


LEAD = 3  # windows of prescribed motion in one launch before the repeated ones (the lead-in)


def solve_each_window_three_times(p, motion):
    """Implicit coupling's pattern after a lead-in: two wrong iterates, each restored, then the
    right one. Returns every solve's force."""
    p.follow([motion.displacement(k * DT) for k in range(1, LEAD + 1)], DT)
    forces = []
    for k in range(LEAD + 1, N + 1):
        p.store_checkpoint()
        for wrong in (1.3, 0.8):
            p.read_data({DISPLACEMENT: wrong * motion.displacement(k * DT)})
            p.solve(DT)
            forces.append(p.monitor()["force_n"])
            p.restore_checkpoint()
        forces.append(drive(p, motion, [k])[0])
    return np.array(forces)


@pytest.fixture(scope="module")
def repeated_history(setup):
    """The plain relaunch driver (one launch per solve, nothing ahead) through the pattern."""
    p = participant(setup, "repeat_reference", FluidDriver.RELAUNCH)
    try:
        return solve_each_window_three_times(p, setup[2])
    finally:
        p.finalize()


def test_a_repeated_window_ends_as_if_solved_once(setup, repeated_history):
    p = participant(setup, "led_in", FluidDriver.RELAUNCH)
    p.follow([setup[2].displacement(k * DT) for k in range(1, LEAD + 1)], DT)
    straight = drive(p, setup[2], range(LEAD + 1, N + 1))
    p.finalize()
    assert relative(repeated_history[2::3], straight) < 1e-9


@pytest.mark.parametrize(
    ("kind", "prelaunch"),
    [(FluidDriver.PERSISTENT, False), (FluidDriver.PERSISTENT, True), (FluidDriver.RELAUNCH, True)],
)
def test_repeated_windows_solve_alike_with_every_driver(setup, repeated_history, kind, prelaunch):
    """Restoring goes back to the checkpoint's folder: the persistent driver ends its process
    and goes on with one started there; with prelaunch that process (relaunch: the next
    launch) was started during the solve and waited at its start-up gate. Every solve, the
    wrong iterates too, gives the plain relaunch driver's force (a process started from the
    checkpoint named the window end's time 1e-16 differently from the one it replaced, and
    the stale loads were read: now deleted on restore)."""
    p = participant(setup, f"repeat_{kind.value}_{prelaunch}", kind)
    p.driver.prelaunch = prelaunch
    if prelaunch:
        runner.write_start_up_gate(p.run.path)
    try:
        forces = solve_each_window_three_times(p, setup[2])
        launches = p.driver.launches
    finally:
        p.finalize()
    assert relative(forces, repeated_history) < 1e-9
    windows = N - LEAD
    if kind is FluidDriver.PERSISTENT:
        # a new process for each repeat; the last one goes on into the next window
        assert launches == (1 + 3 * windows if prelaunch else 1 + 2 * windows)
    else:
        assert launches == 4 * windows
    assert not list(p.run.path.glob("*.fifo.*"))
    assert not _solvers_left()


def _solvers_left() -> str:
    """pimpleFoam processes this test process started and did not end (pgrep's output)."""
    found = subprocess.run(
        ["pgrep", "-P", str(os.getpid()), "-x", "pimpleFoam"], capture_output=True, text=True
    )
    return found.stdout.strip()


def test_restored_window_solves_again_as_if_first_time(setup, relaunch_history):
    motion = setup[2]
    p = participant(setup, "implicit", FluidDriver.RELAUNCH)
    drive(p, motion, [1, 2])
    p.store_checkpoint()
    p.read_data({DISPLACEMENT: 1.5 * motion.displacement(3 * DT)})  # a wrong first iterate
    p.solve(DT)
    wrong = p.monitor()["force_n"]
    p.restore_checkpoint()
    assert p.time == pytest.approx(2 * DT)
    again = drive(p, motion, [3])[0]
    p.finalize()
    assert relative(again, relaunch_history[0][2]) < 1e-9
    assert relative(wrong, relaunch_history[0][2]) > 1e-2


def test_nodal_forces_sum_to_the_total(setup):
    p = participant(setup, "nodal", FluidDriver.RELAUNCH)
    drive(p, setup[2], [1])
    data = p.write_data()
    p.finalize()
    np.testing.assert_allclose(data[FORCE].sum(axis=0), p.monitor()["force_n"], atol=1e-12)
    assert data["face_force"].shape == (p.interface().cells.shape[0], 3)


def test_saved_state_resumes_a_killed_run(setup, relaunch_history):
    case, _, motion = setup
    p = participant(setup, "resume", FluidDriver.RELAUNCH)
    drive(p, motion, range(1, 5))
    state = p.save_state()
    drive(p, motion, [5])  # the run goes on, then "dies"
    p.finalize()  # its gated spare would otherwise wait out the test session
    fresh = build_openfoam_participant(
        case, p.run.path, dt=DT, n_windows=N, mesh_scale=SCALE, driver=FluidDriver.RELAUNCH
    )
    fresh.load_state(state)
    assert fresh.time == pytest.approx(4 * DT)
    resumed = drive(fresh, motion, [5, 6])
    fresh.finalize()
    assert relative(resumed, relaunch_history[0][4:6]) < 1e-6


def test_a_checkpoint_whose_flow_is_gone_does_not_load(setup):
    """A fluid folder generated afresh (its settings changed) holds no flow at the
    checkpoint's time: the state is refused at once (the loop's one-line ResumeError), not
    when the next window finds no start folder."""
    case, _, motion = setup
    p = participant(setup, "lost", FluidDriver.RELAUNCH)
    drive(p, motion, range(1, 3))
    state = p.save_state()
    p.finalize()
    p.run.remove_times({"0"})
    fresh = build_openfoam_participant(
        case, p.run.path, dt=DT, n_windows=N, mesh_scale=SCALE, driver=FluidDriver.RELAUNCH
    )
    with pytest.raises(ValueError, match="holds no flow at the checkpoint's t = 0.0166667 s"):
        fresh.load_state(state)
    fresh.finalize()


def test_prescribed_windows_in_one_launch_continue_as_relaunched_windows(setup, relaunch_history):
    """The coupling's lead-in hands the fluid its prescribed windows at once (``follow``): one
    pimpleFoam launch instead of one per window. Its forces are the relaunched ones (as a
    continuous run's: 1e-3), and the relaunch driver goes on from where it stopped."""
    p = participant(setup, "follow", FluidDriver.RELAUNCH)
    motion = setup[2]
    half = N // 2
    nodal = p.follow([motion.displacement(k * DT) for k in range(1, half + 1)], DT)
    assert p.time == pytest.approx(half * DT, rel=1e-12)
    totals = np.array([f.sum(axis=0) for f in nodal])
    np.testing.assert_allclose(totals[-1], p.monitor()["force_n"], rtol=1e-9, atol=1e-12)
    later = drive(p, motion, range(half + 1, N + 1))
    p.finalize()
    forces, _, last_folder = relaunch_history
    assert relative(np.vstack([totals, later]), forces) < 1e-3
    assert [name for _, name in numeric_dirs(p.run.path)] == ["0", last_folder]
