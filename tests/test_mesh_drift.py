"""The moved mesh's drift and its reset (fluid_adapter/openfoam/rest_mesh.py), real OpenFOAM.

Exact-behaviour references: a mesh moved from rest by a zero displacement is the mesh at rest,
and a mesh moved from rest depends on the plate's shape only, not on the path that led there.
``velocityLaplacian`` (the shipped motion solver) has neither property: after whole periods of
a 31 mm first-mode swing its inner points lie off the rest mesh (0.8 mm per period on the
coarse level).
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from scipy.spatial import cKDTree

from fishfsi.cli.prescribed import mode_motion
from fluid_adapter.openfoam import build_openfoam_participant
from fluid_adapter.openfoam.drivers import run_mesh_motion
from fluid_adapter.openfoam.foamio import read_points
from fluid_adapter.openfoam.rest_mesh import DRIFT_LIMIT_M, DriftSchedule, reset_points
from fsi_orchestrator.case.loader import case_from_dict
from fsi_orchestrator.case.schema import FluidDriver
from fsi_orchestrator.participant import DISPLACEMENT

needs_openfoam = pytest.mark.skipif(
    shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed"
)

SCALE = 1.5  # coarse level x 1.5 cell size: about 9k cells
AMPLITUDE_M = 0.031  # the default level's 1 Hz tail amplitude, coupled (docs/validation.md)
PER_PERIOD = 20


def test_the_schedule_follows_the_fastest_drift_measured():
    schedule = DriftSchedule(first=40, longest=400)
    assert not schedule.due(39) and schedule.due(40)
    schedule.record(40, 0.5e-3)  # 1.25e-5 m per window: 80 windows to the 1 mm limit
    assert schedule.next_at == 120
    schedule.record(120, 4e-3)  # 20 windows to the limit: but at most once a period
    assert schedule.next_at == 160
    # a reset that finds no drift (a resumed run repeating one) keeps the pace
    schedule.record(160, 0.0)
    assert schedule.next_at == 200
    assert DRIFT_LIMIT_M == 1e-3
    slow = DriftSchedule(first=40, longest=400)
    slow.record(40, 0.0)  # no drift at all: not again before the longest interval
    assert slow.next_at == 440
    assert not DriftSchedule(first=0, longest=400).due(400)  # 0: never


@pytest.fixture(scope="module")
def fish(tmp_path_factory):
    root = tmp_path_factory.mktemp("drift")
    case = case_from_dict(
        {
            "fluid": {"model": "openfoam", "mesh_level": "coarse", "driver": "relaunch"},
            "actuation": {"frequency_hz": 3.0},
        },
        root,
    )
    return case, root


@pytest.mark.openfoam
@needs_openfoam
def test_a_reset_undoes_the_drift_and_forgets_the_path(fish):
    case, root = fish
    dt = 1 / (3.0 * PER_PERIOD)
    n = round(2.25 * PER_PERIOD)  # ends on a peak; whole periods end flat
    p = build_openfoam_participant(
        case, root / "mesh", dt=dt, n_windows=n, mesh_scale=SCALE, reuse=False
    )
    run = p.run
    motion = mode_motion(case, run.interface.points0, AMPLITUDE_M, 3.0, ramp_periods=0.5)
    run_mesh_motion(run, motion.displacement, dt, n, write_every=PER_PERIOD // 4)
    rest = read_points(run.path / "constant" / "polyMesh" / "points")

    flat = run.time_folder(2 * PER_PERIOD * dt, dt)  # two whole periods: the plate is flat
    followed = read_points(run.path / flat / "polyMesh" / "points")
    drift = np.linalg.norm(followed - rest, axis=1).max()
    assert drift > 1e-3  # velocityLaplacian does not come back
    shift = reset_points(run, flat, motion.displacement(2 * PER_PERIOD * dt), dt)
    assert shift == pytest.approx(drift, rel=1e-6)
    back = read_points(run.path / flat / "polyMesh" / "points")
    assert np.abs(back - rest).max() < 1e-9  # the rest mesh itself

    peaks = [round(k * PER_PERIOD) for k in (1.25, 2.25)]  # the same shape twice
    names = [run.time_folder(k * dt, dt) for k in peaks]
    followed = [read_points(run.path / name / "polyMesh" / "points") for name in names]
    assert np.abs(followed[1] - followed[0]).max() > 0.5e-3  # one more period's drift
    for k, name in zip(peaks, names, strict=True):
        reset_points(run, name, motion.displacement(k * dt), dt)
    reset = [read_points(run.path / name / "polyMesh" / "points") for name in names]
    assert np.abs(reset[1] - reset[0]).max() < 1e-9
    plate = run.interface.points0 + motion.displacement(peaks[1] * dt)  # the plate stays put
    assert cKDTree(reset[1]).query(plate)[0].max() < 1e-9


@pytest.mark.openfoam
@needs_openfoam
def test_a_run_resets_once_a_period_and_its_forces_barely_notice(fish):
    """The participant resets its mesh at the window the schedule names, and its forces
    stay within 0.3 % of the lateral force's swing of the same run without the reset."""
    case, root = fish
    dt, n = 1 / (3.0 * PER_PERIOD), PER_PERIOD + 3
    forces = {}
    resets = {}
    for first in (PER_PERIOD, 0):
        p = build_openfoam_participant(
            case,
            root / f"flow{first}",
            dt=dt,
            n_windows=n,
            mesh_scale=SCALE,
            driver=FluidDriver.RELAUNCH,
            reuse=False,
        )
        p.drift = DriftSchedule(first=first, longest=n)
        motion = mode_motion(case, p.run.interface.points0, AMPLITUDE_M, 3.0, ramp_periods=0.5)
        history = []
        for k in range(1, n + 1):
            p.read_data({DISPLACEMENT: motion.displacement(k * dt)})
            p.solve(dt)
            history.append(p.monitor()["force_n"])
        if first:  # a resume keeps the schedule: its pace and its record
            state = p.save_state()
            schedule = (p.drift.next_at, p.mesh_resets)
            p.drift = DriftSchedule(first=first, longest=n)
            p.load_state(state)
            assert (p.drift.next_at, p.mesh_resets) == schedule
        p.finalize()
        forces[first], resets[first] = np.array(history), p.mesh_resets
    assert [window for window, _ in resets[PER_PERIOD]] == [PER_PERIOD] and not resets[0]
    assert resets[PER_PERIOD][0][1] > 0.2e-3
    swing = np.ptp(forces[0][:, 2])
    gap = np.abs(forces[PER_PERIOD] - forces[0])[:, 2] / swing
    assert gap[:PER_PERIOD].max() < 1e-9  # the same run up to the reset
    assert gap[PER_PERIOD:].max() < 0.003  # measured 0.07 % at the reset, 0.03 % after
