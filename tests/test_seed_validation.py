"""The robot model held to the seed's experiments (docs/validation.md): the calibration set of
the original fish, and the predictions with the calibration frozen in cases/seed/*.

The fast model of benchmarks/seed_validation.py: the default shell level (columns graded to the
outline), potential flow in the tank, the edge drag fitted to OpenFOAM, the linear periodic
response. Targets the model misses are strict
xfails: they fail the suite once the model meets them, so the docs get updated.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from tests.conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))

import seed_validation as sv  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def fast():
    return sv.FastModel(cache={})


def _frozen(name: str, *overrides: str):
    """The case as frozen (the calibrated values are in its case.toml), fast fluid."""
    from fsi_orchestrator.case.loader import load_case

    return load_case(sv.SEED / name, ["fluid.model=potential", *overrides])


def _first_bending(fast, name: str) -> float:
    return fast.bending_modes(_frozen(name, "boundary.head=free"), 1)[0]


def test_calibration_original_first_wet_mode(fast):
    """Table 4.2: 6 Hz measured (Table 3.7: 5.99 Hz simulated), fitted with the CFRP modulus."""
    assert _first_bending(fast, "amplitude_3Hz") == pytest.approx(6.0, rel=0.02)


def test_calibration_original_amplitudes(fast):
    """Fig. 4.4: 19 mm at 3 Hz sine; Fig. 4.8: 24.7 mm at 1 Hz square, head held. One
    electrode spacing and one held length cannot give both: the fit leaves -22 % / +15 %."""
    sine = fast.orbit(_frozen("amplitude_3Hz"))["tip_mm"]
    square = fast.orbit(_frozen("fixed_head_sweep"))["tip_mm"]
    assert sine == pytest.approx(19.0, rel=0.30)
    assert square == pytest.approx(24.7, rel=0.20)
    assert sine / square < 19.0 / 24.7  # the model's 1 Hz / 3 Hz ratio is the open gap


def test_original_second_wet_mode_is_a_prediction_within_10_percent(fast):
    """Table 4.2: 25 Hz measured; not fitted."""
    modes = fast.bending_modes(_frozen("amplitude_3Hz", "boundary.head=free"), 2)
    assert modes[1] == pytest.approx(25.0, rel=0.10)


def test_serial_first_wet_mode_within_10_percent(fast):
    """Table 5.3: 4 Hz measured (Table 5.1: 3.95 Hz simulated); a prediction (4.19 Hz). On
    uniform columns the 3 mm peduncle was one element and the mode 5.3 Hz."""
    assert _first_bending(fast, "serial_prototype") == pytest.approx(4.0, rel=0.10)


@pytest.mark.xfail(
    strict=True,
    reason="integrative f1 2.62 Hz vs 2 Hz measured (+31 %; 2.41 Hz recalibrated on converged "
    "meshes, benchmarks/wet_mode_convergence.py; the seed's model 2.5 Hz, Table 5.5); the case "
    "holds none of the mean strain, with half held 2.21 Hz (the test below)",
)
def test_integrative_first_wet_mode_within_10_percent(fast):
    """Table 5.7: 2 Hz measured (Table 5.5: 2.5 Hz simulated)."""
    assert _first_bending(fast, "integrative_prototype") == pytest.approx(2.0, rel=0.10)


def test_the_integrative_robots_measured_modes_lie_where_half_the_mean_strain_is_held(fast):
    """Table 5.7: 2 / 10 Hz, read while the robot was driven (-500..+1500 V square, Sec.
    5.4.3). About the equilibrium under the mean voltages, with half the mean induced strain
    held (the case holds none), the first two wet bending modes on the default shell level
    are 2.21 / 9.66 Hz, +10.5 / -3.4 % (12 % here: the 10 % target is the xfail above, on the
    case's own share); with none held 2.62 / 11.84 Hz (+31 / +18 %), and the plate buckles at
    0.64 held (0.54 on the fine shell level, where 0.4 held gives 2.23 / 9.31 Hz). The
    original fish's first mode, the calibration, moves by under 2 % over the same shares, so
    the calibration set cannot tell the share."""

    def modes(name: str, share: float) -> list[float]:
        free = _frozen(name, "boundary.head=free", f"actuation.mean_strain_transfer={share}")
        return fast.bending_modes(free, 2, about_mean_voltage=True)

    half = modes("integrative_prototype", 0.5)
    assert half[0] == pytest.approx(2.0, rel=0.12)
    assert half[1] == pytest.approx(10.0, rel=0.12)
    assert modes("integrative_prototype", 0.0)[0] > 1.25 * 2.0
    for share in (0.0, 0.5, 1.0):
        assert modes("amplitude_3Hz", share)[0] == pytest.approx(6.0, rel=0.02)


@pytest.fixture(scope="module")
def thrust_curve(fast):
    """The rig's curve: the fish hinged at the nose, where the stick touches it."""
    frequencies = (3, 5, 10, 13, 14, 15, 16, 17, 18, 20, 22, 25)
    return {
        f: fast.orbit(_frozen("thrust_rig", f"actuation.frequency_hz={f}"))["thrust_n"]
        for f in frequencies
    }


def test_thrust_peaks_where_the_rig_measured_it(thrust_curve):
    """Fig. 4.6: the thrust peaks at 18 Hz (target 15-20 Hz). On the stick's hinge the fish's
    second wet bending mode is at 16.2 Hz; the model's thrust peaks at 15 Hz."""
    peak = max(thrust_curve, key=thrust_curve.get)
    assert 15 <= peak <= 20


def test_the_hinged_fast_thrust_follows_openfoams_on_the_same_rig(fast):
    """OpenFOAM coupled on the hinged rig (coarse level, square wave; its highest point is
    16 Hz, benchmarks/data/openfoam_hinged_rig_coarse.toml): the fast thrust within 40 % of it
    at 3, 5, 12, 16 and 20 Hz (measured: -35 / -32 / -19 / -14 / +12 %), highest at 16 Hz
    of these, and its 5 Hz thrust about twice its 3 Hz thrust, as the CFD's (x1.97)."""
    import tomllib

    data = tomllib.loads((ROOT / "benchmarks/data/openfoam_hinged_rig_coarse.toml").read_text())[
        "square"
    ]
    fast_thrust = {}
    for f, cfd in zip(data["frequency_hz"], data["thrust_mn"], strict=True):
        fast_thrust[f] = fast.orbit(_frozen("thrust_rig", f"actuation.frequency_hz={f}"))[
            "thrust_n"
        ]
        assert 1e3 * fast_thrust[f] == pytest.approx(cfd, rel=0.40)
    assert max(fast_thrust, key=fast_thrust.get) == 16
    cfd_ratio = data["thrust_mn"][1] / data["thrust_mn"][0]
    assert fast_thrust[5] / fast_thrust[3] == pytest.approx(cfd_ratio, rel=0.10)


def test_the_clamped_head_puts_the_thrust_peak_elsewhere(fast):
    """The support decides where the curve peaks: clamped as in the seed's FSI (Sec. 3.5.2),
    the thrust rises toward the third wet bending mode (27.4 Hz) at 25 Hz, and at 18 Hz it is
    under a tenth of the hinged fish's."""
    clamped = {
        f: fast.orbit(
            _frozen("thrust_rig", f"actuation.frequency_hz={f}", "boundary.head=clamped")
        )["thrust_n"]
        for f in (15, 18, 25)
    }
    hinged = fast.orbit(_frozen("thrust_rig", "actuation.frequency_hz=18"))["thrust_n"]
    assert clamped[25] > clamped[15] > clamped[18]
    assert clamped[18] < 0.1 * hinged


def test_the_thrust_curve_is_finite_and_positive_and_the_harmonics_are_damped(fast, thrust_curve):
    """Every point finite and pushing forward. With the head clamped, at 18 Hz the drag,
    linearized on every
    harmonic's velocity, keeps the square wave's harmonics from ringing the fin: on the drag
    alone the thrust is under half of what the drag linearized on the fundamental alone gives
    (71 against 220 mN on the frozen case); the edge inertia moves the fin's modes off the
    harmonics too, and with it the gap narrows (39 against 55 mN)."""
    assert all(np.isfinite(v) and v > 0 for v in thrust_curve.values())
    fundamental = sv.FastModel(cache={}, all_harmonics=False)
    at_18 = _frozen("thrust_rig", "actuation.frequency_hz=18", "boundary.head=clamped")
    assert fast.orbit(at_18)["thrust_n"] < 0.8 * fundamental.orbit(at_18)["thrust_n"]
    drag_alone = _frozen(
        "thrust_rig",
        "actuation.frequency_hz=18",
        "boundary.head=clamped",
        "fluid.edge_inertia=false",
    )
    every = sv.FastModel(cache={}).orbit(drag_alone)["thrust_n"]
    assert every < 0.5 * fundamental.orbit(drag_alone)["thrust_n"]


@pytest.mark.xfail(
    strict=True, reason="hinged: fast thrust at the peak 0.71 N, OpenFOAM 0.81 N; rig <= 0.107 N"
)
def test_peak_thrust_within_what_the_rig_could_read(thrust_curve):
    """Sec. 4.3.1: 0.5 N load cell x 45 / 210 mm lever = 0.107 N at most."""
    assert max(thrust_curve.values()) <= 0.107


@pytest.mark.xfail(
    strict=True, reason="hinged: 5 Hz / 3 Hz thrust 2.05 (OpenFOAM 1.97); seed FSI below 1"
)
def test_5hz_thrust_below_3hz_thrust(thrust_curve):
    """Sec. 3.5.2.4 (the seed's clamped FSI, Fig. 3.25): the 5 Hz thrust is below the 3 Hz
    thrust; the seed reports no such dip from its rig."""
    assert thrust_curve[5] < thrust_curve[3]
