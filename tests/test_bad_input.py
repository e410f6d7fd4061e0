"""Bad input through the real commands (issue 28): exit 2, exactly one line on stderr naming
the key or the file, never a traceback, and before any solver runs."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import typing
from pathlib import Path

import pytest

from fishfsi.cli import modal as modal_cli
from fishfsi.cli import run as run_cli
from fishfsi.cli import sweep as sweep_cli
from fsi_orchestrator.case.params import spec_of
from fsi_orchestrator.case.schema import SECTIONS

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
HUGE = "1" + "0" * 400  # an integer beyond float range
NESTED = "[" * 3000 + "]" * 3000  # deeper than the TOML reader's recursion
RECTANGLE = (
    '[geometry]\nkind = "rectangle"\nlength_m = 1\nwidth_m = 0.1\nthickness_m = 0.01\n'
    "[material]\nyoungs_modulus_pa = 1e9\ndensity_kg_m3 = 1000\n"
)


def console(command: str, case: Path, *args: str) -> subprocess.CompletedProcess:
    """The installed console script, as a user runs it (about a second each: used sparingly)."""
    return subprocess.run(
        [str(BIN / command), str(case), "--json", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )


def run(capsys, command: str, case: Path, *args: str) -> subprocess.CompletedProcess:
    """The command's main() in this process: what the console script runs, minus the start-up
    (an exception that escapes it fails the test as a traceback would)."""
    main = {"fsi-run": run_cli.main, "fsi-modal": modal_cli.main, "fsi-sweep": sweep_cli.main}[
        command
    ]
    capsys.readouterr()
    code = main([str(case), "--json", *args])
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess([command], code, out, err)


def assert_one_line(proc: subprocess.CompletedProcess, *named: str) -> str:
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    for word in named:
        assert word in lines[0], lines[0]
    return lines[0]


def case_with(tmp_path: Path, content: str | bytes) -> Path:
    path = tmp_path / "case.toml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return tmp_path


# (case.toml text, words the error line names); each must fail in the loader
CASES = {
    "huge int, float key": (f"[actuation]\nfrequency_hz = {HUGE}\n", "actuation.frequency_hz"),
    "huge int, int key": (f"[time]\nsteps_per_period = {HUGE}\n", "time.steps_per_period"),
    "huge int, unbounded int key": (f"[output]\nvtk_every = {HUGE}\n", "output.vtk_every"),
    "huge negative int": (f"[loads]\ntip_force_n = -{HUGE}\n", "loads.tip_force_n"),
    "int of 5000 digits": ("[loads]\npressure_pa = 1" + "0" * 5000 + "\n", "loads.pressure_pa"),
    "infinite float": ("[actuation]\nramp_periods = inf\n", "actuation.ramp_periods"),
    "poisson -1": (RECTANGLE + "poisson_ratio = -1\n", "material.poisson_ratio", "-1 < x"),
    "frequency 1e300": ("[actuation]\nfrequency_hz = 1e300\n", "actuation.frequency_hz", "1000"),
    "frequency 1e-300": ("[actuation]\nfrequency_hz = 1e-300\n", "actuation.frequency_hz"),
    "head weight 1e300": ("[geometry]\nhead_weight_radius_m = 1e300\n", "head_weight_radius_m"),
    "steps per period 1e300": ("[time]\nsteps_per_period = 1e300\n", "time.steps_per_period"),
    "steps per period 10**7": ("[time]\nsteps_per_period = 10000000\n", "time.steps_per_period"),
    "step 1e-300": ("[time]\nstep_s = 1e-300\nend_time_s = 1\n", "time.step_s", "range"),
    "too many steps": ("[time]\nperiods = 10000\nsteps_per_period = 1000\n", "time.periods"),
    "elements 1e300": ("[mesh]\nelements_length = 1e300\n", "mesh.elements_length"),
    "elements 10**9": ("[mesh]\nelements_width = 1000000000\n", "mesh.elements_width", "400"),
    "elements 300 x 300": (
        "[mesh]\nelements_length = 300\nelements_width = 300\n",
        "mesh.elements_length",
    ),
    "load steps": ('[analysis]\nkind = "static"\nload_steps = 100000000\n', "load_steps"),
    "sphere 1000 m": (
        '[fluid]\nmodel = "potential"\ndomain_diameter_m = 1000\n',
        "fluid.domain_diameter_m",
    ),
    "youngs 1e300": ("[material]\nyoungs_modulus_pa = 1e300\n", "material.youngs_modulus_pa"),
    "d33 1e300": ("[actuation]\nd33_m_per_v = 1e300\n", "actuation.d33_m_per_v"),
    "tip force 1e300": ("[loads]\ntip_force_n = 1e300\n", "loads.tip_force_n"),
    "nested array": (f"[actuation]\nleft_volts = {NESTED}\n", "actuation.left_volts"),
    "nested inline table": (
        "[fluid]\nmodel = " + "{a = " * 2000 + "1" + "}" * 2000 + "\n",
        "fluid.model",
    ),
    "shallow nesting": ("[actuation]\nleft_volts = " + "[" * 300 + "]" * 300 + "\n", "left_volts"),
    "long string shown short": ("[actuation]\nwaveform = '" + "x" * 10000 + "'\n", "waveform"),
    "NUL in a string": ('[coupling]\njacobian_from = "a\\u0000b"\n', "coupling.jacobian_from"),
    "free plate under a tip force": (
        RECTANGLE
        + "poisson_ratio = 0.3\n"
        + '[analysis]\nkind = "static"\n[boundary]\nhead = "free"\n'
        "[loads]\ntip_force_n = 1\n",
        "loads.tip_force_n",
        "boundary.head",
    ),
    "free plate under a pressure": (
        RECTANGLE
        + "poisson_ratio = 0.3\n"
        + '[analysis]\nkind = "static"\n[boundary]\nhead = "free"\n'
        "[loads]\npressure_pa = 10\n",
        "loads.pressure_pa",
    ),
    "plate on a hinge under a tip force": (
        RECTANGLE
        + "poisson_ratio = 0.3\n"
        + '[analysis]\nkind = "static"\n[boundary]\nhead = "pinned"\n'
        "[loads]\ntip_force_n = 1\n",
        "loads.tip_force_n",
        "hinge",
    ),
    "hinge without a hinged head": (
        "[boundary]\npin_x_m = 0.05\n",
        "boundary.pin_x_m",
        'boundary.head = "pinned"',
    ),
    "hinge behind the tail": (
        '[boundary]\nhead = "pinned"\npin_x_m = 0.5\n',
        "boundary.pin_x_m",
        "must lie on the plate",
    ),
    "head weight behind the tail": (
        "[geometry]\nhead_weight_x_m = 0.5\n",
        "geometry.head_weight_x_m",
        "does not fit on the plate",
    ),
    "empty": ("", "case.toml is empty"),
    "only comments": ("# nothing here\n\n", "case.toml is empty"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_bad_case_file_one_line(tmp_path, capsys, name):
    text, *named = CASES[name]
    line = assert_one_line(run(capsys, "fsi-run", case_with(tmp_path, text)), *named)
    assert len(line) < 400, line


@pytest.mark.parametrize(
    "content",
    [
        '[case]\ntitle = "caf\xe9"\n'.encode("latin-1"),
        '[case]\ntitle = "x"\n'.encode("utf-16"),
        bytes(range(256)),
    ],
    ids=["latin-1", "utf-16", "binary"],
)
def test_not_utf8_names_the_file(tmp_path, capsys, content):
    line = assert_one_line(run(capsys, "fsi-modal", case_with(tmp_path, content)), "case.toml")
    assert "must be UTF-8 TOML" in line and str(tmp_path) in line


def test_utf8_byte_order_mark_is_read(tmp_path):
    from fsi_orchestrator.case import load_case

    case = case_with(tmp_path, '\ufeff[case]\ntitle = "bom"\n'.encode())
    assert load_case(case).case.title == "bom"


@pytest.mark.parametrize(
    "override, named",
    [
        (f"actuation.frequency_hz={HUGE}", "actuation.frequency_hz"),
        ("actuation.frequency_hz=1" + "0" * 5000, "actuation.frequency_hz"),
        (f"actuation.left_volts={NESTED}", "actuation.left_volts"),
        ("time.step_s=1e-300", "time.step_s"),
    ],
)
def test_bad_override_one_line(tmp_path, capsys, override, named):
    case = case_with(tmp_path, '[case]\ntitle = "t"\n')
    assert_one_line(run(capsys, "fsi-run", case, "--set", override), named)


@pytest.mark.parametrize("command", ["fsi-run", "fsi-sweep"])
def test_an_empty_output_is_refused_not_taken_for_the_default(tmp_path, capsys, command):
    case = case_with(tmp_path, '[case]\ntitle = "t"\n')
    assert_one_line(run(capsys, command, case, "--output", ""), "--output is empty")
    assert not (Path(case) / "output").exists()


def test_empty_case_with_an_override_is_a_case(tmp_path, capsys):
    # the overrides define it; their errors are the ones reported
    proc = run(capsys, "fsi-run", case_with(tmp_path, ""), "--set", "time.periods=-1")
    assert_one_line(proc, "time.periods must be > 0")


@pytest.mark.parametrize(
    "text, named",
    [
        ("[boundary]\nclamp_length_m = 10\n", "boundary.clamp_length_m"),
        (
            '[fluid]\nmodel = "potential"\ndomain = "tank"\ntank_length_m = 0.1\n',
            "fluid.tank_length_m",
        ),
        ('[fluid]\nmodel = "openfoam"\ntank_nose_x_m = 0.5\n', "fluid.tank_nose_x_m"),
        ('[fluid]\nmodel = "openfoam"\ntank_width_m = 0.02\n', "fluid.tank_width_m"),
        ('[fluid]\nmodel = "openfoam"\ntank_depth_m = 0.05\n', "fluid.tank_depth_m"),
        ('[fluid]\nmodel = "potential"\ndomain_diameter_m = 0.1\n', "fluid.domain_diameter_m"),
    ],
)
def test_plate_that_does_not_fit_its_clamp_or_domain(tmp_path, capsys, text, named):
    assert_one_line(run(capsys, "fsi-modal", case_with(tmp_path, text)), named)


@pytest.mark.parametrize(
    "case, settings, key, other",
    [
        ("rectangle_tip_force", [], "analysis.load_steps", "time.steps_per_period"),
        (  # the static start converges in 2 iterations, the 12 Hz steps of 4 per period not
            "fish_vacuum_3Hz",
            ["time.periods=0.5", "time.steps_per_period=4", "mesh.level=coarse"],
            "time.steps_per_period",
            "analysis.load_steps",
        ),
    ],
    ids=["static", "dynamic"],
)
def test_newton_names_the_key_of_the_analysis(tmp_path, capsys, case, settings, key, other):
    settings = ["analysis.max_newton_iterations=3", "output.vtk=false", *settings]
    args = [a for setting in settings for a in ("--set", setting)]
    proc = run(
        capsys, "fsi-run", ROOT / "cases" / case, "--quiet", "--output", str(tmp_path), *args
    )
    line = proc.stderr.strip().splitlines()[-1]
    assert proc.returncode == 1, proc.stderr
    assert "Newton did not converge" in line and key in line and other not in line, line
    # the lowered limit is named as a cure too
    assert "allow more iterations (analysis.max_newton_iterations, default 30)" in line, line


def test_console_scripts_exit_2_with_one_line(tmp_path):
    """The installed commands themselves: bad input from the file and from --set."""
    (tmp_path / "latin").mkdir()
    latin = case_with(tmp_path / "latin", '[case]\ntitle = "caf\xe9"\n'.encode("latin-1"))
    assert "must be UTF-8 TOML" in assert_one_line(console("fsi-modal", latin), str(latin))
    (tmp_path / "huge").mkdir()
    huge = case_with(tmp_path / "huge", '[case]\ntitle = "t"\n')
    override = f"time.steps_per_period={HUGE}"
    assert_one_line(console("fsi-run", huge, "--set", override), "time.steps_per_period")


def _number_fields():
    for section, cls in SECTIONS.items():
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            tp = hints[f.name]  # number lists (the volts) are bounded by a cross-check
            args = (tp,) if typing.get_origin(tp) is tuple else typing.get_args(tp) or (tp,)
            if int in args or float in args:
                yield f"{section}.{f.name}", spec_of(f)


@pytest.mark.parametrize("key, spec", [pytest.param(*f, id=f[0]) for f in _number_fields()])
def test_every_number_key_has_a_sane_range(key, spec):
    """A key without both ends lets 1e300 or 1e-300 through to the solver (issue 28)."""
    assert spec.ge is not None or spec.gt is not None, f"{key}: declare a lower bound"
    assert spec.le is not None or spec.lt is not None, f"{key}: declare an upper bound"
