"""The MFC drive models (induced strain, the seed's stress loads), the mean-voltage buckling
check and the seed's experiments as case folders (issue: validation against the seed)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from fsi_orchestrator.case.loader import load_case
from solid_adapter.buckling import buckling_factor
from solid_adapter.build import build_shell_model, run_static
from tests.conftest import ROOT

SEED_CASES = (
    "beam_sweep",
    "amplitude_3Hz",
    "thrust_rig",
    "fixed_head_sweep",
    "serial_prototype",
    "integrative_prototype",
)


@pytest.mark.parametrize("volts", [[1.0, 0.0], [1.0, -1.0]])
def test_seed_stress_is_the_induced_strains_equivalent_load(make_case, volts):
    """Eq. 3-10's stress applied as loads on the flat plate is exactly the induced strain's
    equivalent load, so both drives have the same linear response; beyond it the dead loads
    stretch the laminate (the induced strain of a free strip stresses nothing), which stiffens
    the seed's beam (Table 3.2) under one MFC: 3.4 % less tip deflection already at 1 V. The
    bimorph in anti-phase (the fish's drive) has no net stretch: the same deflection."""
    models, tips = [], []
    for drive in ("induced-strain", "seed-stress"):
        case = make_case(
            geometry={"kind": "beam", "actuator_sides": "both"},
            actuation={"static_volts": volts, "drive_model": drive},
            analysis={"kind": "static", "load_steps": 1},
            mesh={"elements_length": 8, "elements_width": 1},
        )
        models.append(build_shell_model(case))
        tips.append(run_static(case).tip_displacement_m[2])
    strain, stress = models
    zero, V = strain.zero_state(), np.array(volts)
    load = strain.internal(zero, V, tangent=False)[0]
    np.testing.assert_allclose(stress.internal(zero, V, tangent=False)[0], load, atol=1e-15)
    K0 = strain.internal(zero, np.zeros(2))[1]
    np.testing.assert_allclose(stress.internal(zero, np.zeros(2))[1].toarray(), K0.toarray())
    if volts[1] == 0:
        assert 0.95 < tips[1] / tips[0] < 0.99  # the dead loads' tension stiffens
    else:
        assert tips[1] == pytest.approx(tips[0], rel=1e-4)


def _model(preset: str, *overrides: str):
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        [f"geometry.preset={preset}", "fluid.model=none", "mesh.level=coarse", *overrides],
    )
    return build_shell_model(case)


def test_mean_voltage_buckles_the_thin_core_but_not_the_original():
    """Both MFCs at the drive's mean (+500 V): the 0.2 mm core of the original robot carries
    it (factor about 3), the 0.1 mm core of the integrative robot (Table 5.6) buckles at about
    half of it, with either drive model (the passive plate's stresses are the same); the
    factor of a linearized buckling problem scales as 1 / voltage."""
    mean = np.array([500.0, 500.0])
    original = buckling_factor(_model("original"), mean)
    assert 2.5 < original < 4.0
    for drive in ("induced-strain", "seed-stress"):
        model = _model("integrative", f"actuation.drive_model={drive}")
        factor = buckling_factor(model, mean)
        assert 0.4 < factor < 0.7
        assert buckling_factor(model, 0.5 * mean) == pytest.approx(2 * factor, rel=1e-3)


def test_a_laminate_without_piezo_constants_does_not_buckle_under_its_mean_voltage():
    """d33 = d31 = 0: the mean voltage induces no strain and no prestress, so nothing to
    buckle (the eigen-solver had failed on the zero stress with "starting vector is zero")."""
    model = _model("original", "actuation.d33_m_per_v=0", "actuation.d31_m_per_v=0")
    assert buckling_factor(model, np.array([500.0, 500.0])) == float("inf")


def test_a_buckling_mean_voltage_stops_the_run_in_one_line(tmp_path):
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "fishfsi.cli.run",
            str(ROOT / "cases" / "seed" / "integrative_prototype"),
            "--set",
            "actuation.mean_strain_transfer=1",
            "--set",
            "time.periods=0.1",
            "--output",
            str(tmp_path / "out"),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr
    assert "buckles" in lines[0] and "actuation.mean_strain_transfer" in lines[0]


@pytest.mark.parametrize("name", SEED_CASES)
def test_every_seed_experiment_is_a_case_with_its_source(name):
    """cases/seed/<name>/case.toml loads (also with the fast fluid) and its header names the
    figure or table it reproduces and how the seed held the robot."""
    folder = ROOT / "cases" / "seed" / name
    header = (folder / "case.toml").read_text(encoding="utf-8")
    assert "Reproduces:" in header and "How the seed held it:" in header
    assert "leaves open" in header
    load_case(folder, [])
    load_case(folder, ["fluid.model=potential"])


@pytest.mark.slow
def test_integrative_prototype_runs_without_buckling(tmp_path):
    """The integrative robot (CFRP 0.1 mm) that could not run: a quarter period of its case
    (free body, potential flow in the tank) ends with finite, nonzero motion, and fsi-modal
    reports that its drive's held mean cannot buckle it, nor move its modes."""
    folder = str(ROOT / "cases" / "seed" / "integrative_prototype")
    run = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.run", folder, "--json"]
        + ["--set", "time.periods=0.25", "--output", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    assert np.isfinite(summary["tip_max_abs_m"]) and summary["tip_max_abs_m"] > 1e-3
    modal = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.modal", folder, "--json"],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert modal.returncode == 0, modal.stderr
    modes = json.loads(modal.stdout)
    assert modes["mean_voltage_buckling_factor"] is None
    # none of the mean held: the driven robot's modes are the flat plate's, to the digit
    assert modes["wet_hz_at_mean_voltage"] == modes["wet_hz"]
