"""time.periodic_feedback_per_s: the delayed feedback f = -g M (v(t) - v(t - T)) (Pyragas 1992)
vanishes on a periodic motion and damps what does not repeat."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp

from fishfsi.cli import run as run_cli
from fsi_orchestrator.case import CaseError, load_case
from solid_adapter.feedback import PeriodicFeedback

# the piezo beam of tests/test_run_dynamic.py with light mass-proportional damping, so that a
# start from rest rings its first mode for many periods
BEAM = """
[geometry]
kind = "beam"
[actuation]
frequency_hz = 10.0
[analysis]
rayleigh_alpha_per_s = 3.0
[time]
periods = 12
steps_per_period = 20
[mesh]
level = "coarse"
[output]
vtk = false
"""


class _Model:
    ndof = 3
    inertia = sp.diags([1.0, 2.0, 4.0]).tocsr()


def test_the_feedback_is_the_velocitys_change_over_a_period_times_g_m():
    """Exact: no force until a period is recorded (or seeded from a start orbit), then
    g M (v - v one period back); a step solved again (a coupling iteration) records the same
    start; zero on a periodic motion; nothing referred to inside a ramp."""
    feedback, model = PeriodicFeedback(2.0, steps_per_period=3), _Model()
    history = [np.array([k, -k, 2.0 * k]) for k in range(8)]
    for step in range(2):
        feedback.prepare(step, history[step])
        assert not np.any(feedback.force(model, None, np.ones(3))[0])
    feedback.prepare(2, history[2])
    feedback.prepare(2, history[2])  # the same window again
    v = np.array([1.0, 1.0, 1.0])
    force, tangent = feedback.force(model, None, v)
    np.testing.assert_array_equal(force, 2.0 * model.inertia @ (v - history[0]))
    np.testing.assert_array_equal(tangent.toarray(), 2.0 * model.inertia.toarray())
    feedback.prepare(3, history[3])
    assert not np.any(feedback.force(model, None, history[1])[0])  # v(t) = v(t - T)
    assert not feedback.linear(model).nnz  # a harmonic response does not feel it
    feedback.forget()
    assert not np.any(feedback.force(model, None, v)[0])
    # a start orbit stands in for the period before step 0, and only for that period
    orbit = {k: np.array([0.5, k, -1.0]) for k in (-3, -2, -1)}
    feedback.seed(orbit.__getitem__)
    feedback.prepare(0, history[0])
    np.testing.assert_array_equal(
        feedback.force(model, None, v)[0], 2.0 * model.inertia @ (v - orbit[-2])
    )
    feedback.forget()
    feedback.prepare(5, history[5])  # a history without the period back (an old checkpoint)
    assert not np.any(feedback.force(model, None, v)[0])
    # a ramp is no period to come back to
    ramped = PeriodicFeedback(2.0, steps_per_period=3, first_step=3)
    for step in range(6):
        ramped.prepare(step, history[step])
        assert (not ramped.references) == (step < 5)


def test_the_mirrored_term_feeds_back_the_mirror_image_half_a_period_back():
    """Exact: with ``mirror`` the force is g M (2 v - v(t - T) - S v(t - T/2)); zero on a
    motion that repeats every period and is its own mirror image half a period later; each
    term starts once its reference is recorded."""
    S = np.array([1.0, -1.0, -1.0])
    feedback, model = PeriodicFeedback(2.0, steps_per_period=4, mirror=S), _Model()
    a, b = np.array([1.0, 2.0, 3.0]), np.array([0.5, -1.0, 4.0])
    orbit = [a, b, S * a, S * b] * 3  # v(t + T/2) = S v(t)
    feedback.prepare(0, orbit[0])
    assert not np.any(feedback.force(model, None, np.ones(3))[0])
    feedback.prepare(1, orbit[1])  # the mirrored reference (step 0) exists, the period's not
    v = np.array([1.0, 1.0, 1.0])
    force, tangent = feedback.force(model, None, v)
    np.testing.assert_array_equal(force, 2.0 * model.inertia @ (v - S * orbit[0]))
    np.testing.assert_array_equal(tangent.toarray(), 2.0 * model.inertia.toarray())
    for step in range(2, 9):
        feedback.prepare(step, orbit[step])
        assert not np.any(feedback.force(model, None, orbit[step + 1])[0])
    force, tangent = feedback.force(model, None, v)
    np.testing.assert_array_equal(force, 2.0 * model.inertia @ (2 * v - orbit[5] - S * orbit[7]))
    np.testing.assert_array_equal(tangent.toarray(), 4.0 * model.inertia.toarray())
    with pytest.raises(ValueError, match="even"):
        PeriodicFeedback(2.0, steps_per_period=5, mirror=S)


@pytest.mark.parametrize("gain", [-1.0, float("nan")])
def test_a_gain_that_is_negative_or_not_finite_is_refused(gain):
    with pytest.raises(ValueError, match="gain"):
        PeriodicFeedback(gain, 20)


def test_the_feedback_brings_a_start_from_rest_to_the_periodic_orbit(tmp_path, capsys):
    """The beam started from rest rings its first mode: 1-21 % from period to period over 12
    periods (10.8-13.5 mm). With g = 10 /s it lies within 0.5 % of the orbit the periodic start
    begins on (11.09 mm) from period 7 on, and ends on that orbit within 0.2 %: the feedback
    leaves the periodic state where it was."""
    (tmp_path / "beam").mkdir()
    (tmp_path / "beam" / "case.toml").write_text(BEAM)
    amplitudes = {}
    for name, sets in {
        "orbit": ["time.periods=3"],
        "rest": ["time.start=rest"],
        "feedback": ["time.start=rest", "time.periodic_feedback_per_s=10"],
    }.items():
        args = [str(tmp_path / "beam"), "--json", "--quiet", "--output", str(tmp_path / name)]
        for s in sets:
            args += ["--set", s]
        assert run_cli.main(args) == 0
        summary = json.loads(capsys.readouterr().out)
        amplitudes[name] = np.array(summary["tip_amplitude_per_period_m"])
    orbit = amplitudes["orbit"][-1]
    np.testing.assert_allclose(amplitudes["orbit"], orbit, rtol=0.005)
    assert np.max(np.abs(amplitudes["rest"][6:] / orbit - 1)) > 0.02  # 7.9 % measured
    assert np.max(np.abs(amplitudes["feedback"][6:] / orbit - 1)) < 0.005  # 0.3 % measured
    assert amplitudes["feedback"][-1] == pytest.approx(orbit, rel=2e-3)


@pytest.mark.parametrize(
    "sets",
    [
        ["time.step_s=0.001", "time.end_time_s=0.01"],
        ["analysis.integrator=energy-conserving"],
    ],
)
def test_a_feedback_without_a_period_or_on_the_mid_step_velocity_is_refused(tmp_path, sets):
    """No whole number of steps per period; the energy-conserving rule's mid-step velocity
    (the feedback there would not vanish on a periodic motion)."""
    (tmp_path / "beam").mkdir()
    (tmp_path / "beam" / "case.toml").write_text(BEAM)
    with pytest.raises(CaseError, match="time.periodic_feedback_per_s"):
        load_case(tmp_path / "beam", [*sets, "time.periodic_feedback_per_s=5"])


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        ([], "time.periodic_feedback_per_s > 0"),
        (["time.periodic_feedback_per_s=5", "time.steps_per_period=21"], "21 is odd"),
        (
            ["time.periodic_feedback_per_s=5", "actuation.right_volts=[-500, 500]"],
            "left_volts and right_volts differ",
        ),
    ],
)
def test_a_mirrored_feedback_without_the_symmetry_is_refused(sets, message):
    """A turning drive, an odd number of steps per period, or no feedback to be a term of."""
    with pytest.raises(CaseError, match=message):
        load_case("cases/fixed_head_3Hz", [*sets, "time.periodic_feedback_mirror=true"])


def test_a_laminate_that_is_not_its_own_mirror_image_is_refused(tmp_path):
    """The seed's beam has one MFC on one side: the mirror term would push it off its orbit."""
    from solid_adapter.build import build_shell_model, periodic_feedback

    (tmp_path / "beam").mkdir()
    (tmp_path / "beam" / "case.toml").write_text(BEAM)
    case = load_case(tmp_path / "beam", ["time.periodic_feedback_per_s=5"])
    assert periodic_feedback(case, build_shell_model(case)).mirror is None
    case = load_case(
        tmp_path / "beam", ["time.periodic_feedback_per_s=5", "time.periodic_feedback_mirror=true"]
    )
    with pytest.raises(CaseError, match="time.periodic_feedback_mirror: .* laminate"):
        periodic_feedback(case, build_shell_model(case))
    fish = load_case(
        "cases/fixed_head_3Hz",
        ["time.periodic_feedback_per_s=5", "time.periodic_feedback_mirror=true"],
    )
    assert periodic_feedback(fish, build_shell_model(fish)).mirror is not None


def test_a_resumed_run_feeds_back_as_the_uninterrupted_one(tmp_path, capsys):
    """The checkpoint keeps the period of velocities the feedback refers to: 6 periods resumed
    to 12 give the 12-period run's history to round-off."""
    import h5py

    (tmp_path / "beam").mkdir()
    (tmp_path / "beam" / "case.toml").write_text(BEAM)
    base = [str(tmp_path / "beam"), "--json", "--quiet", "--set", "time.start=rest"]
    base += ["--set", "time.periodic_feedback_per_s=10"]
    assert run_cli.main([*base, "--output", str(tmp_path / "full")]) == 0
    full = json.loads(capsys.readouterr().out)
    part = [*base, "--output", str(tmp_path / "part")]
    assert run_cli.main([*part, "--set", "time.periods=6"]) == 0
    capsys.readouterr()
    assert run_cli.main([*part, "--resume"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    with h5py.File(full["results"]) as f, h5py.File(resumed["results"]) as g:
        np.testing.assert_allclose(
            g["shell/tip_displacement_m"][:], f["shell/tip_displacement_m"][:], rtol=0, atol=1e-12
        )
