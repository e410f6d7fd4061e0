"""Prescribed first-mode motion at 3 Hz (one-way, real OpenFOAM): the fish makes thrust.

Amplitude: the seed's acoustic-model tail amplitude at 3 Hz, about 20 mm (Sec. 3.4.3, Fig. 3.17;
shared/reference/seed_data.toml, robot_original.transient_acoustic). Thrust = -F_x: the fish swims
toward -x. Cross-check: Lighthill's elongated-body estimate of the same motion
(fluid_adapter.slender_body); a coarse 3D RANS result within a factor 3 of it is a sanity bound,
not a validation.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from fluid_adapter.openfoam.prescribed import (
    ACOUSTIC_TAIL_AMPLITUDE_M,
    run_prescribed,
    slender_body_estimate,
)
from fsi_orchestrator.case.loader import case_from_dict

pytestmark = [
    pytest.mark.openfoam,
    pytest.mark.skipif(shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed"),
]
WINDOWS = 24  # per period


@pytest.fixture(scope="module")
def flapping(tmp_path_factory):
    root = tmp_path_factory.mktemp("thrust")
    case = case_from_dict({"fluid": {"model": "openfoam", "mesh_level": "coarse"}}, root)
    result = run_prescribed(
        case,
        root / "fish",
        amplitude_m=ACOUSTIC_TAIL_AMPLITUDE_M,
        periods=2,
        steps_per_period=WINDOWS,
    )
    return case, result


def test_mean_thrust_is_propulsive(flapping):
    case, result = flapping
    thrust = result.mean_thrust(WINDOWS)
    estimate = slender_body_estimate(case)
    print(f"mean thrust {thrust:.4f} N (slender body {estimate:.4f} N), {result.cells} cells")
    assert thrust > 0
    assert 1 / 3 < thrust / estimate < 3


def test_pressure_field_on_both_faces_is_reported(flapping):
    _, result = flapping
    p = result.last.pressure_pa
    assert p.shape == (len(result.last.face_centres),) and np.isfinite(p).all()
    n = len(p) // 2  # +z face then -z face: the swinging plate pushes on one, pulls on the other
    assert np.abs(p).max() > 10.0
    assert np.sign(np.median(p[:n])) != np.sign(np.median(p[n:]))


def test_lateral_force_swings_at_the_driving_frequency(flapping):
    _, result = flapping
    fz = result.force_n[-WINDOWS:, 2]
    spectrum = np.abs(np.fft.rfft(fz - fz.mean()))
    assert np.argmax(spectrum) == 1  # one oscillation per period
