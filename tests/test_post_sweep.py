"""fsi-post on a sweep: the legend names the thrust's source and the mesh level, the periodic
estimate's uncertainty draws error bars, and the original fish's curves carry the seed's
figures (1 Hz tail: FSI 34 mm, experiment 24.7 mm; thrust peak at 18 Hz; the rig's 0.107 N)."""

from __future__ import annotations

import csv
import json

import matplotlib
import pytest

from fishfsi.cli import post

matplotlib.use("Agg")

OPENFOAM_COARSE = {
    "method": "transient",
    "case": {
        "geometry": {"kind": "fish", "preset": "original"},
        "fluid": {"model": "openfoam", "mesh_level": "coarse"},
        "mesh": {"level": "default"},
    },
}


def test_the_label_names_the_thrust_source_and_the_mesh_level():
    rows = [{"thrust_source": "openfoam"}]
    assert post.sweep_label(OPENFOAM_COARSE, rows) == "openfoam; OpenFOAM coarse"
    linear = {"method": "linear", "case": {"mesh": {"level": "coarse"}, "fluid": {}}}
    assert post.sweep_label(linear, [{}]) == "slender_body; shell coarse, linear"
    assert post.sweep_label(None, rows) == "openfoam"


def test_only_the_original_fish_gets_the_seed_overlay():
    assert post.is_original_fish(OPENFOAM_COARSE)
    serial = {"case": {"geometry": {"kind": "fish", "preset": "serial"}}}
    assert not post.is_original_fish(serial) and not post.is_original_fish(None)


def test_the_rig_range_is_the_load_cell_through_the_lever():
    """Sec. 4.3.1: F_t = l1 F_s / l2, l1 = 45 mm, l2 = 210 mm, a 0.5 N load cell."""
    assert post.RIG_READABLE_N == pytest.approx(0.5 * 45 / 210, abs=5e-4)


def test_a_sweep_with_uncertainties_is_drawn_with_the_overlay(tmp_path, monkeypatch):
    rows = [
        {
            "waveform": "square",
            "frequency_hz": f,
            "tip_amplitude_m": a,
            "mean_thrust_n": t,
            "thrust_source": "openfoam",
            "tip_amplitude_periodic_uncertainty_m": 1e-4,
            "mean_thrust_periodic_uncertainty_n": "",
        }
        for f, a, t in ((1.0, 0.025, 0.002), (18.0, 0.004, 0.09))
    ]
    with open(tmp_path / "sweep.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (tmp_path / "sweep_case.json").write_text(json.dumps(OPENFOAM_COARSE))
    drawn = []
    monkeypatch.setattr(post, "overlay_seed", lambda *axes: drawn.append(len(axes)))
    target = post.plot_sweep(tmp_path / "sweep.csv", tmp_path)
    assert target.is_file() and target.stat().st_size > 10_000 and drawn == [2]
