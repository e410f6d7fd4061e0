"""fsi-design: study files, bad input in one line, the linear evaluation against fsi-sweep's,
infeasible designs, --resume, the best case and --json (the beam in liquid, coarse, linear:
a few seconds per design)."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from fishfsi.cli import design as design_cli
from fishfsi.cli.linear import linear_sweep
from fishfsi.design.study import parse_constraint
from fsi_orchestrator.case import load_case
from fsi_orchestrator.case.schema import Waveform

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "cases/beam_in_liquid"

# three drive frequencies, 2, 4 and 6 Hz; the constraint leaves 6 Hz infeasible
STUDY = f"""
[base]
case = "{BEAM}"
overrides = ["mesh.level=coarse"]

[[parameters]]
key = "actuation.frequency_hz"
low = 2.0
high = 6.0

[[constraints]]
expression = "actuation.frequency_hz <= 5"

[objective]
quantity = "tip_amplitude_m"
sense = "max"

[method]
kind = "one-at-a-time"
points = 3
"""


def write_study(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text(text)
    return folder


def run_json(capsys, *argv: str) -> dict:
    assert design_cli.main([*argv, "--json", "--quiet"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """The study above, run once (in-process, one worker)."""
    folder = write_study(tmp_path_factory.mktemp("design") / "study", STUDY)
    out = folder / "output"
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = design_cli.main([str(folder), "--json", "--quiet"])
    assert code == 0
    return folder, out, json.loads(text.getvalue())


def rows_of(out: Path) -> list[dict]:
    with open(out / "evaluations.csv") as fh:
        return list(csv.DictReader(fh))


def test_one_at_a_time_records_every_design_and_the_best_is_the_tables_max(finished):
    _, out, summary = finished
    rows = rows_of(out)
    assert [float(r["actuation.frequency_hz"]) for r in rows] == [2.0, 4.0, 6.0]
    assert [r["status"] for r in rows] == ["ok", "ok", "infeasible"]
    assert "actuation.frequency_hz <= 5" in rows[2]["reason"]
    ok = [r for r in rows if r["status"] == "ok"]
    best = max(ok, key=lambda r: float(r["tip_amplitude_m"]))
    assert summary["best"]["objective"] == pytest.approx(float(best["tip_amplitude_m"]), rel=1e-15)
    assert summary["best"]["parameters"] == {
        "actuation.frequency_hz": float(best["actuation.frequency_hz"])
    }
    assert (summary["evaluations"], summary["ok"], summary["infeasible"]) == (3, 2, 1)
    assert {r["fidelity_method"] for r in ok} == {"linear"}
    with h5py.File(out / "evaluations.h5") as h5:
        np.testing.assert_array_equal(h5["parameters"][:, 0], [2.0, 4.0, 6.0])
        assert [s.decode() for s in h5["status"][:]] == ["ok", "ok", "infeasible"]
    for name in ("response.png", "history.png"):
        assert (out / name).stat().st_size > 0


def test_the_evaluations_table_has_unix_line_ends(finished):
    """csv's default "\\r\\n" showed as ^M in a terminal, diff and awk."""
    _, out, _ = finished
    text = (out / "evaluations.csv").read_bytes()
    assert b"\r" not in text and text.endswith(b"\n")


def test_the_linear_evaluation_is_fsi_sweeps_linear_response(finished):
    """Reference: fsi-sweep --method linear (linear_sweep) on the same case at 2 and 4 Hz."""
    _, out, _ = finished
    case = load_case(BEAM, ["mesh.level=coarse"])
    sweep = linear_sweep(case, [2.0, 4.0], [Waveform.SINE])
    rows = rows_of(out)[:2]
    for row, point in zip(rows, sweep, strict=True):
        assert float(row["tip_amplitude_m"]) == pytest.approx(point["tip_amplitude_m"], abs=1e-9)
        summary = json.loads((out / "evaluations" / row["folder"] / "summary.json").read_text())
        assert summary["summary"]["mean_thrust_n"] == point["mean_thrust_n"]  # with shedding
        assert (
            summary["summary"]["slender_body_mean_thrust_n"] == point["slender_body_mean_thrust_n"]
        )


def test_the_best_case_is_a_case_folder_with_the_best_values(finished):
    _, out, summary = finished
    case = load_case(out / "best_case")
    assert case.actuation.frequency_hz == summary["best"]["parameters"]["actuation.frequency_hz"]
    assert case.mesh.level.value == "coarse"
    base = load_case(BEAM)
    assert case.fluid == base.fluid and case.geometry == base.geometry


def test_resume_skips_finished_evaluations_and_runs_only_new_designs(finished, tmp_path, capsys):
    folder, out, first = finished
    study = write_study(tmp_path / "study", STUDY.replace("points = 3", "points = 5"))
    shutil.copytree(out, tmp_path / "out")
    # same study file, another `points`: the finished designs (2, 4, 6 Hz) are reused
    again = run_json(capsys, str(study), "--output", str(tmp_path / "out"), "--resume")
    assert (again["evaluations"], again["resumed"], again["evaluated_now"]) == (5, 3, 2)
    rows = rows_of(tmp_path / "out")
    assert sorted(float(r["actuation.frequency_hz"]) for r in rows) == [2, 3, 4, 5, 6]
    assert again["best"]["objective"] >= first["best"]["objective"]


def test_resume_refuses_the_output_of_another_study(finished, tmp_path, capsys):
    _, out, _ = finished
    other = write_study(tmp_path / "other", STUDY.replace('sense = "max"', 'sense = "min"'))
    code = design_cli.main([str(other), "--output", str(out), "--resume"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "another study" in err[0]


def test_resume_refuses_evaluations_whose_study_is_unknown(finished, tmp_path, capsys):
    """Without study.json the evaluations may be another study's: not reused."""
    folder, out, _ = finished
    shutil.copytree(out, tmp_path / "out")
    (tmp_path / "out" / "study.json").unlink()
    code = design_cli.main([str(folder), "--output", str(tmp_path / "out"), "--resume"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "study.json is missing or damaged" in err[0] and "--overwrite" in err[0]


def test_resume_evaluates_again_a_design_whose_record_lost_its_figures(finished, tmp_path, capsys):
    folder, out, first = finished
    shutil.copytree(out, tmp_path / "out")
    record = tmp_path / "out" / "evaluations" / "0001" / "summary.json"
    damaged = json.loads(record.read_text())
    damaged["objectives"] = {k: float("nan") for k in damaged["objectives"]}
    record.write_text(json.dumps(damaged))
    again = run_json(capsys, str(folder), "--output", str(tmp_path / "out"), "--resume")
    assert (again["resumed"], again["evaluated_now"]) == (first["evaluations"] - 1, 1)
    assert again["best"]["parameters"] == first["best"]["parameters"]
    assert again["best"]["objective"] == pytest.approx(first["best"]["objective"], rel=1e-12)
    rows = rows_of(tmp_path / "out")
    assert all(np.isfinite(float(r["tip_amplitude_m"])) for r in rows if r["status"] == "ok")
    assert [r["status"] for r in rows].count("ok") == 2  # 2 and 4 Hz; 6 Hz is infeasible


@pytest.mark.parametrize(
    ("change", "named"),
    [
        (("actuation.frequency_hz", "geometry.kind"), "not a numeric case key"),
        (("actuation.frequency_hz", "actuation.frequency"), "not a case key"),
        (("low = 2.0", "low = -1.0"), "outside the key's valid range"),
        (("high = 6.0", "high = 2000.0"), "outside the key's valid range"),
        (('quantity = "tip_amplitude_m"', 'quantity = "tip_amplitude"'), "'tip_amplitude'"),
        (('sense = "max"', 'sense = "up"'), "[objective] sense"),
        (('kind = "one-at-a-time"', 'kind = "grid"'), "method.kind"),
        (("<= 5", "<= __import__"), "[[constraints]]"),
        (
            ("points = 3", 'points = 3\nevaluation = "linear"', "tip_amplitude_m", "tip_max_abs_m"),
            "method.evaluation",
        ),
        (
            ('quantity = "tip_amplitude_m"', 'quantity = "swimming_speed_m_s"'),
            "[objective] quantity 'swimming_speed_m_s' needs a swimming base case",
        ),
    ],
)
def test_bad_input_is_one_line_naming_it(tmp_path, capsys, change, named):
    text = STUDY
    for old, new in zip(change[::2], change[1::2], strict=True):
        text = text.replace(old, new)
    study = write_study(tmp_path / "bad", text)
    code = design_cli.main([str(study), "--output", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and named in err[0], err


def test_a_study_whose_designs_are_all_infeasible_stops_in_one_line(tmp_path, capsys):
    study = write_study(tmp_path / "none", STUDY.replace("<= 5", ">= 100"))
    code = design_cli.main([str(study), "--output", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "all 3 designs are infeasible" in err[0]
    assert [r["status"] for r in rows_of(tmp_path / "out")] == ["infeasible"] * 3


def test_constraints_are_parsed_not_evaluated():
    c = parse_constraint("geometry.peduncle_height_m + 0.001 <= 0.5 * geometry.max_height_m")
    values = {"geometry.peduncle_height_m": 0.02, "geometry.max_height_m": 0.05}
    assert c.holds(values.__getitem__) == (True, pytest.approx(0.021), pytest.approx(0.025))
    values["geometry.peduncle_height_m"] = 0.03
    assert not c.holds(values.__getitem__)[0]


def test_optimize_keeps_its_budget_and_improves_on_its_space_filling_start(tmp_path, monkeypatch):
    """Differential evolution on a closed-form score (the evaluation replaced by a quadratic
    with its maximum at 4.4 Hz, 0.3 mm): at most `budget` designs, none twice, and a best
    closer to the maximum than the best of the Sobol start."""
    from fishfsi.design import methods, runner
    from fishfsi.design.evaluate import EvaluationSpec, design_key
    from fishfsi.design.study import load_study

    text = STUDY.replace("points = 3", "budget = 60\ninitial = 12").replace(
        '"one-at-a-time"', '"optimize"'
    )
    text += '\n[[parameters]]\nkey = "geometry.thickness_m"\nlow = 0.0001\nhigh = 0.0004\n'
    study = load_study(write_study(tmp_path / "opt", text))

    def quadratic(spec, design):
        f, t = design.values["actuation.frequency_hz"], design.values["geometry.thickness_m"]
        score = -(((f - 4.4) / 4) ** 2) - ((t - 0.3e-3) / 3e-4) ** 2
        return {
            "index": design.index,
            "key": design_key(design.values),
            "stage": design.stage,
            "parameters": design.values,
            "status": "ok",
            "objectives": {"tip_amplitude_m": score},
            "score": score,
        }

    monkeypatch.setattr(runner, "evaluate", quadratic)
    evaluator = runner.Evaluator(EvaluationSpec.of(study, tmp_path / "out"), {})
    methods.run_method(study, evaluator)
    records = evaluator.all_records()
    assert 12 < len(records) <= 60
    assert len({r["key"] for r in records}) == len(records)
    assert [r["index"] for r in records] == list(range(len(records)))
    start = max(r["score"] for r in records if r["stage"] == "initial")
    assert sum(r["stage"] == "initial" for r in records) == 12
    assert methods.best_of(records)["score"] > start


def test_confirm_reruns_the_best_designs_with_openfoam_and_says_if_the_ranking_holds(
    finished, tmp_path, capsys, monkeypatch
):
    """The OpenFOAM runs replaced by a record whose score reverses the fast ranking: the
    reruns get fluid.model = openfoam at the coarse level, coupled as the main job (one fluid
    step per window, pimpleFoam kept loaded), by time march, best first."""
    from fishfsi.design.evaluate import design_key

    folder, out, _ = finished
    shutil.copytree(out, tmp_path / "out")
    asked = []

    def openfoam(spec, design):
        asked.append((spec.overrides[-4:], spec.evaluation.value, design.values))
        score = design.values["actuation.frequency_hz"]  # the lower frequency ranks first
        return {
            "key": design_key(design.values),
            "status": "ok",
            "score": -score,
            "objectives": {"tip_amplitude_m": -score},
        }

    monkeypatch.setattr(design_cli, "evaluate", openfoam)
    summary = run_json(
        capsys, str(folder), "--output", str(tmp_path / "out"), "--resume", "--confirm", "2"
    )
    assert summary["evaluated_now"] == 0
    coupled_as_the_main_job = (
        "fluid.model=openfoam",
        "fluid.mesh_level=coarse",
        "fluid.max_courant=10",  # one fluid step per window
        "fluid.driver=persistent",
    )
    assert [a[:2] for a in asked] == [(coupled_as_the_main_job, "transient")] * 2
    fast_order = [a[2]["actuation.frequency_hz"] for a in asked]
    assert fast_order[0] == summary["best"]["parameters"]["actuation.frequency_hz"]
    assert summary["confirm"]["ranking_holds"] is (fast_order[0] < fast_order[1])
    assert json.loads((tmp_path / "out" / "confirm.json").read_text())["designs"]


def test_a_rerun_into_a_folder_holding_evaluations_is_refused_unless_overwrite(
    finished, capsys, tmp_path
):
    """Without --resume or --overwrite an earlier study's evaluations are kept, as fsi-run and
    fsi-sweep keep an earlier run; --confirm takes no negative count."""
    folder, out, _ = finished
    held = sorted(p.name for p in (out / "evaluations").iterdir())
    for extra, named in (([], "--overwrite"), (["--resume", "--confirm", "-1"], "--confirm")):
        code = design_cli.main([str(folder), "--quiet", *extra])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and named in err[0], err
    assert sorted(p.name for p in (out / "evaluations").iterdir()) == held
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    assert design_cli.main([str(folder), "--output", str(copy), "--overwrite", "--quiet"]) == 0


SWIM = ROOT / "cases/swim_original_18Hz"
SWIM_STUDY = f"""
[base]
case = "{SWIM}"
overrides = ["mesh.level=coarse"]

[[parameters]]
key = "actuation.frequency_hz"
low = 1.0
high = 18.0

[objective]
quantity = "swimming_speed_m_s"
sense = "max"

[method]
kind = "one-at-a-time"
points = 2
"""


def test_a_swimming_study_evaluates_fsi_runs_swimming_figures(tmp_path, capsys):
    """Reference: fsi-run's summary of the swimming case (swimming_summary) at 1 and 18 Hz.
    At 1 Hz the square wave swims more than a body length per period: the record says so."""
    from fishfsi.cli.linear import swimming_summary

    study = write_study(tmp_path / "swim", SWIM_STUDY)
    summary = run_json(capsys, str(study), "--output", str(tmp_path / "out"))
    rows = rows_of(tmp_path / "out")
    assert [r["status"] for r in rows] == ["ok", "ok"]
    for row in rows:
        f = float(row["actuation.frequency_hz"])
        case = load_case(SWIM, ["mesh.level=coarse", f"actuation.frequency_hz={f!r}"])
        expected = swimming_summary(case)["swimming_speed_m_s"]
        assert float(row["swimming_speed_m_s"]) == pytest.approx(expected, rel=1e-9)
    assert summary["best"]["parameters"]["actuation.frequency_hz"] == 18.0  # the faster
    assert rows[0]["reason"].startswith("swimming number above 1") and rows[1]["reason"] == ""
    prescribed = '"mesh.level=coarse", "swimming.speed_m_s=0.5"'
    flume = SWIM_STUDY.replace('"mesh.level=coarse"', prescribed)
    bad = write_study(tmp_path / "flume", flume)
    assert design_cli.main([str(bad), "--output", str(tmp_path / "flume_out")]) == 2
    assert "fixed by the base's swimming.speed_m_s = 0.5" in capsys.readouterr().err
    transient = SWIM_STUDY.replace("points = 2", 'points = 2\nevaluation = "transient"')
    bad = write_study(tmp_path / "bad", transient)
    assert design_cli.main([str(bad), "--output", str(tmp_path / "bad_out")]) == 2
    assert "method.evaluation" in capsys.readouterr().err


def test_a_modal_study_can_ask_for_the_modes_about_the_mean_voltage(tmp_path, capsys):
    """`wet_hz_at_mean_voltage[0]` is fsi-modal's figure for each design (the beam's first wet
    mode about its mean voltage's bent state); with none of the mean strain held it is the
    flat plate's `wet_hz[0]`, to the digit."""
    from fishfsi.cli.modal import modal_summary

    text = STUDY.replace('key = "actuation.frequency_hz"', 'key = "actuation.mean_strain_transfer"')
    text = text.replace("low = 2.0\nhigh = 6.0", "low = 0.0\nhigh = 1.0")
    text = text.replace('expression = "actuation.frequency_hz <= 5"', 'expression = "1 > 0"')
    text = text.replace('quantity = "tip_amplitude_m"', 'quantity = "wet_hz_at_mean_voltage[0]"')
    text = text.replace("points = 3", "points = 2")
    run_json(capsys, str(write_study(tmp_path / "modal", text)), "--output", str(tmp_path / "o"))
    rows = rows_of(tmp_path / "o")
    assert [r["status"] for r in rows] == ["ok", "ok"]
    for row in rows:
        share = float(row["actuation.mean_strain_transfer"])
        case = load_case(BEAM, ["mesh.level=coarse", f"actuation.mean_strain_transfer={share!r}"])
        expected = modal_summary(case)
        assert float(row["wet_hz_at_mean_voltage[0]"]) == pytest.approx(
            expected["wet_hz_at_mean_voltage"][0], rel=1e-9
        )
        driven, flat = expected["wet_hz_at_mean_voltage"][0], expected["wet_hz"][0]
        if share == 0.0:
            assert driven == flat
        else:  # the unimorph bent by its mean: 4e-4 stiffer, which the figure must carry
            assert driven != pytest.approx(flat, rel=1e-5)


def test_the_driven_modes_of_a_design_whose_mean_buckles_it_make_it_infeasible():
    """The integrative robot (coarse shell) with all of its mean strain held buckles at 0.70
    of its mean: a study asking for `wet_hz_at_mean_voltage[0]` gets the one-line CaseError
    (the design is infeasible), one asking for `wet_hz[0]` gets the flat plate's modes
    without the static solve about the mean."""
    from fishfsi.design.evaluate import modal_figures
    from fishfsi.design.study import Objective
    from fsi_orchestrator.case import CaseError

    sets = ["fluid.model=potential", "mesh.level=coarse", "actuation.mean_strain_transfer=1"]
    case = load_case(ROOT / "cases/seed/integrative_prototype", sets)
    with pytest.raises(CaseError, match="buckles the plate at 0.70"):
        modal_figures(case, (Objective(quantity="wet_hz_at_mean_voltage[0]"),))
    flat = modal_figures(case, (Objective(quantity="wet_hz[0]"),))
    assert "wet_hz_at_mean_voltage" not in flat
    assert flat["mean_voltage_buckling_factor"] == pytest.approx(0.70, abs=0.005)
