"""The structure's own damping, material.loss_factor (hysteretic, K (1 + i eta)): exact against
the viscous equivalent at a resonance, the single-mode quality factor 1 / eta on the seed's
beam, and its viscous form in a transient."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli import run as run_cli
from fishfsi.cli.fast_model import shell_with_fast_fluid
from fsi_orchestrator.case.loader import load_case
from solid_adapter.build import (
    bending_frequencies,
    build_damping,
    build_shell_model,
    mean_voltage_equilibrium,
    static_loads,
    structural_damping,
)
from solid_adapter.harmonic import ModalSweep, harmonic_load, mean_voltage_tangent
from solid_adapter.piezo import DriveSignal
from solid_adapter.shell import NDOF, StrainRate
from solid_adapter.solvers import RayleighDamping

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "cases/seed/beam_sweep"
ETA = 0.013  # the seed cases' value: 1 / Q_m of PZT-5A
THIN = ROOT / "cases/seed/integrative_prototype"  # CFRP 0.1 mm


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


def bent_state(model, seed: int = 0):
    """A bent and twisted plate with some noise, away from any symmetry."""
    rng = np.random.default_rng(seed)
    X, L = model.mesh.nodes, model.layout.length_m
    x = np.zeros((model.n_nodes, NDOF))
    x[:, 2] = 0.08 * L * (X[:, 0] / L) ** 2 + 0.01 * X[:, 1] * X[:, 0] / L
    x[:, 4] = -0.16 * X[:, 0] / L
    x = x.ravel()
    free = model.free_dofs
    x[~np.isin(np.arange(model.ndof), np.flatnonzero(free) if free.dtype == bool else free)] = 0
    return x + 1e-4 * L * rng.standard_normal(x.size) * (np.arange(x.size) % NDOF < 3)


def test_the_strain_rate_damping_has_the_exact_tangent():
    """The step's Kelvin-Voigt stress beta C (eps(x) - eps(x_n)) / dt is a function of x: its
    tangent (material and geometric) is the central difference of its force to 1e-7 on the
    thin integrative plate, bent and twisted from a bent reference."""
    model = build_shell_model(load_case(THIN, ["boundary.head=clamped", "fluid.model=none"]))
    reference, x = bent_state(model, 0), bent_state(model, 1) * 1.3
    rate = StrainRate(ETA / (2 * np.pi * 3.0) / (1 / 120), reference)
    volts = np.array([500.0, -500.0])
    _, K, _ = model.internal(x, volts, True, rate=rate)
    d = np.random.default_rng(2).standard_normal(model.ndof) * 1e-6
    d[~np.isin(np.arange(model.ndof), np.flatnonzero(model.free_dofs))] = 0
    h = 1e-2
    plus = model.internal(x + h * d, volts, False, rate=rate)[0]
    minus = model.internal(x - h * d, volts, False, rate=rate)[0]
    fd = (plus - minus) / (2 * h)
    assert np.linalg.norm(K @ d - fd) <= 1e-7 * np.linalg.norm(fd)
    # the damping stress vanishes at the reference: the elastic force alone
    np.testing.assert_allclose(
        model.internal(reference, volts, False, rate=rate)[0],
        model.internal(reference, volts, False)[0],
        rtol=0,
        atol=1e-12 * np.abs(model.internal(reference, volts, False)[0]).max(),
    )


def test_a_damped_thin_plate_steps_in_few_newton_iterations(tmp_path, capsys):
    """The integrative robot's 0.1 mm CFRP, head clamped, in vacuum, 3 Hz: with the structural
    damping's exact tangent Newton converges quadratically, 5 iterations in the first step
    (with beta K_mat(x) v, whose tangent misses dK_mat/dx v, the whole step failed to converge
    in 30 and was retried in halves down to eighths)."""
    out = tmp_path / "out"
    args = [str(THIN), "--set", "fluid.model=none", "--set", "boundary.head=clamped"]
    args += ["--set", "time.periods=0.1", "--set", "analysis.reuse_tangent=false"]
    assert run_cli.main([*args, "--json", "--quiet", "--output", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["windows"] == 4
    assert summary["mean_newton_iterations_per_window"] <= 6


@pytest.mark.parametrize("fraction", [0.5, 1.0])
def test_the_drive_power_in_air_is_the_laminates_loss(fraction):
    """In air the actuators' mean power over a period is what the laminate's loss takes out,
    1/2 w eta sum_j w_j^2 |q_j|^2 over the modes (q_j the modal amplitudes), below and at
    the beam's first resonance."""
    from fishfsi.cli.fast_model import linear_model
    from fsi_orchestrator.case.schema import Waveform

    linear = linear_model(load_case(BEAM, ["mesh.level=coarse"]))
    sweep = linear.sweep
    omega = fraction * sweep.omegas[0]
    response = linear.response(omega / (2 * np.pi), Waveform.SINE)
    ((_, X),) = response.harmonics
    q = sweep.shapes @ (linear.model.inertia @ X)
    loss = 0.5 * omega * ETA * np.sum(sweep.omegas**2 * np.abs(q) ** 2)
    power = linear.drive_power(response, Waveform.SINE)
    assert power > 0
    assert power == pytest.approx(loss, rel=1e-3)
