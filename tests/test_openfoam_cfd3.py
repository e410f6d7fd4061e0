"""Turek & Hron CFD3 (Re = 200, periodic vortex shedding past the cylinder and rigid flag) with
real OpenFOAM: the transient setup of the fish case against a sourced periodic answer, and the
LES option on a flow it must leave nearly alone.

Reference: Turek & Hron (2006), "Proposal for numerical benchmarking of fluid-structure
interaction between an elastic object and laminar incompressible flow", CFD3: drag
439.45 +- 5.6183 N/m, lift -11.893 +- 437.81 N/m, frequency 4.3956 Hz.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from fsi_orchestrator.case.schema import Turbulence
from turek_hron.cfd3 import (
    DRAG_MEAN_REF,
    FREQUENCY_REF_HZ,
    LIFT_AMPLITUDE_REF,
    Kick,
    run_cfd3,
    run_cfd3_models,
    shedding_statistics,
)


def test_shedding_statistics_of_a_known_signal():
    """Mean, (max - min) / 2 and frequency over whole periods of a two-harmonic signal."""
    t = np.linspace(0.0, 3.0, 30001)
    f = 4.0
    drag = 440.0 + 5.0 * np.sin(4 * np.pi * f * t)
    lift = -12.0 + 400.0 * np.sin(2 * np.pi * f * t + 0.3)
    stats = shedding_statistics(np.column_stack([t, drag, lift]), periods=4)
    assert stats["frequency_hz"] == pytest.approx(f, rel=1e-6)
    assert stats["drag_mean_n_m"] == pytest.approx(440.0, abs=1e-3)
    assert stats["drag_amplitude_n_m"] == pytest.approx(5.0, rel=1e-4)
    assert stats["lift_mean_n_m"] == pytest.approx(-12.0, abs=0.05)
    assert stats["lift_amplitude_n_m"] == pytest.approx(400.0, rel=1e-6)
    with pytest.raises(ValueError, match="run longer"):
        shedding_statistics(np.column_stack([t, drag, lift]), periods=20)


needs_openfoam = pytest.mark.skipif(
    shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed"
)
BODY_SIZE = 4e-3  # m at the body (CFD1 uses 2.5e-3): 9.5k cells, ~1 ms steps at Courant 2


@pytest.fixture(scope="module")
def shedding(tmp_path_factory):
    """Laminar from rest to 3 s, kicked into shedding from 0.6 s (left alone it develops from
    ~2.5 s and needs 6 s), then each model continues the same developed flow for 1.5 s, the
    three side by side; statistics over the last 4 periods of each."""
    root = tmp_path_factory.mktemp("cfd3")
    run_cfd3(root / "precursor", body_size=BODY_SIZE, end_time_s=3.0, kick=Kick())
    models = (Turbulence.LAMINAR, Turbulence.WALE, Turbulence.SMAGORINSKY)
    return run_cfd3_models(root / "precursor", root, models)


@pytest.mark.parametrize("model", [Turbulence.LAMINAR, Turbulence.WALE])
@pytest.mark.openfoam
@pytest.mark.slow
@needs_openfoam
def test_cfd3_shedding_matches_turek_hron(shedding, model):
    """Lift amplitude and frequency within 5 % and 3 %. The mean drag is 5.7 % high at this
    body size (CFD1's 2.5 mm mesh gets the steady drag to 0.01 %): 7 % allowed."""
    r = shedding[model]
    assert r.lift_amplitude_n_m == pytest.approx(LIFT_AMPLITUDE_REF, rel=0.05)
    assert r.frequency_hz == pytest.approx(FREQUENCY_REF_HZ, rel=0.03)
    assert r.drag_mean_n_m == pytest.approx(DRAG_MEAN_REF, rel=0.07)


@pytest.mark.openfoam
@pytest.mark.slow
@needs_openfoam
def test_wale_les_leaves_the_resolved_flow_alone_and_smagorinsky_damps_it(shedding):
    """On a laminar, resolved flow an LES model should vanish. WALE (nut -> 0 in pure shear and
    at walls) stays within 2 % of the laminar lift amplitude; Smagorinsky's nut (up to ~0.4 nu
    here) damps the shedding by more than 20 % while its frequency stays within 3 %."""
    laminar, wale, smag = (
        shedding[m] for m in (Turbulence.LAMINAR, Turbulence.WALE, Turbulence.SMAGORINSKY)
    )
    assert wale.lift_amplitude_n_m == pytest.approx(laminar.lift_amplitude_n_m, rel=0.02)
    assert wale.drag_mean_n_m == pytest.approx(laminar.drag_mean_n_m, rel=0.01)
    assert smag.lift_amplitude_n_m < 0.8 * laminar.lift_amplitude_n_m
    assert smag.frequency_hz == pytest.approx(FREQUENCY_REF_HZ, rel=0.03)
