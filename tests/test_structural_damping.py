"""The structure's own damping, material.loss_factor (hysteretic, K (1 + i eta)): exact against
the viscous equivalent at a resonance, the single-mode quality factor 1 / eta on the seed's
beam, and its viscous form in a transient."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli.compose import shell_with_fast_fluid
from fsi_orchestrator.case.loader import load_case
from solid_adapter.build import (
    bending_frequencies,
    build_damping,
    mean_voltage_equilibrium,
    static_loads,
    structural_damping,
)
from solid_adapter.harmonic import ModalSweep, harmonic_load, mean_voltage_tangent
from solid_adapter.piezo import DriveSignal
from solid_adapter.solvers import RayleighDamping

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "cases/seed/beam_sweep"
ETA = 0.013  # the seed cases' value: 1 / Q_m of PZT-5A


@pytest.fixture(scope="module")
def beam():
    case = load_case(BEAM, ["mesh.level=coarse"])
    model, _ = shell_with_fast_fluid(case)
    drive = DriveSignal.from_case(case)
    x_static = mean_voltage_equilibrium(case, model, drive, static_loads(case, model))
    load = harmonic_load(model, drive, x_static)
    tangent = mean_voltage_tangent(model, x_static, drive)
    tip = model.mesh.nearest_node(*model.layout.tip_point) * 5 + 2
    return model, load, tangent, tip


def test_the_seed_cases_carry_the_documented_loss_factor():
    for case in sorted((ROOT / "cases/seed").iterdir()):
        assert load_case(case).material.loss_factor == ETA, case.name


def test_hysteretic_equals_viscous_at_the_resonance_in_the_resonant_mode(beam):
    """At w = w_1, w_1^2 (1 + i eta) - w^2 = i eta w_1^2 = 2 i zeta w_1 w with zeta = eta / 2:
    the first modal coordinate is the same as with beta = eta / w_1."""
    model, load, tangent, _ = beam
    hysteretic = ModalSweep.build(model, load, 10, stiffness=tangent, loss_factor=ETA)
    w1 = hysteretic.omegas[0]
    viscous = ModalSweep.build(model, load, 10, (0.0, ETA / w1), stiffness=tangent)

    def first_mode(sweep):
        return hysteretic.shapes[0] @ (model.inertia @ (sweep.response(w1) - sweep.static))

    assert first_mode(hysteretic) == pytest.approx(first_mode(viscous), rel=1e-10)
    # and its magnitude is the modal load over eta w_1^2 (less the static correction's share)
    expected = hysteretic.modal_load[0] * (1 / (1j * ETA * w1**2) - 1 / w1**2)
    assert first_mode(hysteretic) == pytest.approx(expected, rel=1e-10)


def test_the_beam_resonance_is_its_quasi_static_deflection_over_eta(beam):
    """Single-mode quality factor: |X(w_1)| = |X_1(0)| / eta, X_1(0) the first mode's share of
    the quasi-static tip deflection; the other modes add under 2 % at the tip."""
    model, load, tangent, tip = beam
    sweep = ModalSweep.build(model, load, 20, stiffness=tangent, loss_factor=ETA)
    w1 = sweep.omegas[0]
    share = sweep.modal_load[0] * sweep.shapes[0, tip] / w1**2
    peak = abs(sweep.response(w1)[tip])
    assert peak == pytest.approx(abs(share) / ETA, rel=0.02)
    # hysteretic: even at w -> 0 the modes respond with 1 / (1 + i eta), |.| = 1 - eta^2 / 2
    quasi_static = abs(sweep.response(1e-6 * w1)[tip])
    assert 1 - quasi_static / abs(sweep.static[tip]) == pytest.approx(ETA**2 / 2, rel=0.05)


def test_a_transient_takes_eta_over_the_drive_or_first_mode_frequency(beam):
    """Exact at the drive above the first mode (24.7 Hz), at that mode below it."""
    model = beam[0]
    w1 = 2 * np.pi * bending_frequencies(model, 1)[0]
    above = load_case(BEAM, ["mesh.level=coarse", "actuation.frequency_hz=40"])
    assert structural_damping(above, model) == RayleighDamping(0.0, ETA / (2 * np.pi * 40.0))
    below = load_case(BEAM, ["mesh.level=coarse", "actuation.frequency_hz=20"])
    assert structural_damping(below, model) == RayleighDamping(0.0, ETA / w1)
    assert 24.0 < w1 / (2 * np.pi) < 25.5  # Table 3.3: 24.8 Hz
    assert build_damping(below, model) == structural_damping(below, model)
    assert structural_damping(load_case(BEAM, ["material.loss_factor=0"]), model) is None
