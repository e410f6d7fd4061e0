"""The flume (issue 31, CFD check of the swimming model): the tank with an inlet and an outlet,
the free fish's periodic motion prescribed in it (fishfsi/cli/flume.py).

References: a flat plate held still in a uniform stream feels its skin friction only, between
the laminar (Blasius, C_f = 1.328 / sqrt(Re)) and the fully turbulent (ITTC 1957,
0.075 / (log10 Re - 2)^2) lines (Schlichting, Boundary-Layer Theory, eq. 7.34; ITTC 1957).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fluid_adapter.openfoam.casefiles import FlowSettings, initial_fields
from fluid_adapter.openfoam.fishmesh import (
    INLET,
    LEVELS,
    OUTLET,
    WALLS,
    tank_geometry,
    tank_topology,
)
from fluid_adapter.openfoam.prescribed import PeriodicMotion
from fsi_orchestrator.case import CaseError
from fsi_orchestrator.case.loader import case_from_dict, load_case
from fsi_orchestrator.case.planform import planform
from fsi_orchestrator.case.schema import MeshLevel, TimeScheme, Turbulence

ROOT = Path(__file__).resolve().parents[1]
FLUME = ROOT / "cases" / "flume_original_18Hz"
OPENFOAM = pytest.mark.skipif(shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed")


def settings(inflow: float) -> FlowSettings:
    flume = inflow > 0
    return FlowSettings(
        nu_m2_s=0.75e-6,
        rho_kg_m3=1820.0,
        turbulence=Turbulence.K_OMEGA_SST,
        time_scheme=TimeScheme.BACKWARD,
        body_patches=("fishPlusZ", "fishMinusZ"),
        wall_patches=("walls",),
        open_patches=("top",),
        inflow_m_s=inflow,
        inlet_patches=("inlet",) if flume else (),
        outlet_patches=("outlet",) if flume else (),
    )


def test_flume_fields_have_an_inlet_an_outlet_and_slip_walls():
    fields = initial_fields(settings(0.8))
    u, p = fields["U"], fields["p"]
    assert u["internalField"] == [0.8, 0.0, 0.0]
    assert u["boundaryField"]["inlet"] == {"type": "fixedValue", "value": [0.8, 0.0, 0.0]}
    assert u["boundaryField"]["outlet"]["type"] == "inletOutlet"
    assert p["boundaryField"]["outlet"] == {"type": "fixedValue", "value": 0.0}
    assert p["boundaryField"]["inlet"] == {"type": "zeroGradient"}
    for patch in ("walls", "top"):
        assert u["boundaryField"][patch] == {"type": "slip"}
        assert fields["k"]["boundaryField"][patch] == {"type": "zeroGradient"}
    # 1 % intensity, nut = nu at the inlet
    k = fields["k"]["boundaryField"]["inlet"]["value"]
    omega = fields["omega"]["boundaryField"]["inlet"]["value"]
    assert k == pytest.approx(1.5 * (0.01 * 0.8) ** 2)
    assert k / omega == pytest.approx(0.75e-6)
    # the mesh holds still at the openings
    motion = fields["pointMotionU"]["boundaryField"]
    assert motion["inlet"] == motion["outlet"] == {"type": "fixedValue", "value": [0.0, 0.0, 0.0]}
    # the body keeps its moving wall
    assert u["boundaryField"]["fishPlusZ"]["type"] == "movingWallVelocity"


def test_closed_tank_fields_are_unchanged_without_inflow():
    fields = initial_fields(settings(0.0))
    assert fields["U"]["internalField"] == [0.0, 0.0, 0.0]
    assert fields["U"]["boundaryField"]["walls"] == {"type": "noSlip"}
    assert "inlet" not in fields["U"]["boundaryField"]


def test_flume_mesh_turns_the_front_and_back_walls_into_inlet_and_outlet():
    tank = case_from_dict({"fluid": {"model": "openfoam", "mesh_level": "coarse"}}, ROOT)
    flume = case_from_dict(
        {"fluid": {"model": "openfoam", "mesh_level": "coarse", "inflow_m_s": 0.5}}, ROOT
    )
    res = LEVELS[MeshLevel.COARSE]
    closed = tank_topology(tank_geometry(tank), res).patches
    opened = tank_topology(tank_geometry(flume), res).patches
    assert INLET not in closed and closed[WALLS][0] == "wall"
    assert opened[WALLS][0] == "patch"  # slip: no wall distance for the turbulence model
    n_inlet, n_outlet = len(opened[INLET][1]), len(opened[OUTLET][1])
    assert n_inlet == n_outlet > 0
    assert len(closed[WALLS][1]) == len(opened[WALLS][1]) + n_inlet + n_outlet
    vertices = tank_topology(tank_geometry(flume), res).vertices
    front = -tank_geometry(flume).x_front
    for face in opened[INLET][1]:
        assert np.allclose(vertices[list(face), 0], -front)


def test_periodic_motion_is_the_harmonics_after_the_ramp():
    rng = np.random.default_rng(0)
    harmonics = [(k, rng.normal(size=(4, 3)) + 1j * rng.normal(size=(4, 3))) for k in (1, 3)]
    motion = PeriodicMotion(harmonics=harmonics, frequency_hz=18.0, ramp_periods=0.5)
    assert np.all(motion.displacement(0.0) == 0)
    t = 0.7 / 18.0
    expected = sum(np.imag(X * np.exp(1j * k * 2 * np.pi * 18.0 * t)) for k, X in harmonics)
    assert np.allclose(motion.displacement(t), expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        (["fluid.model=potential", "fluid.inflow_m_s=0.5"], "fluid.inflow_m_s"),
        (["fluid.inflow_m_s=-0.5"], "fluid.inflow_m_s"),
        (["fluid.inflow_m_s=nan"], "fluid.inflow_m_s"),
        (["swimming.speed_m_s=0"], "swimming.speed_m_s"),
    ],
)
def test_bad_flume_input_names_the_key(overrides, named):
    with pytest.raises(CaseError, match=named.replace(".", r"\.")):
        load_case(FLUME, overrides=overrides)


def test_a_flume_inflow_other_than_the_swimming_speed_is_refused_naming_it():
    from fishfsi.cli.flume import flume_case

    case = load_case(FLUME, overrides=["fluid.inflow_m_s=0.3"])
    with pytest.raises(
        CaseError, match=r"fluid\.inflow_m_s = 0\.3: .*swimming\.speed_m_s \(0\.8\)"
    ):
        flume_case(case)
    assert flume_case(load_case(FLUME)).fluid.inflow_m_s == 0.8


def test_the_flume_case_runs_its_fast_model_at_the_flume_speed():
    case = load_case(FLUME, overrides=["fluid.model=potential"])
    assert case.swimming.speed_m_s == 0.8


# The coarse flume's mean plate force (thrust less skin friction) on the original robot's
# free-body motion, 18 Hz square wave (benchmarks/swimming_flume.py; docs/swimming.md), made
# with the fast model's motion of this electrode spacing in still liquid: the fast side
# compares on that motion too
CFD_PLATE_FORCE_N = {0.05: 0.1150, 0.8: -0.2442}
# with elongated-body theory's own added mass per length, rho pi b^2, as the tables were made
STRIP = "swimming.section_added_mass=strip"
FLUME_MOTION = ["actuation.electrode_spacing_m=0.514e-3", "swimming.speed_coupling=false", STRIP]
STILL_MOTION = "swimming.speed_coupling=false"  # the motion in still liquid at every speed


@pytest.mark.parametrize("speed", sorted(CFD_PLATE_FORCE_N))
def test_the_pressure_share_of_the_thrust_is_closer_to_the_flume_than_lighthills(speed):
    """Lighthill's thrust less skin friction misses the CFD by 1.2 N; its share carried by
    the pressure (no suction at the sharp edges) by 0.08-0.27 N."""
    from fishfsi.cli.linear import swimming_summary

    sets = ["fluid.model=potential", f"swimming.speed_m_s={speed}", *FLUME_MOTION]
    row = swimming_summary(load_case(FLUME, overrides=sets))
    friction, cfd = row["skin_friction_drag_n"], CFD_PLATE_FORCE_N[speed]
    pressure_gap = row["pressure_thrust_at_speed_n"] - friction - cfd
    lighthill_gap = row["lighthill_thrust_at_speed_n"] - friction - cfd
    assert 0 < pressure_gap < 0.3
    assert lighthill_gap > 1.0
    assert lighthill_gap > 4 * pressure_gap


def test_the_free_original_robots_speed_with_either_thrust_model():
    """At 18 Hz square the robot swam 0.72 m/s (Sec. 4.4). On the motion in still liquid
    the pressure's share of the thrust swims the model's free robot within 10 % of that,
    Lighthill's thrust at twice it; the CFD flume on the same motion finds 0.23 m/s
    (docs/swimming.md), so neither settles the free motion."""
    from fishfsi.cli.linear import swimming_summary

    swim = ROOT / "cases" / "swim_original_18Hz"
    pressure = swimming_summary(
        load_case(swim, overrides=["swimming.thrust_model=pressure", STILL_MOTION, STRIP])
    )
    assert pressure["thrust_at_speed_n"] == pressure["pressure_thrust_at_speed_n"]
    assert pressure["swimming_speed_m_s"] == pytest.approx(0.72, rel=0.10)
    lighthill = swimming_summary(load_case(swim, overrides=[STILL_MOTION, STRIP]))
    assert lighthill["swimming_speed_m_s"] > 1.8 * 0.72


@OPENFOAM
@pytest.mark.openfoam
def test_held_plate_in_the_flume_is_pushed_downstream_by_at_most_turbulent_friction(tmp_path):
    """The plate held still (no drive) in the stream: a drag along +x (thrust = -F_x < 0), no
    side force, and no more than a fully turbulent flat plate's friction (ITTC 1957) - the
    inflow is quiet. The benchmark (benchmarks/swimming_flume.py) compares the settled coarse
    value with Blasius too; this small mesh is only for the signs and the bound."""
    from fishfsi.cli.flume import flume_case
    from fluid_adapter.openfoam.prescribed import run_periodic

    case = flume_case(load_case(FLUME, overrides=["fluid.mesh_scale=2"]))
    result = run_periodic(
        case,
        tmp_path / "held",
        lambda points: [(1, np.zeros((len(points), 3), dtype=complex))],
        periods=2,
        steps_per_period=10,
        mesh_scale=2.0,
    )
    drag = float(result.force_n[-5:, 0].mean())
    speed, nu, rho = 0.8, case.fluid.kinematic_viscosity_m2_s, case.fluid.density_kg_m3
    plate = planform(case)
    x = np.linspace(0.0, plate.length_m, 2001)
    wetted = 2 * np.trapezoid(plate.height(x), x)  # both faces
    re = speed * plate.length_m / nu
    ittc = 0.5 * rho * speed**2 * wetted * 0.075 / (np.log10(re) - 2) ** 2
    print(f"held plate drag {drag:.4f} N; ITTC {ittc:.4f} N")
    assert 0 < drag < ittc
    assert np.all(result.thrust_n < 0)
    assert np.abs(result.force_n[-1, 2]) < 0.1 * drag  # no side force on a plate in line


@OPENFOAM
@pytest.mark.openfoam
def test_fsi_run_of_the_flume_case_reports_the_cfd_and_the_model(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "fishfsi.cli.run", str(FLUME), "--json", "--output", str(out)]
    cmd += ["--set", "fluid.mesh_scale=2", "--set", "time.periods=1"]
    cmd += ["--set", "time.steps_per_period=20"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["inflow_m_s"] == summary["swimming_speed_m_s"] == 0.8
    assert np.isfinite(summary["cfd_plate_force_n"])
    form = summary["head_weight_drag_n"] + summary["float_drag_n"]
    assert summary["cfd_net_force_n"] == pytest.approx(summary["cfd_plate_force_n"] - form)
    assert summary["model_plate_force_n"] == pytest.approx(
        summary["thrust_at_speed_n"] - summary["skin_friction_drag_n"]
    )
    assert json.loads((out / "flume.json").read_text())["cfd_cells"] == summary["cfd_cells"]
    forces = np.loadtxt(out / "flume_forces.csv", delimiter=",")
    assert forces.shape == (20, 4) and np.isfinite(forces).all()
    assert "flume: OpenFOAM" in done.stderr


def test_a_head_on_stiff_springs_makes_the_pressure_share_swim_faster():
    """The same robot with its head on springs of 1e4 N/m (boundary.head = "elastic", a
    sensitivity study; the motion in still liquid): the recoil is held and the pressure
    share swims it at 1.30 m/s (docs/swimming.md), twice the free robot's 0.67 m/s."""
    from fishfsi.cli.linear import swimming_summary

    swim = ROOT / "cases" / "swim_original_18Hz"
    held = ["boundary.head=elastic", "boundary.support_stiffness_n_per_m=1e4", STILL_MOTION, STRIP]
    pressure = ["swimming.thrust_model=pressure", STILL_MOTION, STRIP]
    row = swimming_summary(load_case(swim, overrides=[*held, "swimming.thrust_model=pressure"]))
    free = swimming_summary(load_case(swim, overrides=pressure))
    assert row["swimming_speed_m_s"] == pytest.approx(1.30, abs=0.02)
    assert row["pressure_thrust_at_speed_n"] > 0
    assert row["swimming_speed_m_s"] > 1.5 * free["swimming_speed_m_s"]
