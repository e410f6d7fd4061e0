"""The periodic state estimated from a run's per-period figures (fsi_orchestrator.periodic):
exact on a geometric sequence, and bracketing a measured start-up's limit."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from fsi_orchestrator.periodic import estimate, summary_fields
from tests.conftest import strict_json

# The main job's scene (default level, iqn-ils-am) continued to 10 periods, docs/coupling.md
# "The main job run on to its periodic state": tail amplitude (mm) and mean thrust (N) per
# period; periods 9-10 agree to 0.1 % / 0.2 %.
AMPLITUDE_MM = [7.770, 7.667, 8.134, 7.643, 7.901, 7.864, 7.789, 7.878, 7.837, 7.846]
THRUST_N = [
    0.01382,
    0.01342,
    0.01473,
    0.01292,
    0.01384,
    0.01353,
    0.01323,
    0.01349,
    0.01330,
    0.01333,
]


def test_a_geometric_alternating_sequence_gives_its_limit():
    """x_k = 7.85 + 0.3 (-0.6)^k: the Aitken limit is exact from three periods."""
    x = [7.85 + 0.3 * (-0.6) ** k for k in range(4)]
    found = estimate(x)
    assert found.value == pytest.approx(7.85, rel=1e-12)
    assert found.periods == 4 and found.uncertainty == pytest.approx(abs(x[-1] - x[-2]))


def test_one_period_has_no_uncertainty_bound_and_none_is_not_periodic():
    one = estimate([0.0123])
    assert one.value == 0.0123 and math.isinf(one.uncertainty) and not one.is_periodic(0.5)
    assert estimate([]) is None
    assert summary_fields({"tip_amplitude": ([], "m")}, 0.01) == {"periodic": False}


@pytest.mark.parametrize(("series", "limit"), [(AMPLITUDE_MM, 7.85), (THRUST_N, 0.0133)])
def test_the_measured_start_up_limit_lies_within_the_estimate_from_period_two_on(series, limit):
    for n in range(2, len(series) + 1):
        found = estimate(series[:n])
        assert abs(found.value - limit) <= found.uncertainty, (n, found)


def test_the_summary_says_periodic_once_every_figure_is_known_to_the_tolerance():
    def fields(n):
        return summary_fields(
            {"tip_amplitude": (AMPLITUDE_MM[:n], "mm"), "mean_thrust": (THRUST_N[:n], "n")}, 0.01
        )

    late, early = fields(10), fields(5)
    assert late["periodic"] and not early["periodic"]
    assert late["tip_amplitude_periodic_mm"] == pytest.approx(7.85, abs=0.01)
    assert late["mean_thrust_periodic_n"] == pytest.approx(0.0133, rel=0.005)
    assert set(late) == {
        "tip_amplitude_periodic_mm",
        "tip_amplitude_periodic_uncertainty_mm",
        "mean_thrust_periodic_n",
        "mean_thrust_periodic_uncertainty_n",
        "periodic",
    }


def vacuum_fish_summary(output: Path, periods: int, *overrides: str) -> dict:
    """fsi-run --json of the coarse fish_vacuum_3Hz case, 20 windows per period."""
    case = Path(__file__).resolve().parents[1] / "cases/fish_vacuum_3Hz"
    sets = ["mesh.level=coarse", f"time.periods={periods}", "output.vtk=false"]
    sets += ["time.steps_per_period=20", *overrides]
    done = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.run", str(case), "--json", "--quiet"]
        + [x for s in sets for x in ("--set", s)]
        + ["--output", str(output)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return strict_json(done.stdout)


def test_an_uncertainty_not_known_yet_is_null_in_strict_json(tmp_path):
    """One period bounds nothing: the estimate's uncertainty is infinite in Python and null in
    --json and summary.json, which jq reads (it refuses Infinity)."""
    summary = vacuum_fish_summary(tmp_path / "run", 1)
    assert summary["tip_amplitude_periodic_m"] > 0
    assert summary["tip_amplitude_periodic_uncertainty_m"] is None
    assert summary["periodic"] is False
    assert strict_json((tmp_path / "run" / "summary.json").read_text()) == summary


def test_a_figure_not_known_yet_prints_as_none_in_the_plain_summary_too(capsys):
    """What --json prints as null (an infinite uncertainty, a NaN, None) is "none" in the
    plain summary as well, alone or in a list or a table; it printed inf and nan."""
    import numpy as np

    from fishfsi.cli.common import emit

    summary = {
        "tip_amplitude_periodic_uncertainty_m": math.inf,
        "non_fluid_share": np.float64("nan"),
        "iterated_fluid_solves_per_window": None,
        "mean_thrust_per_period_n": [0.0125, -math.inf],
        "start_correction": {"added_mass_kg": 1.5e-4, "damping_ns_m": math.nan},
        "tip_amplitude_m": 0.00784512345,
        "windows": 40,
        "periodic": False,
    }
    emit(summary, as_json=True)
    printed = strict_json(capsys.readouterr().out)
    emit(summary, as_json=False)
    lines = dict(line.strip().split(": ", 1) for line in capsys.readouterr().out.splitlines())
    assert lines == {
        "tip_amplitude_periodic_uncertainty_m": "none",
        "non_fluid_share": "none",
        "iterated_fluid_solves_per_window": "none",
        "mean_thrust_per_period_n": "[0.0125, none]",
        "start_correction": "{added_mass_kg: 0.00015, damping_ns_m: none}",
        "tip_amplitude_m": "0.00784512",
        "windows": "40",
        "periodic": "False",
    }
    assert [k for k, v in printed.items() if v is None] == list(summary)[:3]


def test_fsi_run_json_carries_the_estimate_and_windows_per_period(tmp_path):
    summary = vacuum_fish_summary(tmp_path / "run", 2)
    assert summary["windows_per_period"] == 20 and summary["periodic_tolerance"] == 0.01
    assert len(summary["tip_amplitude_per_period_m"]) == 2
    found = estimate(summary["tip_amplitude_per_period_m"])
    assert summary["tip_amplitude_periodic_m"] == found.value
    assert summary["tip_amplitude_periodic_uncertainty_m"] == found.uncertainty
    assert summary["periodic"] == found.is_periodic(0.01)
    assert "mean_thrust_periodic_n" not in summary  # in vacuum: no thrust per period


def test_a_fast_fluid_runs_thrust_has_its_per_period_figures_and_estimate(tmp_path):
    """The fast thrust over each complete period (the last is the run's thrust) and
    its periodic estimate, as OpenFOAM's thrust has: a sweep row then holds no NaN for it."""
    summary = vacuum_fish_summary(tmp_path / "run", 3, "fluid.model=slender_body")
    thrust = summary["mean_thrust_per_period_n"]
    assert len(thrust) == 3 and summary["thrust_source"] == "slender_body"
    assert thrust[-1] == summary["mean_thrust_n"]
    # the run's thrust has the shedding efficiency; Lighthill's stays beside it, larger
    assert 0 < summary["mean_thrust_n"] < summary["slender_body_mean_thrust_n"]
    found = estimate(thrust)
    assert summary["mean_thrust_periodic_n"] == found.value
    assert summary["mean_thrust_periodic_uncertainty_n"] == found.uncertainty
