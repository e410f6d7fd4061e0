"""Start correction (fsi_orchestrator.start_orbit): the liquid's force beyond the fast model is
fitted over the lead-in and the shell restarts on the corrected periodic orbit."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from fsi_orchestrator.case.loader import load_case
from fsi_orchestrator.start_orbit import LeadInSamples, fit_modal_force

ROOT = Path(__file__).resolve().parents[1]


def test_fit_recovers_a_modal_force_per_node():
    """Exact for a force -M~ a - p s'' - d s' + b with s = e . u (motion not purely along e)."""
    rng = np.random.default_rng(3)
    n, w = 6, 2 * np.pi * 3
    e = rng.normal(size=n)
    e /= np.linalg.norm(e)
    other = rng.normal(size=n)
    M = rng.normal(size=(n, n))
    M = M @ M.T
    p, d, b = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    t = np.linspace(0.2, 0.4, 15)
    u = np.outer(np.sin(w * t), e) + 0.3 * np.outer(np.cos(w * t + 0.4), other)
    v = w * (np.outer(np.cos(w * t), e) - 0.3 * np.outer(np.sin(w * t + 0.4), other))
    a = -(w**2) * u
    s_dd, s_d = a @ e, v @ e
    f = -a @ M.T - np.outer(s_dd, p) - np.outer(s_d, d) + b
    fit = fit_modal_force(LeadInSamples(t, u, v, a, f), 2.5 * e, M)
    np.testing.assert_allclose(fit.mass_z, p, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(fit.damping_z, d, rtol=1e-8, atol=1e-10)
    assert fit.residual < 1e-8
    assert abs(fit.amplitude_m - np.ptp(u @ e) / 2) < 1e-12


def test_start_correction_puts_the_shell_on_the_liquids_orbit():
    """A liquid with 1.3 times the preconditioner's added mass (the CFD carries 1.2-1.6 times
    the potential one, docs/coupling.md). Started on the preconditioner's orbit, the shell's
    tail velocity at t = 0 is 69 % off the liquid's periodic orbit (analytic: the linear
    periodic response with 1.3 M~); after one lead-in period and the fit, within 5 %."""
    from fishfsi.cli.compose import added_mass_for_preconditioning, coupled_setup
    from fluid_adapter.potential.model import AddedMass
    from fluid_adapter.potential.participant import PotentialParticipant
    from fsi_orchestrator.coupling import Coupling
    from solid_adapter.build import CorrectableStart, periodic_orbit, static_loads
    from solid_adapter.piezo import DriveSignal
    from solid_adapter.shell import NDOF

    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        ["fluid.model=potential", "coupling.partitioned=true", "time.periods=1"],
    )
    factor, n = 1.3, 40

    def heavier_liquid(case, solid):
        estimate = added_mass_for_preconditioning(case, solid.model)
        heavier = AddedMass(factor * estimate.matrix, estimate.density_kg_m3, 0)
        return PotentialParticipant(heavier, solid.interface())

    solid, coupling = coupled_setup(case, heavier_liquid)
    estimate = coupling.fluid.added_mass.matrix / factor
    start = CorrectableStart(case, solid.model, solid, estimate)
    settings = dataclasses.replace(
        coupling.settings, lead_in_windows=n, lead_in_omega=2 * np.pi * 3.0
    )
    coupling = Coupling(
        coupling.fluid, solid.interface().points, settings, estimate, start_orbit=start
    )
    tip_v = solid.tip_node * NDOF + 2
    v_before = solid.state.v[tip_v]
    coupling.lead_in(solid, 1.0 / (3.0 * n))
    v_after = solid.state.v[tip_v]

    model = solid.model
    with start._start_inertia():
        model.set_added_mass(factor * estimate)
        drive = DriveSignal.from_case(case)
        true = periodic_orbit(case, model, drive, static_loads(case, model), solid.integrator)
        v_true = true.at(0.0)[1][tip_v]
    assert abs(v_before / v_true - 1) > 0.5
    assert abs(v_after / v_true - 1) < 0.05
    fit = coupling.start_fit
    assert fit is not None and fit.residual < 1e-3
    assert fit.applied and fit.alignment > 0.99  # the orbit keeps its shape


def test_a_square_wave_start_holds_the_harmonics_the_time_step_resolves():
    """The periodic start keeps the harmonics with >= 8 steps per period (1, 3, 5 at 40 steps:
    undamped, the 15th of the potential orbit had 30 mm at 45 Hz and crashed the CFD lead-in),
    and the lead-in follows that orbit with all of them: at t = 0 it is at the structure's
    position with its velocity. A single harmonic through (u0, v0), the former lead-in, swings
    more than twice as far as the orbit does."""
    from fsi_orchestrator.case.loader import load_case
    from fsi_orchestrator.lead_in import periodic_motion
    from fsi_orchestrator.participant import DISPLACEMENT, VELOCITY
    from solid_adapter.build import build_shell_participant, resolved_harmonics

    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        ["fluid.model=potential", "actuation.waveform=square"],
    )
    assert resolved_harmonics(case) == 3
    assert resolved_harmonics(dataclasses.replace(case, time=_steps(case, 8))) == 1
    solid = build_shell_participant(case)
    assert [k for k, _ in solid.orbit.harmonics] == [1, 3, 5]
    omega = 2 * np.pi * case.actuation.frequency_hz
    motion, state = periodic_motion(solid, omega), solid.write_data()
    period = np.linspace(0, 2 * np.pi / omega, 200)
    on_orbit = max(np.abs(motion(t)[:, 2]).max() for t in period)  # the tail's amplitude
    # normal motion (the in-plane translations differ by ~1e-9 m: the start puts the in-plane
    # DOFs into equilibrium with the bending, solid_adapter.solvers)
    assert np.abs(motion(0.0) - state[DISPLACEMENT])[:, 2].max() < 1e-9 * on_orbit
    h = 1e-6 / omega
    velocity = (motion(h) - motion(-h)) / (2 * h)
    assert np.abs(velocity - state[VELOCITY])[:, 2].max() < 1e-6 * omega * on_orbit
    u0, v0 = state[DISPLACEMENT][:, 2], state[VELOCITY][:, 2]
    single = max(
        np.abs(u0 * np.cos(omega * t) + v0 / omega * np.sin(omega * t)).max() for t in period
    )
    assert single > 2 * on_orbit


def _steps(case, steps_per_period):
    return dataclasses.replace(case.time, steps_per_period=steps_per_period)


def test_the_lead_in_blends_from_the_orbit_it_started_on():
    """The second lead-in period blends the fluid's motion from the old orbit into the
    corrected one: a motion taken before the restart must keep the old orbit (a bound method
    reading the current orbit made the blend jump to the new one at once)."""
    from fsi_orchestrator.case.loader import load_case
    from fsi_orchestrator.lead_in import periodic_motion
    from solid_adapter.build import build_shell_participant
    from solid_adapter.harmonic import PeriodicResponse
    from solid_adapter.shell import NDOF

    case = load_case(ROOT / "cases" / "fixed_head_3Hz", ["fluid.model=potential"])
    solid = build_shell_participant(case)
    omega = 2 * np.pi * case.actuation.frequency_hz
    old = periodic_motion(solid, omega)
    before = old(0.01).copy()
    orbit = solid.orbit
    doubled = PeriodicResponse(
        orbit.omega, orbit.x_static, [(k, 2 * X) for k, X in orbit.harmonics]
    )
    solid.restart(doubled)
    np.testing.assert_array_equal(old(0.01), before)
    new = periodic_motion(solid, omega)
    swing = new(0.01)[:, 2] - orbit.x_static[2::NDOF]
    np.testing.assert_allclose(swing, 2 * (before[:, 2] - orbit.x_static[2::NDOF]), atol=1e-15)


def test_the_fitting_lead_in_period_moves_no_faster_than_the_cfd_resolves():
    """At 25 Hz the clamped fish's undamped fast orbit sits on its wet torsion modes and moved
    the fin at 3.5 m/s, which blew the coarse CFD up within the first lead-in period. That
    period only serves the fit, so it is scaled down to LEAD_IN_MAX_SPEED_M_S; the second
    period blends into the corrected orbit."""
    from fishfsi.cli.compose import added_mass_for_preconditioning, coupled_setup
    from fluid_adapter.potential.participant import PotentialParticipant
    from fsi_orchestrator.case.loader import load_case
    from fsi_orchestrator.coupling import Coupling
    from fsi_orchestrator.lead_in import LEAD_IN_MAX_SPEED_M_S, periodic_motion
    from fsi_orchestrator.participant import DISPLACEMENT
    from solid_adapter.build import CorrectableStart

    frequency, n = 25.0, 40
    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        [
            "fluid.model=potential",
            "coupling.partitioned=true",
            f"actuation.frequency_hz={frequency}",
        ],
    )
    moved = []

    class Recording(PotentialParticipant):
        def read_data(self, data):
            moved.append(np.array(data[DISPLACEMENT]))
            super().read_data(data)

    def recording_liquid(case, solid):
        return Recording(added_mass_for_preconditioning(case, solid.model), solid.interface())

    solid, coupling = coupled_setup(case, recording_liquid)
    estimate = coupling.fluid.added_mass.matrix
    start = CorrectableStart(case, solid.model, solid, estimate)
    settings = dataclasses.replace(
        coupling.settings, lead_in_windows=n, lead_in_omega=2 * np.pi * frequency
    )
    coupling = Coupling(
        coupling.fluid, solid.interface().points, settings, estimate, start_orbit=start
    )
    dt = 1.0 / (frequency * n)
    orbit = periodic_motion(solid, 2 * np.pi * frequency)
    orbit_speed = max(np.abs(orbit(k * dt) - orbit((k - 1) * dt)).max() / dt for k in range(-n, 1))
    coupling.lead_in(solid, dt)
    first = np.array(moved[:n])
    speed = np.abs(np.diff(first, axis=0)).max() / dt
    assert orbit_speed > 1.5 * LEAD_IN_MAX_SPEED_M_S  # 4.7 m/s here (3.5 m/s in the tank)
    assert speed <= LEAD_IN_MAX_SPEED_M_S * 1.001


def test_a_run_whose_fast_orbit_outruns_the_cfd_starts_from_rest():
    """The periodic start leads the CFD onto the fast model's (undamped) orbit. At 25 Hz, near
    the clamped fish's wet torsion and bending modes, that orbit moves the fin at 4.9 m/s,
    more than the lead-in lets the CFD follow (2 m/s), and its corrected start left the
    plate where the first coupled window never converged: such a run starts from rest with a
    one-period voltage ramp and two periods added. At 3 Hz (0.33 m/s) the case is run as
    given. The liquid stands in for OpenFOAM: the choice is made before the fluid is built."""
    from fishfsi.cli.compose import added_mass_for_preconditioning, build_coupled_run
    from fluid_adapter.potential.participant import PotentialParticipant
    from fsi_orchestrator.case.loader import load_case
    from solid_adapter.shell import NDOF

    def stand_in_liquid(case, solid):
        return PotentialParticipant(
            added_mass_for_preconditioning(case, solid.model), solid.interface()
        )

    runs = {
        f: build_coupled_run(
            load_case(
                ROOT / "cases" / "fixed_head_3Hz",
                [f"actuation.frequency_hz={f}", "time.periods=2", "fluid.mesh_level=coarse"],
            ),
            stand_in_liquid,
        )
        for f in (3, 25)
    }
    as_given = runs[3]
    assert as_given.start_note is None
    assert as_given.case.actuation.ramp_periods == 0 and as_given.case.time.periods == 2
    assert as_given.coupling.settings.lead_in_windows == 40
    ramped = runs[25]
    assert "4.9 m/s" in ramped.start_note and "4 periods in all (2 asked for)" in ramped.start_note
    assert ramped.case.actuation.ramp_periods == 1 and ramped.case.time.periods == 4
    assert ramped.coupling.settings.lead_in_windows == 0
    at_rest = ramped.solid.state.v.reshape(-1, NDOF)
    assert np.all(at_rest == 0)


@pytest.mark.slow
def test_a_lead_in_that_turns_the_plate_past_the_mesh_motion_starts_from_rest():
    """The free integrative robot (0.1 mm core, 3 mm peduncle) is driven near its first wet
    mode: its undamped fast orbit, capped at 40 mm, turns the midline by 55 deg, where the
    shipped mesh motion fails (benchmarks/mesh_rotation.py), and pimpleFoam blew up in the
    lead-in at t = 0.242 s. It starts from rest (then it couples: 4.1 mm, 4.8 fluid solves per
    window, coarse). The main job's scene turns it by 13 deg and is run as given."""
    from fishfsi.cli.compose import (
        LEAD_IN_MAX_TURN_DEG,
        added_mass_for_preconditioning,
        choose_start,
    )
    from fsi_orchestrator.case.loader import load_case
    from solid_adapter.build import build_shell_model, build_shell_participant

    def start(folder, sets):
        case = load_case(ROOT / folder, ["fluid.mesh_level=coarse", *sets])
        model = build_shell_model(case)
        model.set_added_mass(added_mass_for_preconditioning(case, model).matrix)
        return choose_start(case, build_shell_participant(case, model))

    free, note = start("cases/seed/integrative_prototype", ["fluid.model=openfoam"])
    assert note is not None and "turns the plate by 55 deg" in note
    assert f"({LEAD_IN_MAX_TURN_DEG:g} deg" in note
    assert free.actuation.ramp_periods == 1
    as_given, note = start("cases/fixed_head_3Hz", [])
    assert note is None and as_given.actuation.ramp_periods == 0


def test_the_normal_dofs_elimination_solves_the_harmonics_exactly_and_is_kept_for_the_drag(
    monkeypatch,
):
    """The fish in potential flow (the added mass fills the normal block): each harmonic of
    the square wave solved by elimination onto the normal DOFs equals the plain sparse LU's;
    a second call whose damping differs on the normal diagonal only (the edge drag's fixed
    point) keeps each harmonic's elimination and refactors its dense block, and a damping
    that reaches the other DOFs builds it anew."""
    from fishfsi.cli.fast_model import shell_with_fast_fluid
    from solid_adapter import harmonic
    from solid_adapter.piezo import DriveSignal

    case = load_case(
        ROOT / "cases/seed/thrust_rig",
        ["fluid.model=potential", "mesh.level=coarse", "actuation.frequency_hz=12"],
    )
    model, _ = shell_with_fast_fluid(case)
    drive = DriveSignal.from_case(case)
    x0 = model.zero_state()
    n = model.ndof
    normal = np.arange(n) % 5 == 2
    drag = sp.diags(np.where(normal, 0.3, 0.0)).tocsr()
    cache: dict = {}
    fast = harmonic.periodic_response(model, drive, x0, drag, 3, cache=cache)
    assert len(cache) == 3
    kept = dict(cache)
    rng = np.random.default_rng(1)
    varied = sp.diags(np.where(normal, rng.uniform(0.1, 2.0, n), 0.0)).tocsr()
    reused = harmonic.periodic_response(model, drive, x0, varied, 3, cache=cache)
    assert all(cache[key] is kept[key] for key in kept)
    structural = sp.diags(np.full(n, 1e-3)).tocsr()
    harmonic.periodic_response(model, drive, x0, drag + structural, 3, cache=cache)
    assert all(cache[key] is not kept[key] for key in kept)
    monkeypatch.setattr(harmonic, "DENSE_NORMAL_BLOCK", float("inf"))
    for response, damping in ((fast, drag), (reused, varied)):
        plain = harmonic.periodic_response(model, drive, x0, damping, 3)
        for (k, X), (k2, Y) in zip(response.harmonics, plain.harmonics, strict=True):
            assert k == k2
            np.testing.assert_allclose(X, Y, rtol=0, atol=1e-7 * np.abs(Y).max())  # round-off
