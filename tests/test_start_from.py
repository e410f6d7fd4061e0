"""time.start_from: a run starts on the periodic orbit an earlier run ended on, from its last
state (solid_adapter/recorded_orbit.py)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from fishfsi.cli import run as run_cli
from fsi_orchestrator.case import CaseError, load_case
from solid_adapter.harmonic import periodic_response_from_samples
from tests.test_periodic_feedback import BEAM as FEEDBACK_BEAM

ROOT = Path(__file__).resolve().parents[1]

# the lightly damped piezo beam of tests/test_periodic_feedback.py (a start from rest rings
# its first mode for many periods), run for 6 periods
BEAM = FEEDBACK_BEAM.replace("periods = 12", "periods = 6")
assert "periods = 6" in BEAM


@pytest.fixture
def beam(tmp_path):
    (tmp_path / "beam").mkdir()
    (tmp_path / "beam" / "case.toml").write_text(BEAM)
    return tmp_path / "beam"


def _run(capsys, case, output, *sets: str) -> dict:
    args = [str(case), "--json", "--quiet", "--output", str(output)]
    for s in sets:
        args += ["--set", s]
    assert run_cli.main(args) == 0
    return json.loads(capsys.readouterr().out)


def test_the_interpolant_passes_through_the_samples_with_their_harmonics():
    """Exact for a trigonometric polynomial of degree < N / 2 (the Nyquist term a cosine)."""
    omega, n = 2 * np.pi * 3.0, 16
    t = np.arange(n) / (3.0 * n)

    def exact(s):
        return np.array([0.1 + np.sin(omega * s) + 0.2 * np.cos(3 * omega * s + 0.3)])

    samples = np.array([exact(s) for s in t]) + np.cos(np.pi * np.arange(n))[:, None] * 1e-3
    orbit = periodic_response_from_samples(omega, samples)
    for s, x in zip(t, samples, strict=True):
        np.testing.assert_allclose(orbit.at(s)[0], x, rtol=0, atol=1e-14)
    smooth = periodic_response_from_samples(omega, np.array([exact(s) for s in t]))
    s = 0.0123
    velocity = omega * np.cos(omega * s) - 0.6 * omega * np.sin(3 * omega * s + 0.3)
    np.testing.assert_allclose(smooth.at(s)[0], exact(s), rtol=1e-12)
    np.testing.assert_allclose(smooth.at(s)[1], [velocity], rtol=1e-12)


@pytest.mark.parametrize("gain", [0, 10])
def test_a_run_started_from_another_continues_it(beam, tmp_path, capsys, gain):
    """From rest the beam rings for periods (its amplitude 1-21 % from the periodic one). A run
    started from a 6-period run's checkpoint goes on where it ended: its windows are the
    12-period run's last 120 to the Newton tolerance, also with the delayed feedback, whose
    period before t = 0 is the recorded one (a sample shifted by a window breaks it). Resumed
    after 3 periods it is the same run, and it says where it started."""
    feedback = f"time.periodic_feedback_per_s={gain}"
    full = _run(capsys, beam, tmp_path / "full", "time.start=rest", "time.periods=12", feedback)
    _run(capsys, beam, tmp_path / "first", "time.start=rest", feedback)
    start = f"time.start_from={tmp_path / 'first'}"
    second = _run(capsys, beam, tmp_path / "second", start, feedback)
    assert second["start_from"] == str(tmp_path / "first" / "checkpoint.h5")
    _run(capsys, beam, tmp_path / "part", start, feedback, "time.periods=3")
    args = [str(beam), "--json", "--quiet", "--output", str(tmp_path / "part"), "--resume"]
    assert run_cli.main([*args, "--set", start, "--set", feedback]) == 0
    resumed = json.loads(capsys.readouterr().out)
    with h5py.File(full["results"]) as f, h5py.File(second["results"]) as g:
        tail, tail_full = g["shell/tip_displacement_m"][:, 2], f["shell/tip_displacement_m"][:, 2]
    with h5py.File(resumed["results"]) as r:
        tail_resumed = r["shell/tip_displacement_m"][:, 2]
    assert len(tail) == 120
    np.testing.assert_allclose(tail, tail_full[120:], rtol=0, atol=1e-9 * np.ptp(tail))
    np.testing.assert_allclose(tail_resumed, tail, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        second["tip_amplitude_per_period_m"], full["tip_amplitude_per_period_m"][6:], rtol=1e-8
    )


def test_a_start_continues_a_run_whose_steps_damp_by_the_strain_rate(tmp_path, capsys):
    """A damping ratio adds beta K to the beam in liquid, which a step takes as the strain rate
    over the step, not beta K v at its end. The started run takes the source's last damping
    force: at 8 windows per period it is the two-period run's second period to 1e-9 (with
    beta K v recomputed at the start it swung 4.2 times as far)."""
    beam = ROOT / "cases/beam_in_liquid"
    sets = [
        "actuation.mean_strain_transfer=0",
        "time.steps_per_period=8",
        "fluid.damping_ratio=0.05",
    ]
    two = _run(capsys, beam, tmp_path / "two", *sets, "time.periods=2")
    _run(capsys, beam, tmp_path / "one", *sets, "time.periods=1")
    started = _run(
        capsys,
        beam,
        tmp_path / "started",
        *sets,
        "time.periods=1",
        f"time.start_from={tmp_path / 'one'}",
    )
    with h5py.File(two["results"]) as f, h5py.File(started["results"]) as g:
        tail, tail_two = g["shell/tip_displacement_m"][:, 2], f["shell/tip_displacement_m"][:, 2]
    np.testing.assert_allclose(tail, tail_two[8:], rtol=0, atol=1e-9 * np.ptp(tail))


@pytest.mark.parametrize(
    ("first", "then", "message"),
    [
        ([], ["actuation.frequency_hz=12"], "driven at 10 Hz, this case at 12 Hz"),
        ([], ["mesh.level=default"], "shell meshes differ"),
        (["time.periods=2.5"], [], "not at the end of a whole recorded period"),
        # held another way, the held nodes would stay where the first run left them
        ([], ["boundary.head=pinned"], "held otherwise (boundary.head"),
    ],
)
def test_a_start_that_does_not_fit_is_refused_in_one_line(
    beam, tmp_path, capsys, first, then, message
):
    _run(capsys, beam, tmp_path / "first", *first)
    args = [str(beam), "--quiet", "--output", str(tmp_path / "second")]
    for s in [f"time.start_from={tmp_path / 'first'}", *then]:
        args += ["--set", s]
    assert run_cli.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "time.start_from" in err[0] and message in err[0], err
    assert not (tmp_path / "second" / "results.h5").exists()


def test_a_missing_source_is_refused_in_one_line(beam, tmp_path, capsys):
    args = [str(beam), "--quiet", "--set", f"time.start_from={tmp_path / 'none'}"]
    assert run_cli.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "time.start_from" in err[0] and "does not exist" in err[0], err


@pytest.mark.parametrize(
    "sets",
    [
        ["time.step_s=0.001", "time.end_time_s=0.01"],
        ["time.start=rest"],
        ["actuation.ramp_periods=1"],
    ],
)
def test_a_start_from_without_a_period_or_from_rest_is_refused(beam, sets):
    with pytest.raises(CaseError, match="time.start_from"):
        load_case(beam, [*sets, "time.start_from=elsewhere"])


class _PeriodicFluid:
    """A fluid whose force is F0 sin(w t) on every node, wherever the plate is."""

    name = "fluid"

    acceleration_stencil = (1.0, -2.0, 1.0)  # a = (u_n+1 - 2 u_n + u_n-1) / dt^2

    def __init__(self, points, omega: float) -> None:
        from fsi_orchestrator.participant import InterfaceMesh

        self.mesh = InterfaceMesh(
            points=points, cells=np.zeros((0, 4), dtype=int), cell_type="quad"
        )
        self.omega, self.time = omega, 0.0

    def interface(self):
        return self.mesh

    def read_data(self, data) -> None:
        pass

    def solve(self, dt: float) -> None:
        self.time += dt

    def write_data(self):
        from fsi_orchestrator.participant import FORCE

        force = np.zeros((len(self.mesh.points), 3))
        force[:, 2] = np.sin(self.omega * self.time)
        return {FORCE: force}


class _DisplacedPeriodicFluid(_PeriodicFluid):
    """... that starts where it is told (StartsDisplaced), its force zig-zagging about the
    periodic one in its first windows as a CFD started from a mapped flow does."""

    started_at = None
    solves = 0
    start_up_windows = 3

    def start_displaced(self, displacement) -> None:
        self.started_at = np.array(displacement)

    def solve(self, dt: float) -> None:
        super().solve(dt)
        self.solves += 1

    def write_data(self):
        from fsi_orchestrator.participant import FORCE

        data = super().write_data()
        if self.solves <= self.start_up_windows:
            data[FORCE] += (-1) ** self.solves
        return data


@pytest.mark.parametrize(
    ("periods", "added_mass", "displaced"),
    [(1, False, False), (2, False, False), (2, True, False), (1, False, True), (1, True, True)],
)
def test_a_lead_in_of_whole_periods_seeds_the_predictors_period_before_t0(
    periods, added_mass, displaced
):
    """After a lead-in that ends on two whole periods of the orbit (a recorded start) window 0
    predicts one period back: on a periodic fluid force its first iterate is exact, also in an
    *-am scheme's variable g = f + M~ a (a as the fluid's stencil differentiates the motion).
    So it does after one period of a fluid that started displaced on the orbit (with the flow
    of the run that recorded it), the two ends before it taken by periodicity, to the cubic
    interpolation that bridges the fluid's start-up (1e-3). After the one ramped period of a
    usual lead-in the predictor can only hold the last force."""
    from fishfsi.cli.compose import coupled_setup
    from fsi_orchestrator.coupling import FIELD, Coupling

    case = load_case(
        ROOT / "cases" / "fixed_head_3Hz",
        ["fluid.model=potential", "coupling.partitioned=true", "time.periods=1"],
    )
    n, frequency = 40, case.actuation.frequency_hz
    dt, omega = 1 / (frequency * n), 2 * np.pi * frequency
    solid, coupling = coupled_setup(case)
    settings = dataclasses.replace(
        coupling.settings,
        lead_in_windows=n,
        lead_in_omega=omega,
        lead_in_periods=periods,
        lead_in_displaced=displaced,
    )
    points = solid.interface().points
    fluid = (_DisplacedPeriodicFluid if displaced else _PeriodicFluid)(points, omega)
    fluid.time = -periods / frequency  # the lead-in ends at t = 0
    m_tilde = 0.01 * np.eye(len(points)) if added_mass else None  # None: x = the force
    coupling = Coupling(fluid, points, settings, m_tilde)
    assert coupling.start_up.fluid_windows == periods * n
    coupling.lead_in(solid, dt)
    assert len(coupling.start_up.last_period) == (n + 2 if periods == 2 or displaced else 0)
    if displaced:  # where the orbit was a period before t = 0: where its recording ended
        motion = solid.orbit_motion()
        assert motion is not None
        np.testing.assert_allclose(fluid.started_at, motion(0.0), rtol=0, atol=1e-12)
    predicted = coupling.predictor.predict(dt)[FIELD][:, 2]
    exact = np.sin(omega * dt) * coupling.mapping.conservative(np.ones((len(points), 3)))[:, 2]
    if m_tilde is not None:
        motion = solid.orbit_motion()
        assert motion is not None
        u = [motion(dt - k * dt)[:, 2] for k in range(3)]
        exact = exact + m_tilde @ (u[0] - 2 * u[1] + u[2]) / dt**2
    miss = np.abs(predicted - exact).max() / np.abs(exact).max()
    if periods == 2 or displaced:
        assert coupling.predictor.rule == "period"
        assert miss < (3e-3 if displaced else 1e-9)
    else:
        assert miss > 0.99  # sin(0): the last force


def test_a_sweep_starts_each_point_from_the_same_point_of_another(beam, tmp_path, capsys):
    """fsi-sweep --start-from: the 10 Hz point goes on from the earlier sweep's 10 Hz run (its
    windows are a 12-period run's last 6), a point the earlier sweep lacks starts as usual
    with a note, and a linear sweep is refused."""
    from fishfsi.cli import sweep as sweep_cli

    full = _run(capsys, beam, tmp_path / "full", "time.start=rest", "time.periods=12")
    sweep = [str(beam), "--method", "transient", "--waveforms", "sine", "--quiet"]
    first = [*sweep, "--set", "time.start=rest", "--frequencies", "10"]
    assert sweep_cli.main([*first, "--output", str(tmp_path / "a")]) == 0
    capsys.readouterr()
    later = [*sweep, "--frequencies", "10,12", "--output", str(tmp_path / "b")]
    assert sweep_cli.main([*later, "--start-from", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert f"{tmp_path / 'a' / 'sine_12Hz'} holds no finished run" in err
    with h5py.File(full["results"]) as f, h5py.File(tmp_path / "b/sine_10Hz/results.h5") as g:
        tail, tail_full = g["shell/tip_displacement_m"][:, 2], f["shell/tip_displacement_m"][:, 2]
    np.testing.assert_allclose(tail, tail_full[120:], rtol=0, atol=1e-9 * np.ptp(tail))
    linear = [str(beam), "--frequencies", "10", "--output", str(tmp_path / "c")]
    assert sweep_cli.main([*linear, "--start-from", str(tmp_path / "a")]) == 2
    assert "--start-from" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        (["time.start=rest"], "--start-from"),
        (["time.start_from=elsewhere"], "time.start_from names one run"),
    ],
)
def test_a_sweep_whose_points_cannot_start_on_an_orbit_is_refused(
    beam, tmp_path, capsys, sets, message
):
    from fishfsi.cli import sweep as sweep_cli

    (tmp_path / "a").mkdir()
    args = [str(beam), "--method", "transient", "--frequencies", "10", "--waveforms", "sine"]
    args += ["--output", str(tmp_path / "b"), "--start-from", str(tmp_path / "a")]
    for s in sets:
        args += ["--set", s]
    assert sweep_cli.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_sweep_point_whose_source_ended_mid_period_starts_as_usual(beam, tmp_path, capsys):
    """A killed or short earlier point is not a start: a note names it, and the point runs as
    it would without --start-from."""
    from fishfsi.cli import sweep as sweep_cli

    sweep = [str(beam), "--method", "transient", "--waveforms", "sine", "--frequencies", "10"]
    sweep += ["--quiet", "--json"]
    short = [*sweep, "--output", str(tmp_path / "a"), "--set", "time.periods=2.5"]
    assert sweep_cli.main(short) == 0
    capsys.readouterr()
    assert (
        sweep_cli.main(
            [*sweep, "--output", str(tmp_path / "b"), "--start-from", str(tmp_path / "a")]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert "not at the end of a whole recorded period" in captured.err
    assert "the point starts as usual" in captured.err
    assert sweep_cli.main([*sweep, "--output", str(tmp_path / "c")]) == 0
    plain = json.loads(capsys.readouterr().out)["rows"][0]
    started = json.loads(captured.out)["rows"][0]
    assert started["tip_amplitude_m"] == pytest.approx(plain["tip_amplitude_m"], rel=1e-12)


def test_a_recorded_start_leads_in_two_periods_without_the_start_correction():
    """The OpenFOAM driver is sized for the lead-in's fluid windows: two uncorrected periods
    on a recorded orbit, as with the start correction's fit and blend; one without either."""
    from fishfsi.cli.compose import corrects_start, coupling_settings, lead_in_fluid_windows

    base: list[str] = []  # the case's OpenFOAM at 40 windows per period
    usual = load_case(ROOT / "cases" / "fixed_head_3Hz", base)
    recorded = load_case(ROOT / "cases" / "fixed_head_3Hz", [*base, "time.start_from=x"])
    plain = load_case(ROOT / "cases" / "fixed_head_3Hz", [*base, "coupling.start_correction=false"])
    assert corrects_start(usual) and not corrects_start(recorded)
    assert lead_in_fluid_windows(usual) == lead_in_fluid_windows(recorded) == 80
    assert lead_in_fluid_windows(plain) == 40
    assert coupling_settings(recorded).lead_in_periods == 2
    assert coupling_settings(usual).lead_in_periods == 1


def test_a_start_from_without_actuators_is_refused(make_case):
    from tests.conftest import rectangle

    sections = rectangle()
    sections["time"] = {"start_from": "elsewhere"}
    with pytest.raises(CaseError, match="time.start_from.*no actuators"):
        make_case(**sections)
