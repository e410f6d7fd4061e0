"""Time integration of the shell: energy, frequency, checkpoints of the participant."""

from __future__ import annotations

import numpy as np
import pytest

from fsi_orchestrator.participant import DISPLACEMENT, FORCE, Participant
from solid_adapter.build import build_shell_model, build_shell_participant, run_static
from solid_adapter.solvers import make_integrator, modal_analysis
from tests.conftest import BIMORPH_STRIP, rectangle


def _strip(make_case, elements=4, **case_sections):
    """The 1 m x 0.1 m x 10 mm strip (E = 1 GPa) in ``elements`` elements along its length."""
    mesh = {"elements_length": elements, "elements_width": 1}
    return make_case(**rectangle(1.0, 0.1, 0.01, 1e9, 0.3, 1000.0, mesh=mesh, **case_sections))


def _released_strip(make_case, tip_force, elements=4):
    case = _strip(
        make_case,
        elements,
        loads={"tip_force_n": tip_force},
        analysis={"kind": "static", "load_steps": 2},
    )
    model = build_shell_model(case)
    return model, run_static(case, model).x


def _unloaded(model):
    return (lambda t, x, tangent: (np.zeros(model.ndof), None)), (lambda t: np.zeros(2))


def _strip_participant(make_case, step_s: float, **case_sections):
    """The strip as a shell participant stepping by ``step_s``."""
    time = {"step_s": step_s, "end_time_s": 10 * step_s}
    return build_shell_participant(_strip(make_case, time=time, **case_sections))


@pytest.mark.slow
def test_energy_conserving_integrator_keeps_energy_over_100_periods(make_case):
    """Undamped free vibration from a 2.3 % tip deflection (nonlinear regime: there the
    trapezoidal rule drifts about 1 % in 10 periods and blows up at 7 %): energy drift < 1 %."""
    model, x0 = _released_strip(make_case, tip_force=0.6, elements=2)
    assert x0.reshape(-1, 5)[model.mesh.nearest_node(1.0, 0.0), 2] > 0.02
    loads, volts = _unloaded(model)
    integrator = make_integrator("energy-conserving", model)
    state = integrator.initial_state(0.0, loads, volts, x0=x0)
    energy0 = model.strain_energy(state.x, np.zeros(2))
    dt = 1.0 / modal_analysis(model, 1).frequencies_hz[0] / 12
    energies = []
    for _ in range(100 * 12):
        state = integrator.step(state, dt, loads, volts)
        energies.append(
            integrator.kinetic_energy(state) + model.strain_energy(state.x, np.zeros(2))
        )
    assert np.max(np.abs(np.array(energies) / energy0 - 1)) < 1e-2


def test_free_vibration_period_matches_modal_frequency(make_case):
    """Small amplitude: the tip oscillates at the first modal frequency (40 steps per period,
    trapezoidal period error (w dt)^2 / 12 = 0.2 %)."""
    model, x0 = _released_strip(make_case, tip_force=1e-4)
    f1 = modal_analysis(model, 1).frequencies_hz[0]
    loads, volts = _unloaded(model)
    integrator = make_integrator("generalized-alpha", model, rho_inf=1.0)
    state = integrator.initial_state(0.0, loads, volts, x0=x0)
    tip = model.mesh.nearest_node(1.0, 0.0) * 5 + 2
    dt = 1.0 / f1 / 40
    w = [state.x[tip]]
    for _ in range(120):
        state = integrator.step(state, dt, loads, volts)
        w.append(state.x[tip])
    w = np.array(w)
    crossings = np.flatnonzero((w[:-1] > 0) & (w[1:] <= 0))
    t_cross = (crossings + w[crossings] / (w[crossings] - w[crossings + 1])) * dt
    period = np.mean(np.diff(t_cross))
    assert period == pytest.approx(1.0 / f1, rel=5e-3)


def test_shell_participant_checkpoint_is_a_copy(make_case):
    """Mutating the live state after store_checkpoint leaves the checkpoint unchanged
    (fenics-adapter tests/unit/test_checkpointing.py)."""
    solid = _strip_participant(make_case, 1e-3)
    assert isinstance(solid, Participant)
    n = len(solid.interface().points)
    solid.store_checkpoint()
    before = solid.write_data()[DISPLACEMENT]
    force = np.zeros((n, 3))
    force[:, 2] = 1.0
    solid.read_data({FORCE: force})
    solid.solve(1e-3)
    moved = solid.write_data()[DISPLACEMENT]
    solid.state.x[:] = 123.0  # mutate the live state in place
    solid.restore_checkpoint()
    np.testing.assert_array_equal(solid.write_data()[DISPLACEMENT], before)
    assert solid.time == 0.0
    solid.read_data({FORCE: force})
    solid.solve(1e-3)
    # the re-solve starts Newton from the previous answer (a private copy, not the mangled
    # state): the same solution to Newton's tolerance (1e-8 of the step)
    scale = np.abs(moved).max()
    np.testing.assert_allclose(solid.write_data()[DISPLACEMENT], moved, rtol=0, atol=1e-8 * scale)


def test_shell_participant_save_load_state_round_trip(make_case):
    case = _strip(make_case, loads={"tip_force_n": 0.1})
    a = build_shell_participant(case)
    a.solve(1e-3)
    saved = a.save_state()
    copy = {k: np.array(v, copy=True) for k, v in saved.items()}
    b = build_shell_participant(case)
    b.load_state(saved)
    a.solve(1e-3)
    b.solve(1e-3)
    np.testing.assert_array_equal(a.write_data()[DISPLACEMENT], b.write_data()[DISPLACEMENT])
    for k, v in saved.items():  # the saved dict was not changed by loading it
        np.testing.assert_array_equal(np.asarray(v), copy[k])


def test_a_free_piezo_strip_keeps_zero_momentum(make_case):
    """A free bimorph strip (boundary.head = "free") in vacuum, driven in anti-phase from its
    periodic orbit: the piezo load is internal, so the lateral momentum 1_z . M v stays zero
    (generalized-alpha keeps it exactly for self-equilibrated forces) - no drift, while the ends
    swing."""
    case = make_case(
        geometry=BIMORPH_STRIP,
        boundary={"head": "free"},
        actuation={"frequency_hz": 20.0},
        analysis={"kind": "dynamic", "rho_infinity": 0.5},
        time={"periods": 2.0, "steps_per_period": 40},
    )
    model = build_shell_model(case)
    shell = build_shell_participant(case, model)
    lateral = np.zeros(model.ndof)
    lateral[2::5] = 1.0
    mass = lateral @ (model.mass @ lateral)
    tip = model.mesh.nearest_node(87e-3, 0.0) * 5 + 2
    momentum, tip_speed = [], []
    for _ in range(80):
        shell.solve(1.0 / 20.0 / 40)
        momentum.append(lateral @ (model.mass @ shell.state.v))
        tip_speed.append(shell.state.v[tip])
    scale = mass * np.max(np.abs(tip_speed))
    assert np.max(np.abs(tip_speed)) > 0.1  # m/s: the ends swing
    assert np.max(np.abs(momentum)) < 1e-8 * scale  # 3.5e-11 measured


def test_a_kept_tangent_gives_full_newtons_answer_with_fewer_factorizations(make_case, monkeypatch):
    """analysis.reuse_tangent: coupling-like re-solves of one step (restore, a slightly changed
    load, solve again from the previous answer) with modified Newton on the kept tangent give
    full Newton's displacements to its tolerance (1e-8 of the step; measured 1e-14), with
    fewer factored tangents; a restart checkpoint (save_state) drops the kept tangent, so a
    resumed run iterates as the original (the round trip above is exact)."""
    import solid_adapter.solvers as solvers

    factored = {"n": 0}
    original = solvers.factorized

    def counting(*args, **kwargs):
        factored["n"] += 1
        return original(*args, **kwargs)

    monkeypatch.setattr(solvers, "factorized", counting)
    runs = {}
    for reuse in (False, True):
        solid = _strip_participant(make_case, 2e-3, analysis={"reuse_tangent": reuse})
        n = len(solid.interface().points)
        factored["n"], answers = 0, []
        for window in range(4):
            solid.store_checkpoint()
            for scale in (1.0, 1.01, 1.0001):  # the coupling's iterates of one window
                solid.restore_checkpoint()
                force = np.zeros((n, 3))
                force[:, 2] = 20.0 * scale * (1 + window)  # tip deflection up to 4.6 %
                solid.read_data({FORCE: force})
                solid.solve(2e-3)
            answers.append(solid.write_data()[DISPLACEMENT])
        runs[reuse] = (np.array(answers), factored["n"])
        assert (solid.integrator.kept_tangent.solve is not None) is reuse
        solid.save_state()
        assert solid.integrator.kept_tangent.solve is None
    (full, full_factored), (kept, kept_factored) = runs[False], runs[True]
    assert np.abs(full[-1][:, 2]).max() > 0.02  # large deflection: a nonlinear step
    np.testing.assert_allclose(kept, full, rtol=0, atol=1e-8 * np.abs(full).max())
    assert kept_factored < full_factored / 3  # measured: 11 against 39


def test_a_kept_tangent_that_fails_gives_way_to_full_newton(make_case):
    """A kept tangent that returns NaN, or one three times too soft (each modified increment
    overshoots, the next is twice as large), is dropped after one iteration: full Newton
    from the last good iterate gets the same step as a run that never kept one."""
    solid = _strip_participant(make_case, 2e-3)
    n = len(solid.interface().points)
    solid.store_checkpoint()

    def solve(load: float):  # a coupling iterate: from the window start, warm from the last
        solid.restore_checkpoint()
        force = np.zeros((n, 3))
        force[:, 2] = load
        solid.read_data({FORCE: force})
        solid.solve(2e-3)
        return solid.write_data()[DISPLACEMENT]

    solve(40.0)
    reference = solve(44.0)
    kept = solid.integrator.kept_tangent
    nan = lambda good: lambda r: np.full_like(r, np.nan)  # noqa: E731
    soft = lambda good: lambda r: 3.0 * good(r)  # noqa: E731
    for breaking in (nan, soft):
        solve(40.0)
        broken = breaking(kept.solve)
        kept.solve = broken
        np.testing.assert_allclose(
            solve(44.0), reference, rtol=0, atol=1e-8 * np.abs(reference).max()
        )
        assert kept.solve is not broken  # replaced by a fresh factorization
        assert kept.solve is not broken  # replaced by the fresh factorization


def test_the_shell_takes_the_preconditioning_added_mass_as_a_capability(make_case):
    """The *-am schemes hand the structure its preconditioning added mass through the typed
    TakesAddedMass capability: M~ joins the inertia and the integrator weights it like the
    exchanged force, with the fluid's stencil; None takes both away."""
    from fsi_orchestrator.participant import AddedMassPreconditioning, TakesAddedMass
    from solid_adapter.solvers import AddedMassAsForce

    solid = _strip_participant(make_case, 1e-3)
    assert isinstance(solid, TakesAddedMass)
    n = solid.model.n_nodes
    stencil = (2.25, -6.0, 5.5, -2.0, 0.25)
    solid.take_added_mass(AddedMassPreconditioning(added_mass_z=np.eye(n), stencil=stencil))
    added = solid.model.inertia - solid.model.mass
    assert added.sum() == pytest.approx(n)  # one unit on each node's z acceleration
    assert solid.integrator.added_mass_as_force == AddedMassAsForce(stencil)
    solid.take_added_mass(None)
    assert solid.model.added_mass is None and solid.model.inertia is solid.model.mass
    assert solid.integrator.added_mass_as_force is None
