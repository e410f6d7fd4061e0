"""Strict case validation: one error line naming the key, exit code 2, no traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fishfsi.cli import modal as modal_cli
from fishfsi.cli import run as run_cli
from fsi_orchestrator.case import CaseError, load_case, parse_override
from fsi_orchestrator.case.schema import AnalysisKind, Waveform

ROOT = Path(__file__).resolve().parents[1]


def write_case(tmp_path: Path, text: str) -> Path:
    (tmp_path / "case.toml").write_text(text)
    return tmp_path


def error_of(tmp_path, text, overrides=()):
    with pytest.raises(CaseError) as err:
        load_case(write_case(tmp_path, text), overrides)
    return str(err.value)


FREQUENCY_LIMIT = "actuation.frequency_hz must be >= 0.01, got {} (range: 0.01 <= x <= 1000 Hz)"


def test_negative_frequency_names_the_key(tmp_path):
    msg = error_of(tmp_path, "[actuation]\nfrequency_hz = -3\n")
    assert msg == "case.toml: " + FREQUENCY_LIMIT.format(-3)


def test_a_frequency_below_the_limit_names_the_limit_itself(tmp_path):
    """The key is declared > 0 and >= 0.01 Hz: 0 Hz said "must be > 0", which 0.005 Hz
    passes and is refused all the same."""
    for value in ("0", "0.005"):
        msg = error_of(tmp_path, "", [f"actuation.frequency_hz={value}"])
        assert msg == f"--set 'actuation.frequency_hz={value}': " + FREQUENCY_LIMIT.format(value)


def test_override_is_validated_like_the_file_and_named_as_the_set(tmp_path):
    msg = error_of(tmp_path, "", ["actuation.frequency_hz=-3"])
    assert msg == "--set 'actuation.frequency_hz=-3': " + FREQUENCY_LIMIT.format(-3)
    msg = error_of(tmp_path, "[actuation]\nfrequency_hz = 3\n", ["fluid.modle=potential"])
    assert msg.startswith("--set 'fluid.modle=potential': fluid.modle is not a known key")
    # the file's own key is still the file's, whatever else --set gives
    msg = error_of(tmp_path, "[actuation]\nfrequency_hz = -3\n", ["fluid.model=potential"])
    assert msg == "case.toml: " + FREQUENCY_LIMIT.format(-3)
    # a list's item is the --set's that gave the list
    msg = error_of(tmp_path, "", ["actuation.left_volts=[nan, 1500]"])
    assert msg.startswith("--set 'actuation.left_volts=[nan, 1500]': actuation.left_volts[0]")
    # a check across keys names the --set it mentions
    msg = error_of(tmp_path, "", ["time.end_time_s=0.01"])
    assert msg.startswith("--set 'time.end_time_s=0.01': time.step_s and time.end_time_s go")


def test_a_key_named_only_in_the_advice_is_not_blamed():
    from fsi_orchestrator.case.loader import blame_override

    message = (
        'case.toml: fluid.inflow_m_s = 0.3: a flume\'s inflow needs fluid.model = "openfoam" '
        "(the fast models take the speed from swimming.speed_m_s)"
    )
    assert blame_override(message, ["swimming.speed_m_s=0.3"]) == message
    message = "case.toml: time.step_s must be > 0; see time.end_time_s"
    assert blame_override(message, ["time.end_time_s=1"]) == message


def test_a_check_of_the_resolved_plate_names_the_set_it_follows_from(tmp_path):
    """A head weight from --set that does not fit the plate, and a clamp longer than the
    plate: the line names the --set, not the file alone."""

    def modal(*settings: str) -> subprocess.CompletedProcess:
        sets = [a for s in settings for a in ("--set", s)]
        cmd = [sys.executable, "-m", modal_cli.__name__, str(ROOT / "cases" / "fixed_head_3Hz")]
        return subprocess.run([*cmd, *sets], capture_output=True, text=True)

    done = modal("fluid.model=potential", "geometry.head_weight_radius_m=0.09")
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "error: --set 'geometry.head_weight_radius_m=0.09': geometry.head_weight_x_m and "
        "geometry.head_weight_radius_m put a head weight of radius 0.09 m at x = 0.093 m, where "
        "it does not fit on the plate (0.167 m long, as little as 0.03178 m high under it)"
    )
    done = modal("fluid.model=potential", "boundary.clamp_length_m=0.2")
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "error: --set 'boundary.clamp_length_m=0.2': boundary.clamp_length_m (0.2 m) must "
        "be shorter than the plate (0.167 m), or nothing is free to move"
    )
    done = modal("geometry.max_height_m=0.01")
    assert done.returncode == 2
    assert done.stderr.startswith("error: --set 'geometry.max_height_m=0.01': geometry.peduncle")


@pytest.mark.parametrize(
    "text, expected",
    [
        ("[actuation]\nfrequency = 3\n", "actuation.frequency is not a known key"),
        ("[actuator]\nfrequency_hz = 3\n", "[actuator] is not a known section"),
        (
            '[actuation]\nwaveform = "triangle"\n',
            'actuation.waveform must be one of "sine" | "square", got \'triangle\'',
        ),
        ("[time]\nsteps_per_period = 2.5\n", "time.steps_per_period must be an integer, got 2.5"),
        ("[actuation]\nleft_volts = [-600, 1500]\n", "actuation.left_volts must lie within"),
        ("[actuation]\nleft_volts = [1500, -500]\n", "actuation.left_volts must be [min, max]"),
        (
            '[geometry]\nkind = "rectangle"\nlength_m = 1\nwidth_m = 0.1\n',
            "geometry.thickness_m is required",
        ),
        (
            '[geometry]\nkind = "rectangle"\nlength_m = 1\nwidth_m = 0.1\nthickness_m = 0.01\n'
            "peduncle_height_m = 0.003\n",
            "geometry.peduncle_height_m does not apply",
        ),
        ("[coupling]\nrelaxation = 1.7\n", "coupling.relaxation must be <= 1, got 1.7"),
        (
            '[coupling]\nscheme = "aitken"\nexplicit_periods = 1\n',
            'coupling.explicit_periods applies to coupling.scheme = "iqn-ils-am" only',
        ),
        (
            "[time]\nperiods = 2\n[coupling]\nexplicit_periods = 2\n",
            "coupling.explicit_periods (2) must be less than time.periods (2)",
        ),
        (
            '[coupling]\nscheme = "iqn-ils"\njacobian_from = "../run"\n',
            'coupling.jacobian_from applies to coupling.scheme = "iqn-ils-am" only',
        ),
        ('[fluid]\nmodel = "lbm"\n', "fluid.model must be one of"),
        (
            '[geometry]\nkind = "beam"\n[boundary]\nhead = "elastic"\n',
            'boundary.head = "elastic" is the fish\'s head on springs; for geometry.kind = "beam"',
        ),
    ],
)
def test_bad_input_gives_one_line_naming_the_key(tmp_path, text, expected):
    msg = error_of(tmp_path, text)
    assert expected in msg and msg.startswith("case.toml: ") and "\n" not in msg


@pytest.mark.parametrize(
    "text, expected",
    [
        ("[analysis\nkind = 1\n", "not valid TOML: "),
        ("[actuation]\nleft_volts = " + "[" * 3000 + "]" * 3000 + "\n", "actuation.left_volts is"),
        ("[loads]\npressure_pa = 1" + "0" * 5000 + "\n", "loads.pressure_pa: "),
    ],
    ids=["syntax", "nested", "long integer"],
)
def test_a_file_the_toml_reader_refuses_is_named_with_its_folder(
    tmp_path, monkeypatch, text, expected
):
    """As given (cases/foo/case.toml): a bare case.toml did not say which case's."""
    (tmp_path / "foo").mkdir()
    write_case(tmp_path / "foo", text)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(CaseError) as err:
        load_case("foo")
    msg = str(err.value)
    assert msg.startswith(f"foo/case.toml: {expected}") and "\n" not in msg, msg


def test_missing_case_file(tmp_path):
    with pytest.raises(CaseError, match="no case.toml found"):
        load_case(tmp_path / "nowhere")


def test_geometry_that_does_not_fit_names_the_key(tmp_path):
    case = load_case(write_case(tmp_path, "[geometry]\nactuator_width_m = 0.06\n"))
    from solid_adapter.geometry import build_layout

    with pytest.raises(CaseError, match="geometry.actuator_width_m .* does not fit"):
        build_layout(case)


def test_parse_override_types():
    assert parse_override("actuation.frequency_hz=5") == ("actuation", "frequency_hz", 5)
    assert parse_override("fluid.model=potential") == ("fluid", "model", "potential")
    assert parse_override("actuation.left_volts=[-500, 500]") == (
        "actuation",
        "left_volts",
        [-500, 500],
    )
    with pytest.raises(CaseError):
        parse_override("frequency_hz=5")


def test_defaults_and_enums(tmp_path):
    case = load_case(write_case(tmp_path, ""))
    assert case.analysis.kind is AnalysisKind.DYNAMIC
    assert case.actuation.waveform is Waveform.SINE
    assert case.actuation.left_volts == (-500.0, 1500.0)
    with pytest.raises(AttributeError):
        case.actuation.frequency_hz = 5  # frozen


def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys):
    write_case(tmp_path, "[actuation]\nfrequency_hz = -3\n")
    assert run_cli.main([str(tmp_path), "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "error: case.toml: " + FREQUENCY_LIMIT.format(-3)


def test_resume_and_overwrite_together_are_refused(tmp_path, capsys):
    write_case(tmp_path, "[actuation]\nfrequency_hz = 3\n")
    with pytest.raises(SystemExit) as exit_:
        run_cli.main([str(tmp_path), "--resume", "--overwrite"])
    assert exit_.value.code == 2
    # one line, as all bad input (argparse's usage block is a --help away)
    assert capsys.readouterr().err == (
        "error: fsi-run: argument --overwrite: not allowed with argument --resume "
        "(see fsi-run --help)\n"
    )


def test_console_script_prints_no_traceback(tmp_path):
    write_case(tmp_path, "[time]\nperiods = 0\n")
    proc = subprocess.run(
        [sys.executable, "-m", "fishfsi.cli.run", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == "error: case.toml: time.periods must be > 0, got 0"
    assert "Traceback" not in proc.stderr


def test_fsi_run_static_json_contract(capsys):
    assert run_cli.main([str(ROOT / "cases/rectangle_tip_force"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert len(summary["tip_displacement_m"]) == 3
    assert summary["tip_displacement_m"][2] == pytest.approx(6.70, rel=1e-2)  # w/L = 0.670


def test_fsi_modal_json_contract(capsys):
    assert (
        modal_cli.main(
            [str(ROOT / "cases/fish_modal_free"), "--json", "--set", "analysis.num_modes=3"]
        )
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert len(summary["dry_hz"]) == 3 and summary["dry_hz"] == sorted(summary["dry_hz"])


def test_case_format_doc_is_generated_from_the_schema():
    from fsi_orchestrator.case.docgen import render

    assert (ROOT / "docs/case_format.md").read_text() == render(), (
        "run: python -m fsi_orchestrator.case.docgen"
    )


def test_persistent_driver_takes_an_implicit_scheme(tmp_path):
    # it repeats a window by going on with a process started from the checkpoint (drivers.py)
    (tmp_path / "case.toml").write_text(
        '[fluid]\nmodel = "openfoam"\ndriver = "persistent"\n[coupling]\nscheme = "iqn-ils"\n'
    )
    assert load_case(tmp_path).fluid.driver.value == "persistent"


def test_the_pimple_correctors_come_from_the_case(tmp_path):
    """fluid.outer_correctors and fluid.non_orthogonal_correctors reach fvSolution's PIMPLE
    dictionary; the fish's tank solves pFinal to 1e-5 (every outer iteration ends on it)."""
    from fluid_adapter.openfoam.casefiles import fv_solution
    from fluid_adapter.openfoam.tankcase import flow_settings
    from fsi_orchestrator.case.loader import case_from_dict

    default = fv_solution(flow_settings(case_from_dict({"fluid": {"model": "openfoam"}}, tmp_path)))
    pimple = default["PIMPLE"]
    assert (pimple["nOuterCorrectors"], pimple["nNonOrthogonalCorrectors"]) == (2, 1)
    assert default["solvers"]["pFinal"]["tolerance"] == 1e-5
    assert default["solvers"]["pFinal"]["relTol"] == 0
    fluid = {"model": "openfoam", "outer_correctors": 3, "non_orthogonal_correctors": 0}
    pimple = fv_solution(flow_settings(case_from_dict({"fluid": fluid}, tmp_path)))["PIMPLE"]
    assert (pimple["nOuterCorrectors"], pimple["nNonOrthogonalCorrectors"]) == (3, 0)


def test_pimple_settings_do_not_regenerate_the_fluid_folder(tmp_path):
    """The PIMPLE keys are left out of the generated folder's fingerprint (a reused folder gets
    its fvSolution rewritten instead of a new mesh), and so is the fast thrust's KC0, which
    the folder does not use: a folder stamped before the keys existed (a run resumed across
    versions) keeps its key; a physical key still changes it."""
    import dataclasses
    import hashlib
    import json

    from fluid_adapter.openfoam.build import SOLUTION_KEYS, UNUSED_KEYS, fingerprint
    from fsi_orchestrator.case.loader import case_from_dict

    case = case_from_dict({"fluid": {"model": "openfoam"}}, tmp_path)
    fluid = {"model": "openfoam", "outer_correctors": 4, "non_orthogonal_correctors": 2}
    fluid |= {"thrust_shedding_kc": 0.0}
    assert fingerprint(case_from_dict({"fluid": fluid}, tmp_path), 1.0, 1) == fingerprint(
        case, 1.0, 1
    )
    later = SOLUTION_KEYS + UNUSED_KEYS
    old_fluid = {k: v for k, v in dataclasses.asdict(case.fluid).items() if k not in later}
    old = {"geometry": dataclasses.asdict(case.geometry), "fluid": old_fluid}
    old |= {"mesh_scale": 1.0, "processes": 1}
    stamped = hashlib.sha256(json.dumps(old, sort_keys=True, default=str).encode()).hexdigest()
    assert fingerprint(case, 1.0, 1) == stamped
    denser = case_from_dict({"fluid": {"model": "openfoam", "density_kg_m3": 1000.0}}, tmp_path)
    assert fingerprint(denser, 1.0, 1) != stamped


def test_a_static_run_needs_no_room_for_a_liquid_it_never_meets(tmp_path, capsys):
    """A static solve of the 10 m plate with the potential model set runs; its wet modes need
    a sphere of 11 m, beyond the key's 2 m, and the line says to use the tank."""
    case = str(ROOT / "cases" / "rectangle_tip_force")
    sets = ["--set", "fluid.model=potential"]
    assert run_cli.main([case, *sets, "--json", "--quiet", "--output", str(tmp_path)]) == 0
    capsys.readouterr()
    assert modal_cli.main([case, *sets, "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert "fluid.domain_diameter_m (0.2 m)" in err and 'fluid.domain = "tank"' in err
