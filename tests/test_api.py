"""The Python API (fsi_orchestrator.load_case / run / Results), as docs/user_guide.md shows it:
the same summary as ``fsi-run --json`` and typed access to the time series."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fsi_orchestrator as fsi

ROOT = Path(__file__).resolve().parents[1]
SETTINGS = ["mesh.level=coarse", "time.periods=0.5", "output.vtk=false"]


def test_the_api_runs_a_case_as_fsi_run_does(tmp_path):
    case = fsi.load_case(ROOT / "cases/fish_vacuum_3Hz", overrides=SETTINGS)
    results = fsi.run(case, tmp_path / "api", overrides=SETTINGS)
    cli = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.run", str(ROOT / "cases/fish_vacuum_3Hz")]
        + [a for s in SETTINGS for a in ("--set", s)]
        + ["--json", "--quiet", "--output", str(tmp_path / "cli")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert cli.returncode == 0, cli.stderr
    summary = json.loads(cli.stdout)
    timed = {"wall_s", "setup_s", "results", "mean_newton_iterations_per_window"}
    assert set(results.summary) == set(summary)
    for key in set(summary) - timed:
        np.testing.assert_allclose(np.asarray(results.summary[key]), summary[key], rtol=1e-12)
    assert results.time_s.shape == (20,) and results.time_s[-1] == pytest.approx(1 / 6)
    tip = results.tip_displacement_m
    assert tip.shape == (20, 3)
    assert results.summary["tip_amplitude_m"] == pytest.approx(np.ptp(tip[:, 2]) / 2)
    assert results.thrust_n is None  # in vacuum the fluid reports no force
    assert "shell/tip_displacement_m" in results.names()
    np.testing.assert_array_equal(results.series("shell/tip_displacement_m"), tip)
    assert json.loads(results.attributes["overrides"]) == SETTINGS


def test_the_api_refuses_bad_input_with_the_commands_line():
    with pytest.raises(fsi.CaseError, match=r"actuation.frequency_hz must be >= 0.01, got -3"):
        fsi.load_case(ROOT / "cases/fish_vacuum_3Hz", overrides=["actuation.frequency_hz=-3"])


def test_the_api_finds_the_application_layer_without_importing_it(monkeypatch):
    """``import fsi_orchestrator`` alone loads and checks a case (the composition root comes
    through its entry point), and says in one line when no application layer is installed."""
    from fsi_orchestrator import api

    script = (
        "import sys, fsi_orchestrator as fsi\n"
        "assert not any(m.startswith('fishfsi') for m in sys.modules)\n"
        f"fsi.load_case({str(ROOT / 'cases/fish_vacuum_3Hz')!r})\n"
        "print(sorted(m for m in sys.modules if m.startswith('fishfsi')))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd="/"
    )
    assert "fishfsi.cli.root" in done.stdout

    api.composition_root.cache_clear()
    monkeypatch.setattr(api, "entry_points", lambda group: [])
    try:
        with pytest.raises(RuntimeError, match=r"no composition root installed .*pip install"):
            fsi.load_case(ROOT / "cases/fish_vacuum_3Hz")
    finally:
        api.composition_root.cache_clear()
