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
    monkeypatch.setattr(post, "overlay_seed", lambda *args: drawn.append(args[2]))
    target = post.plot_sweep(tmp_path / "sweep.csv", tmp_path)
    assert target.is_file() and target.stat().st_size > 10_000 and drawn == ["clamped"]


@pytest.mark.parametrize(
    "head, amplitude_points, rig",
    [("clamped", 2, True), ("pinned", 0, True), ("free", 0, False), ("elastic", 0, False)],
)
def test_the_seed_overlay_follows_how_the_head_is_held(head, amplitude_points, rig):
    """The 1 Hz tail (Figs. 3.28, 4.8) was the head clamped; the thrust peak and range the
    rig's stick (Fig. 4.6, compared with the clamped FSI in Sec. 4.3.1); neither a free fish."""
    import matplotlib.pyplot as plt

    fig, (ax_amp, ax_thrust) = plt.subplots(2, 1)
    identity = {"case": {"boundary": {"head": head}}}
    post.overlay_seed(ax_amp, ax_thrust, post.head_support(identity))
    assert len(ax_amp.lines) == amplitude_points
    assert bool(ax_thrust.lines or ax_thrust.patches) == rig
    plt.close(fig)
    assert post.head_support({"case": {}}) == "clamped"  # the schema's default


def test_the_mesh_error_is_measured_at_shared_frequencies_and_interpolated_between():
    """Coarse 10 / 8 / 6 at 1, 3, 5 Hz; the default level has 11 at 1 Hz and 5.4 at 5 Hz:
    measured |1| and |-0.6| there; at 3 Hz the relative differences +10 % and -10 % average
    to 0; beyond the last shared frequency the relative error is held."""
    error, measured = post.mesh_errors([1, 3, 5, 7], [10, 8, 6, 4], [1, 5], [11, 5.4])
    assert error == pytest.approx([1.0, 0.0, 0.6, 0.4])
    assert measured.tolist() == [True, False, True, False]
    error, measured = post.mesh_errors([1, 3], [10, 8], [2], [9])
    assert all(e != e for e in error) and not measured.any()  # nothing shared: NaN


def _write_sweep(folder, rows, identity):
    folder.mkdir()
    with open(folder / "sweep.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (folder / "sweep_case.json").write_text(json.dumps(identity))


def _rows(points):
    return [
        {
            "waveform": "sine",
            "frequency_hz": f,
            "tip_amplitude_m": a,
            "mean_thrust_n": t,
            "thrust_source": "openfoam",
            "tip_amplitude_periodic_uncertainty_m": 1e-4,
            "mean_thrust_periodic_uncertainty_n": 1e-3,
        }
        for f, a, t in points
    ]


def test_fsi_post_draws_the_mesh_reference_and_lists_both_errors(tmp_path, capsys):
    default = json.loads(json.dumps(OPENFOAM_COARSE))
    default["case"]["fluid"]["mesh_level"] = "default"
    coarse = _rows([(3, 0.008, 0.014), (5, 0.005, 0.011), (7, "", "")])  # failed: no figures
    for row, status in zip(coarse, ("ok", "ok", "failed: coupling diverged"), strict=True):
        row["status"] = status
        row["slender_body_mean_thrust_n"] = row["mean_thrust_n"]  # as fsi-sweep writes it
    _write_sweep(tmp_path / "coarse", coarse, OPENFOAM_COARSE)
    _write_sweep(tmp_path / "default", _rows([(3, 0.0079, 0.0133)]), default)
    code = post.main([str(tmp_path / "coarse"), "--mesh-reference", str(tmp_path / "default")])
    assert code == 0
    with open(tmp_path / "coarse" / "sweep_errors.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    # "\n" line ends, as sweep.csv (csv's default "\r\n" showed as ^M)
    assert b"\r" not in (tmp_path / "coarse" / "sweep_errors.csv").read_bytes()
    assert [r["mesh_error"] for r in table] == ["measured", "interpolated", "interpolated"]
    # a failed point's NaN row says why
    assert [r["status"] for r in table] == ["ok", "ok", "failed: coupling diverged"]
    assert float(table[0]["mean_thrust_mesh_error_mn"]) == pytest.approx(0.7)
    # 5 Hz holds 3 Hz's relative difference, -5 %
    assert float(table[1]["mean_thrust_mesh_error_mn"]) == pytest.approx(0.55)
    assert float(table[1]["mean_thrust_periodic_uncertainty_mn"]) == pytest.approx(1.0)


def test_a_mesh_reference_of_another_case_or_the_same_level_is_refused_in_one_line(
    tmp_path, capsys
):
    other = json.loads(json.dumps(OPENFOAM_COARSE))
    other["case"]["fluid"]["mesh_level"] = "default"
    other["case"]["geometry"]["preset"] = "serial"
    _write_sweep(tmp_path / "coarse", _rows([(3, 0.008, 0.014)]), OPENFOAM_COARSE)
    _write_sweep(tmp_path / "serial", _rows([(3, 0.01, 0.02)]), other)
    _write_sweep(tmp_path / "same", _rows([(3, 0.01, 0.02)]), OPENFOAM_COARSE)
    # another case on the same level: what differs is the case, not the level
    other_coarse = json.loads(json.dumps(other))
    other_coarse["case"]["fluid"]["mesh_level"] = "coarse"
    _write_sweep(tmp_path / "serial_coarse", _rows([(3, 0.01, 0.02)]), other_coarse)
    for folder, says in (
        ("serial", "geometry.preset"),
        ("same", "same fluid.mesh_level"),
        ("serial_coarse", "another sweep, not only another fluid.mesh_level (geometry.preset"),
    ):
        code = post.main([str(tmp_path / "coarse"), "--mesh-reference", str(tmp_path / folder)])
        err = capsys.readouterr().err.strip()
        assert code == 2 and says in err and len(err.splitlines()) == 1
    code = post.main([str(tmp_path / "coarse"), "--mesh-reference", str(tmp_path / "nowhere")])
    assert code == 2 and "--mesh-reference" in capsys.readouterr().err


@pytest.mark.parametrize(
    "table, expected",
    [
        ("", "sweep.csv: no rows; run fsi-sweep into that folder (again)"),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,abc1.0,0.01,ok\n",
            "sweep.csv, line 2: frequency_hz = 'abc1.0' is not a number",
        ),
        (  # cut short while being copied
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,1.0,0.01,ok\nsine,3.0\n",
            "sweep.csv, line 3: 2 cells where the header has 4 (a cut or edited table); run "
            "fsi-sweep into that folder again with --resume",
        ),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,1.0,inf,ok\n",
            "sweep.csv, line 2: tip_amplitude_m = 'inf' is not finite for a point whose status "
            "is 'ok'",
        ),
        (  # a drawn swimming figure
            "waveform,frequency_hz,tip_amplitude_m,swimming_speed_m_s,status\n"
            "square,18,0.007,nan,ok\n",
            "sweep.csv, line 2: swimming_speed_m_s = 'nan' is not finite for a point whose "
            "status is 'ok'",
        ),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,-3,0.01,ok\n",
            "sweep.csv, line 2: frequency_hz = '-3' is outside the drive's 0.01..1000 Hz "
            "(actuation.frequency_hz)",
        ),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,1e308,0.01,ok\n",
            "sweep.csv, line 2: frequency_hz = '1e308' is outside the drive's 0.01..1000 Hz "
            "(actuation.frequency_hz)",
        ),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\ntriangle,3,0.01,ok\n",
            "sweep.csv, line 2: waveform = 'triangle' is none of sine, square",
        ),
        (  # an empty picture would say nothing
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,3,,failed: crashed\n",
            "sweep.csv: no point finished (each row's status says why; its folder keeps "
            "failure.txt); nothing to draw",
        ),
        (
            "waveform,frequency_hz,tip_amplitude_m,status\nsine,nan,,failed: crashed\n",
            "sweep.csv, line 2: frequency_hz = 'nan' is not finite for a point whose status "
            "is 'failed: crashed'",
        ),
    ],
)
def test_a_damaged_sweep_table_is_refused_in_one_line(tmp_path, capsys, table, expected):
    (tmp_path / "sweep.csv").write_text(table)
    assert post.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {tmp_path / expected}"
    assert not (tmp_path / "sweep.png").exists()


def test_an_output_that_cannot_be_a_folder_is_refused_in_one_line(tmp_path, capsys):
    (tmp_path / "sweep.csv").write_text("waveform,frequency_hz,tip_amplitude_m\nsine,3,0.01\n")
    (tmp_path / "afile").write_text("")
    for output in (tmp_path / "afile", tmp_path / "afile" / "sub"):
        assert post.main([str(tmp_path), "--output", str(output)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"error: --output {output}: cannot write there (") and "\n" not in err


def test_a_missing_path_and_a_mesh_reference_to_a_run_are_refused_in_one_line(tmp_path, capsys):
    assert post.main([str(tmp_path / "nowhere")]) == 2
    assert capsys.readouterr().err.strip().endswith("nowhere: no such file or folder")
    (tmp_path / "results.h5").write_text("")
    assert post.main([str(tmp_path), "--mesh-reference", str(tmp_path)]) == 2
    assert "--mesh-reference applies to a sweep's sweep.csv" in capsys.readouterr().err


def test_a_run_without_windows_is_refused_in_one_line(tmp_path, capsys):
    """A run stopped in its set-up leaves a results file with no rows: nothing to draw."""
    import h5py

    with h5py.File(tmp_path / "results.h5", "w") as h5:
        h5.create_dataset("time_s", shape=(0, 1), maxshape=(None, 1))
        h5.create_dataset("shell/tip_displacement_m", shape=(0, 3), maxshape=(None, 3))
    assert post.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {tmp_path / 'results.h5'}: no windows yet") and "\n" not in err
    assert not (tmp_path / "run.png").exists()


def test_a_vacuum_sweep_without_a_thrust_column_is_drawn(tmp_path, capsys):
    """A linear sweep in vacuum writes no thrust: the amplitude curve is still drawn."""
    rows = [
        {"waveform": "sine", "frequency_hz": f, "tip_amplitude_m": a, "status": "ok"}
        for f, a in ((3, 0.006), (5, 0.004))
    ]
    _write_sweep(tmp_path / "vacuum", rows, {"method": "linear", "case": {}})
    assert post.main([str(tmp_path / "vacuum")]) == 0
    assert (tmp_path / "vacuum" / "sweep.png").stat().st_size > 10_000
