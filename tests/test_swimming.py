"""Swimming (issue 31): Lighthill's thrust at forward speed, the body's drag, the self-propelled
speed and the turning rate (fluid_adapter/swimming.py), the contract of ``fsi-run --json`` for
``analysis.kind = "swimming"`` and the seed's measured swimming (Sec. 4.4-4.5, Table 5.8)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fishfsi.cli import run, sweep
from fishfsi.cli.linear import swimming_summary
from fishfsi.cli.swimming import MEASURED, SWIMMING_KEYS
from fluid_adapter.swimming import (
    BodyDrag,
    FormDrag,
    SpeedLoads,
    divergence_speed,
    mean_thrust,
    mirrored_over_half_a_period,
    self_propelled_speed,
    skin_friction_coefficient,
    speed_loads,
    turning_rate,
)
from fsi_orchestrator.case import load_case
from fsi_orchestrator.case.schema import Waveform

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "swim_original_18Hz"
RIGHT_TURN = "actuation.right_volts=[-500.0, 500.0]"  # Sec. 4.5: left -500..+1500 V
RHO = 1820.0  # FC-3283 (Table 3.6)


def travelling_wave(x, a=0.01, k=20.0, omega=2 * np.pi * 10, n=64):
    t = np.arange(n) / n * 2 * np.pi / omega
    return t[1] - t[0], a * np.sin(k * x[None, :] - omega * t[:, None])


def test_thrust_of_a_travelling_wave_is_lighthills_closed_form():
    # constant height, h = a sin(k x - w t): <T> = A a^2 (w^2 - V^2 k^2) / 4 (Lighthill 1960)
    x = np.linspace(0.0, 0.15, 801)
    b = np.full_like(x, 0.02)
    a, k, omega = 0.01, 20.0, 2 * np.pi * 10
    dt, h = travelling_wave(x, a, k, omega)
    area = RHO * np.pi * 0.02**2
    for v in (0.0, 0.5, 2.0):
        expected = area * a**2 * (omega**2 - v**2 * k**2) / 4
        got = mean_thrust(x, b, h, dt, v, density_kg_m3=RHO)
        assert got == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("speed", [0.3, 1.0])
def test_the_load_at_speed_takes_lighthills_power(speed):
    """The lateral load that forward speed adds, fed back into the structure, does on the
    fluid Lighthill's mean work P = A V <w h_t>(L) (Lighthill 1960, constant height; the
    still liquid's A h_tt does none over a period). The body: a plate with a blunt nose, its
    midline a travelling wave growing toward the tail, H = (0.3 + x / L) e^{-i k x}."""
    x = np.linspace(0.0, 0.15, 3001)
    b = np.full_like(x, 0.02)
    area = RHO * np.pi * 0.02**2
    k, omega = 25.0, 2 * np.pi * 12
    wave = (0.3 + x / x[-1]) * np.exp(-1j * k * x) * 5e-3
    loads = speed_loads(x, b, np.stack([wave.real, wave.imag]), density_kg_m3=RHO)
    q = np.array([1.0, 1.0j])  # H = Re + i Im in the two "modes"
    operator = 1j * omega * loads.damping(speed) + loads.stiffness(speed)
    power = 0.5 * np.real(np.vdot(1j * omega * q, operator @ q))
    h_t = 1j * omega * wave[-1]
    w = h_t + speed * np.gradient(wave, x)[-1]
    expected = area * speed * 0.5 * np.real(w * np.conj(h_t))
    assert power > 0  # the swimming plate works on the liquid
    assert power == pytest.approx(expected, rel=2e-3)


def test_the_divergence_speed_is_where_the_elastic_stiffness_is_used_up():
    """w_j^2 + V^2 K_jj = 0 for a diagonal K: V_d = min sqrt(w_j^2 / -K_jj) over the elastic
    modes (here 2, 3 and 4 m/s); a rigid mode (w = 0) and a stiffening K do not count."""
    omegas = np.array([0.0, 10.0, 20.0, 30.0])
    k = np.array([-5.0, -((10.0 / 3) ** 2), -((20.0 / 2) ** 2), -((30.0 / 4) ** 2)])
    loads = SpeedLoads(np.zeros((4, 4)), np.diag(k))
    assert divergence_speed(loads, omegas, rigid=1) == pytest.approx(2.0, rel=1e-12)
    stiffening = SpeedLoads(np.zeros((4, 4)), np.diag(-k))
    assert divergence_speed(stiffening, omegas, rigid=1) == np.inf


def test_a_prescribed_speed_past_the_divergence_is_refused_in_one_line(capsys):
    """The original robot's motion diverges near 4.1 m/s (2.5 m/s with the strip's own added
    mass): a flume speed past it gets one line naming the key and the bad-input exit, not a
    figure of a meaningless motion."""
    code = run.main([str(CASE), "--json", "--set", "swimming.speed_m_s=5"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""  # bad input, refused before the work
    assert len(err.strip().splitlines()) == 1
    assert "swimming.speed_m_s = 5 is past the plate's divergence speed (4.07 m/s)" in err


def test_a_swimming_sweep_whose_every_point_failed_keeps_its_swimming_table(tmp_path, capsys):
    """fsi-sweep fails each point past the divergence speed alone (its folder is prepared by
    then); with every point failed, the table is still the swimming case's, not a held
    fish's thrust."""
    argv = [str(CASE), "--frequencies", "18", "--waveforms", "square", "--set", "mesh.level=coarse"]
    code = sweep.main([*argv, "--set", "swimming.speed_m_s=5", "--output", str(tmp_path / "s")])
    out, err = capsys.readouterr()
    assert code == 1 and "1 of 1 points failed" in err
    header, row = out.splitlines()[:2]
    assert "speed [m/s]" in header and "body lengths/s" in header and "thrust" not in header
    assert "failed: swimming.speed_m_s = 5 is past the plate's divergence speed" in row
    assert "speed - m/s" in err  # the progress line too


def test_at_no_forward_speed_nothing_turns_nor_slips(capsys):
    """A flume at 0 m/s: no path to turn along, so the right-turn drive reports no turn, no
    sideslip and no note of a tight turn (the radius V / Omega had read 0 / 0)."""
    code, out, err = fsi_run(capsys, "swimming.speed_m_s=0", RIGHT_TURN)
    assert code == 0, err
    summary = json.loads(out)
    assert summary["turning_rate_deg_s"] == 0.0 and summary["slip_deg"] == 0.0
    assert "notes" not in summary and "note:" not in err


def test_a_swimming_case_is_not_swept_by_a_time_march(tmp_path, capsys):
    """The swimming figures come from the linear response at speed: a transient sweep of a
    swimming case would drop them without a word. One line naming analysis.kind, exit 2."""
    argv = [str(CASE), "--method", "transient", "--frequencies", "18", "--quiet"]
    code = sweep.main([*argv, "--output", str(tmp_path / "sweep")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert err.startswith('error: analysis.kind = "swimming"') and "--method transient" in err
    assert not (tmp_path / "sweep").exists()


def test_an_interrupted_swimming_run_says_nothing_was_kept(tmp_path, capsys, monkeypatch):
    """A swimming (or modal, static) run keeps no checkpoint: Ctrl-C says to run it again,
    not to --resume (which it refuses)."""

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(run, "execute", stopped)
    assert run.main([str(CASE), "--output", str(tmp_path / "out")]) == 130
    assert capsys.readouterr().err == "interrupted: nothing was written; run it again\n"


def test_a_turn_tighter_than_the_body_at_a_low_prescribed_speed_says_so(capsys):
    """At a flume's 0.05 m/s the seed's right-turn drive lands on a turn of about 180 deg/s,
    a radius of 16 mm on a 167 mm body, where the slender-body turning balance does not hold:
    fsi-run says so in one note (the row's status carries it)."""
    sets = ["--set", RIGHT_TURN, "--set", "swimming.speed_m_s=0.05"]
    assert run.main([str(CASE), "--json", *sets]) == 0
    out, err = capsys.readouterr()
    summary = json.loads(out)
    radius = 0.05 / np.radians(abs(summary["turning_rate_deg_s"]))
    assert radius < 0.167
    assert [line for line in err.splitlines() if line.startswith("note:")] == [
        "note: turning radius below the body length: outside the turning model (turning_rate_deg_s)"
    ]


def test_skin_friction_lines():
    assert skin_friction_coefficient(1e6, "ittc-1957") == pytest.approx(0.075 / 16)
    assert skin_friction_coefficient(1e5, "blasius") == pytest.approx(1.328 / np.sqrt(1e5))
    drag = BodyDrag(
        density_kg_m3=RHO,
        kinematic_viscosity_m2_s=1e-6,
        length_m=0.5,
        wetted_area_m2=0.01,
        form=(FormDrag(name="float", frontal_area_m2=1e-4, drag_coefficient=1.05),),
    )
    # V = 2 m/s: Re = 1e6, q = 3640 Pa
    assert drag.total(2.0) == pytest.approx(3640 * (0.075 / 16 * 0.01 + 1.05e-4))


def test_self_propelled_speed_balances_thrust_and_drag():
    x = np.linspace(0.0, 0.15, 201)
    b = np.where(x < 0.14, 0.025, 0.02)
    dt, h = travelling_wave(x * (x / 0.15))
    drag = BodyDrag(
        density_kg_m3=RHO, kinematic_viscosity_m2_s=0.75e-6, length_m=0.15, wetted_area_m2=0.014
    )

    def thrust(v):
        return mean_thrust(x, b, h, dt, v, density_kg_m3=RHO)

    speed = self_propelled_speed(thrust, drag.total)
    assert speed > 0
    assert thrust(speed) == pytest.approx(drag.total(speed), rel=1e-6)


def bent_body(sign: float, bend: float):
    """A travelling wave on a body whose mean shape bends its tail toward sign * z."""
    x = np.linspace(0.0, 0.167, 121)
    b = np.where(x < 0.14, 0.0275, 0.02)
    dt, h = travelling_wave(x, a=0.005 * (x / 0.167) ** 2)
    return x, b, dt, sign * (h + bend * (x / 0.167) ** 2)


def turning_of(sign: float, bend: float, speed: float = 0.5) -> float:
    x, b, dt, h = bent_body(sign, bend)
    load = dict(speed_m_s=speed, x_ref_m=0.06, density_kg_m3=RHO, crossflow_drag_coefficient=1.2)
    return turning_rate(x, b, h, dt, **load).yaw_rate_rad_s


def test_turning_flips_with_the_mirrored_drive_and_vanishes_without_a_mean_bend():
    right = turning_of(1.0, -0.01)  # tail bent to -z (right): turns right
    assert right < 0
    assert turning_of(-1.0, -0.01) == pytest.approx(-right, rel=1e-9)
    assert turning_of(1.0, 0.0) == pytest.approx(0.0, abs=1e-9 * abs(right))


def test_a_plate_swaying_at_speed_carries_jones_slender_wing_lift():
    """A rigid plate of constant height 2b swimming at V and swaying at v meets the stream at
    the incidence v / V: Jones' slender-wing lift F = -rho pi b^2 V v (R. T. Jones 1946, NACA
    Report 835), up to the trailing edge's third-order tilt (v / V)^2 / 2."""
    from fluid_adapter.swimming import side_force_and_moment

    x = np.linspace(0.0, 0.17, 60)
    b = np.full_like(x, 0.03)
    h = np.zeros((16, x.size))  # no undulation
    speed, sway = 0.6, 0.01
    load = side_force_and_moment(
        x, b, h, 1e-3, speed_m_s=speed, x_ref_m=0.06, density_kg_m3=RHO, lateral_velocity_m_s=sway
    )
    jones = -RHO * np.pi * 0.03**2 * speed * sway
    assert load.side_force_n == pytest.approx(jones, rel=2 * (sway / speed) ** 2)
    # Jones: the lift acts where the span grows, here all at the blunt nose, 0.06 m ahead of
    # the reference point (N = int (x - x_r) l dx)
    assert load.yaw_moment_nm == pytest.approx(-0.06 * jones, rel=2 * (sway / speed) ** 2)


def test_at_a_low_speed_a_symmetric_drive_does_not_turn_and_a_bent_tail_turns_its_way():
    """At 0.05 m/s the yaw balance near 0 is unstable (the moment grows with the rate); the
    symmetric motion's N is 0 exactly, and a bent tail turns toward its bend on the stable
    root."""
    assert mirrored_over_half_a_period(bent_body(1.0, 0.0)[3])
    assert not mirrored_over_half_a_period(bent_body(1.0, -1e-4)[3])
    assert turning_of(1.0, 0.0, speed=0.05) == 0.0
    for bend in (-0.003, -0.01):
        assert turning_of(1.0, bend, speed=0.05) < 0  # right
        assert turning_of(-1.0, bend, speed=0.05) > 0  # mirrored: left


def fsi_run(capsys, *overrides: str) -> tuple[int, str, str]:
    argv = [str(CASE), "--json", "--quiet"]
    for o in overrides:
        argv += ["--set", o]
    code = run.main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def original_runs():
    """The shipped case with the seed's right-turn drive, and with the left MFC alone
    (~25 s)."""
    results = {}
    for name, overrides in (
        ("right_turn", (RIGHT_TURN,)),
        ("left_mfc_alone", ("actuation.right_volts=[0.0, 0.0]",)),
    ):
        case = load_case(CASE, overrides)
        results[name] = swimming_summary(case)
    return results


def test_fsi_run_prints_the_contract(capsys):
    code, out, err = fsi_run(capsys)
    assert code == 0, err
    summary = json.loads(out)
    for key in SWIMMING_KEYS:
        assert np.isfinite(summary[key]), key
    v, f, length = summary["swimming_speed_m_s"], 18.0, 0.167
    assert summary["body_lengths_per_s"] == pytest.approx(v / length)
    assert summary["swimming_number"] == pytest.approx(v / (f * length))  # eq. 5-15
    assert summary["thrust_at_speed_n"] == pytest.approx(summary["drag_at_speed_n"], rel=1e-6)
    assert summary["turning_rate_deg_s"] == pytest.approx(0.0, abs=1e-6)  # symmetric drive


def test_matched_to_a_strip_fluid_the_section_added_mass_is_its_own():
    """swimming.section_added_mass = "matched" scales rho pi b^2 to the structure's fluid on
    its first wet bending mode: where that fluid is the strip theory itself, by its own gamma."""
    from fishfsi.cli.fast_model import linear_model

    sets = ["fluid.model=slender_body", "fluid.added_mass_coefficient=0.7"]
    linear = linear_model(load_case(CASE, sets))
    assert linear.section_added_mass_coefficient == pytest.approx(0.7, rel=1e-9)
    strip = linear_model(load_case(CASE, [*sets, "swimming.section_added_mass=strip"]))
    assert strip.section_added_mass_coefficient == 0.7


def test_the_3d_flow_carries_about_a_third_of_the_strips_added_mass(original_runs):
    """The original robot's first free wet bending mode (6.0 Hz) changes sign over about its
    55 mm height: the 3D potential flow in the tank carries 0.38 of rho pi b^2 on it
    (docs/swimming.md), and the swimming model uses that gamma by default."""
    row = original_runs["right_turn"]
    assert row["section_added_mass_coefficient"] == pytest.approx(0.38, abs=0.01)


def test_a_swimming_number_above_one_gets_a_note(capsys):
    """At 1 Hz square the voltage steps ring the fin: 0.22 m/s, Sw 1.3, more than a body
    length per drive period, where the seed's robots reached 0.75 at most (Table 5.8)."""
    code, out, err = fsi_run(capsys, "actuation.frequency_hz=1.0")
    assert code == 0
    assert json.loads(out)["swimming_number"] > 1
    assert "note: swimming number above 1" in err


def test_a_symmetric_drive_does_not_turn_at_a_low_prescribed_speed(capsys):
    """At 0.05 m/s (a flume's speed) the yaw balance has far roots on which the fish would
    spin at about 200 deg/s; the symmetric drive's own root is 0."""
    code, out, err = fsi_run(capsys, "swimming.speed_m_s=0.05")
    assert code == 0, err
    assert json.loads(out)["turning_rate_deg_s"] == pytest.approx(0.0, abs=1e-6)


def test_the_seeds_right_turn_turns_right(original_runs):
    assert original_runs["right_turn"]["turning_rate_deg_s"] < 0


def test_the_left_mfc_alone_turns_right_more_slowly_than_the_seeds_turning_drive(original_runs):
    """Sec. 3.6: with one MFC at -500..+1500 V and the other at 0 V the robot turns, but
    more slowly than with the other at -500..+500 V. Both drives bend it alike on average
    (the same 500 V of mean difference); the lone MFC swings the tail less, so the fish
    swims and turns more slowly (model: 7.0 against 8.8 deg/s)."""
    alone, turning = original_runs["left_mfc_alone"], original_runs["right_turn"]
    assert turning["turning_rate_deg_s"] < alone["turning_rate_deg_s"] < 0
    assert alone["swimming_speed_m_s"] < turning["swimming_speed_m_s"]


@pytest.mark.xfail(
    strict=True,
    reason="the model turns at 8.8 deg/s: its turning radius (3.8 m) is about 2.5 times "
    "that of 27 deg/s at 0.72 m/s; in the slender-body yaw balance it is set by the mean "
    "bend's shape, not by the speed",
)
def test_the_seeds_right_turn_rate_within_a_factor_1_5(original_runs):
    """Measured about 27 deg/s (Sec. 4.5, 18 Hz square, right MFC -500..+500 V)."""
    rate = -original_runs["right_turn"]["turning_rate_deg_s"]
    assert 27.0 / 1.5 <= rate <= 27.0 * 1.5


@pytest.mark.parametrize(
    "override, key",
    [
        ("swimming.speed_m_s=-0.1", "swimming.speed_m_s"),
        ("swimming.speed_m_s=nan", "swimming.speed_m_s"),
        ("swimming.float_drag_coefficient=-1.0", "swimming.float_drag_coefficient"),
        ("swimming.head_weight_drag_coefficient=inf", "swimming.head_weight_drag_coefficient"),
        ("swimming.crossflow_drag_coefficient=-0.5", "swimming.crossflow_drag_coefficient"),
        ("boundary.head=clamped", "boundary.head"),
        ("boundary.head=pinned", "boundary.head"),
        ("fluid.model=none", "fluid.model"),
        ("fluid.density_kg_m3=25", "swimming.float_density_kg_m3"),  # no float can rise
    ],
)
def test_bad_input_is_one_line_naming_the_key(capsys, override, key):
    code, out, err = fsi_run(capsys, override)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert key in err


FREQUENCIES = [15.0, 18.0, 25.0]
ROBOTS = {
    "original": (CASE, ()),
    "serial": (ROOT / "cases/seed/serial_prototype", ("analysis.kind=swimming",)),
    "integrative": (ROOT / "cases/seed/integrative_prototype", ("analysis.kind=swimming",)),
}


@pytest.fixture(scope="module")
def square_curves():
    """Speed against frequency, square wave (the seed's swimming drive), coarse shell."""
    curves = {}
    for robot, (folder, overrides) in ROBOTS.items():
        case = load_case(folder, overrides)
        rows = sweep.linear_sweep(case, FREQUENCIES, [Waveform.SQUARE])
        assert all(r["status"] == "ok" for r in rows)
        curves[robot] = rows
    return curves


def peak(rows: list[dict], key: str = "swimming_speed_m_s") -> dict:
    return max(rows, key=lambda r: r[key])


def test_a_swimming_sweeps_table_shows_the_speed_not_the_thrust(capsys):
    """The free fish's figure is its speed (m/s and body lengths per second); the held
    fish's table keeps its thrust. A failed point shows '-'."""
    held = {"waveform": "square", "frequency_hz": 18.0, "tip_amplitude_m": 0.0081}
    held |= {"slender_body_mean_thrust_n": 0.0123, "status": "ok"}
    free = {**held, "swimming_speed_m_s": 1.4231, "body_lengths_per_s": 8.52}
    failed = {**held, "frequency_hz": 25.0, "tip_amplitude_m": float("nan"), "status": "failed"}
    sweep.print_table([free, failed])
    head, *lines = capsys.readouterr().out.splitlines()
    assert "speed [m/s]" in head and "body lengths/s" in head and "thrust" not in head
    assert lines[0].split() == ["square", "18.00", "8.10", "1.423", "8.52", "ok"]
    assert lines[1].split() == ["square", "25.00", "-", "-", "-", "failed"]
    assert "speed 1.42 m/s" in sweep.progress_line(free, 0.5, 1, 2)
    sweep.print_table([held])
    head, line = capsys.readouterr().out.splitlines()
    assert "thrust [mN]" in head and "speed" not in head and head.split()[-1] == "status"
    assert line.split() == ["square", "18.00", "8.10", "12.30", "ok"]
    # the tail at the swimming speed where the rows carry it; three figures, no exponent
    at_speed = {**free, "tip_amplitude_at_speed_m": 0.0035}
    sweep.print_table([at_speed])
    head, line = capsys.readouterr().out.splitlines()
    assert "tip at speed [mm]" in head and line.split()[2] == "3.50"
    assert "tip at speed 3.50 mm, speed 1.42 m/s" in sweep.progress_line(at_speed, 0.5, 1, 2)
    strong = {**held, "slender_body_mean_thrust_n": 1.0}
    assert "tip amplitude 8.10 mm, thrust 1000 mN" in sweep.progress_line(strong, 0.5, 1, 2)
    shown = [sweep._figure(v, "3s") for v in (9.996, 12345.6, -0.0, 1e-15, -3.456)]
    assert shown == ["10.0", "12300", "0", "1e-15", "-3.46"]


def test_sweep_rows_carry_the_swimming_columns(square_curves):
    for rows in square_curves.values():
        for row in rows:
            assert all(np.isfinite(row[k]) for k in SWIMMING_KEYS)


def test_original_speed_at_18_hz_within_30_percent_of_the_measured(square_curves):
    """Sec. 4.4, Fig. 4.11: 0.72 m/s at 18 Hz, square wave. The motion is the one at the
    speed (swimming.speed_coupling) and the sections' added mass the 3D flow's: 0.72 m/s;
    0.84 m/s with the strip's rho pi b^2, 1.00 m/s on the still liquid's motion."""
    at_18 = next(r for r in square_curves["original"] if r["frequency_hz"] == 18.0)
    assert at_18["swimming_speed_m_s"] == pytest.approx(MEASURED["original"]["speed_m_s"], rel=0.3)


@pytest.mark.xfail(
    strict=True,
    reason="measured 0.72 m/s at its 18 Hz peak (Sec. 4.4, Fig. 4.11); the model's speed "
    "still grows at 25 Hz (0.72 m/s at 18 Hz, 0.88 m/s at 25 Hz)",
)
def test_original_speed_peaks_between_15_and_25_hz_at_the_measured_speed(square_curves):
    best = peak(square_curves["original"])
    assert 15.0 <= best["frequency_hz"] <= 25.0 and best["frequency_hz"] < FREQUENCIES[-1]
    assert best["swimming_speed_m_s"] == pytest.approx(MEASURED["original"]["speed_m_s"], rel=0.3)


def test_three_robots_peak_body_lengths_per_second_rank_as_measured(square_curves):
    # measured maxima: serial 4.6 BL/s (Table 5.8), original 0.72 / 0.167 = 4.3 BL/s
    # (Sec. 4.4), integrative 3.5 BL/s (Table 5.8)
    measured = {
        "serial": MEASURED["serial"]["body_lengths_per_s"],
        "original": MEASURED["original"]["speed_m_s"] / 0.167,
        "integrative": MEASURED["integrative"]["body_lengths_per_s"],
    }
    model = {
        r: peak(rows, "body_lengths_per_s")["body_lengths_per_s"]
        for r, rows in square_curves.items()
    }
    assert sorted(model, key=model.get) == sorted(measured, key=measured.get)


def test_pressure_thrust_is_lighthills_less_the_edge_suction():
    """int <l h_x> dx (the pressure's share, fluid_adapter.swimming.mean_pressure_thrust),
    integrated by parts: [A (<w^2>/2 - V <w h_x>)] from nose to tail, less 1/2 int A' <w^2>,
    plus V int_{A'<0} A' <w h_x> where the sections shed (l = -A Dw/Dt there). Lighthill's
    thrust differs from it by the suction on the growing sections and the nose's term."""
    from scipy.integrate import trapezoid

    from fluid_adapter.slender_body import added_mass_per_length, periodic_derivative
    from fluid_adapter.swimming import mean_pressure_thrust

    length, f, speed, rho = 0.17, 10.0, 0.3, 1820.0
    x = np.linspace(0, length, 1201)
    b = 0.02 + 0.01 * np.sin(np.pi * x / length) ** 2  # grows, then shrinks
    t = np.arange(128) / (128 * f)
    omega = 2 * np.pi * f
    h = 0.004 * np.sin(4 * np.pi * x[None, :] / length - omega * t[:, None]) * (0.3 + x / length)
    h += 0.002 * np.cos(3 * omega * t[:, None] + 20 * x[None, :])
    area = added_mass_per_length(b, rho)
    h_x = np.gradient(h, x, axis=1)
    w = periodic_derivative(h, t[1]) + speed * h_x
    slope = np.gradient(area, x)

    def end(i: int) -> float:
        return area[i] * (0.5 * np.mean(w[:, i] ** 2) - speed * np.mean(w[:, i] * h_x[:, i]))

    expected = end(-1) - end(0) - 0.5 * trapezoid(slope * np.mean(w**2, axis=0), x)
    expected += trapezoid(np.where(slope < 0, speed * slope * np.mean(w * h_x, axis=0), 0), x)
    got = mean_pressure_thrust(x, b, h, t[1], speed, density_kg_m3=rho)
    assert got == pytest.approx(expected, rel=1e-3)
    assert abs(got) > 0.01  # not a vanishing case


def test_a_point_without_a_self_propelled_speed_fails_alone(monkeypatch):
    """A frequency whose speed balance has no root (here made so at 18 Hz) is a failed row
    naming why; the sweep's other frequencies keep their figures."""
    from fishfsi.cli import swimming as swimming_cli
    from fluid_adapter.swimming import SwimmingError

    real = swimming_cli.SwimmingModel.row

    def no_root_at_18(self, times, history, frequency_hz):
        if frequency_hz == 18.0:
            raise SwimmingError("the mean thrust exceeds the drag up to 2.51 m/s")
        return real(self, times, history, frequency_hz)

    monkeypatch.setattr(swimming_cli.SwimmingModel, "row", no_root_at_18)
    rows = sweep.linear_sweep(load_case(CASE), [6.0, 18.0], [Waveform.SQUARE])
    assert rows[0]["status"] == "ok" and rows[0]["swimming_speed_m_s"] > 0
    assert rows[1]["status"] == "failed: the mean thrust exceeds the drag up to 2.51 m/s"
