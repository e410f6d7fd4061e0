"""Partitioned coupling: stability under extreme added mass, and restart of coupled runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from fsi_orchestrator.loop import AFRESH
from tests.conftest import PARTITIONED_BEAM as BEAM

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from stability import cfd_like_fluid, run  # noqa: E402


@pytest.mark.slow
def test_added_mass_schemes_converge_where_plain_schemes_fail():
    """rho_s/rho_f = 0.01 (liquid 100 times denser than the plate; the fish's laminate is about
    2.5, its thin tail far less): explicit and constant relaxation diverge and are stopped with
    one clear error; the added-mass preconditioned scheme converges to 1e-4 in every window,
    with a preconditioner 7 % off the fluid's added mass (coarse vs default potential mesh)."""
    explicit = run(1e-2, 20, "explicit", windows=8)
    assert explicit["diverged"] and "coupling diverged" in explicit["message"]
    constant = run(1e-2, 20, "constant", relaxation=0.5, windows=4)
    assert constant["diverged"] or constant["mean_solves"] >= 30
    extreme = run(1e-2, 20, "iqn-ils-am", windows=12)
    assert not extreme["diverged"] and extreme["unconverged"] == 0
    assert extreme["mean_solves"] <= 3.5
    fish_like = run(1.0, 20, "iqn-ils-am", windows=12)
    assert fish_like["unconverged"] == 0 and fish_like["mean_solves"] <= 3.0
    one = run(1e-2, 20, "explicit-am", windows=10)
    assert not one["diverged"] and one["mean_solves"] == 1.0


@pytest.mark.slow
def test_plain_and_preconditioned_schemes_converge_to_the_same_run():
    """The coupled equations do not depend on the scheme, so tightly converged runs must agree.
    IQN-ILS exchanges the fluid force f, iqn-ils-am g = f + M~ a with M~ in the structure's
    inertia (a coarser potential mesh than the fluid's: M~ != M_a). Both start from the same
    load at t = 0: the undamped orbit is in phase with the sine drive, a(0) = 0, so f(0) = 0
    (with OpenFOAM the lead-in provides f(0): test_openfoam_coupled.py)."""
    plain = run(1.0, 20, "iqn-ils", windows=8, tolerance_rel=1e-8, max_iterations=200)
    am = run(1.0, 20, "iqn-ils-am", windows=8, tolerance_rel=1e-8, max_iterations=200)
    assert plain["unconverged"] == 0 and am["unconverged"] == 0
    tip_plain, tip_am = np.array(plain["tip_z_m"]), np.array(am["tip_z_m"])
    np.testing.assert_allclose(tip_plain, tip_am, atol=1e-6 * np.abs(tip_am).max())
    assert am["mean_solves"] < plain["mean_solves"]


@pytest.mark.slow
def test_explicit_am_needs_the_added_mass_weighted_with_the_fluids_own_acceleration():
    """A fluid that differentiates the displacements it is given (BDF2 of BDF2, as OpenFOAM's
    backward scheme does) sees a different acceleration than the structure's generalized-alpha
    one. With M~ weighted by the structure's a, g = f + M~ a keeps M~ (a_fluid - a), ~50 plate
    masses times the difference, and one solve per window feeds it back: diverges (detected)
    even with the fluid's added mass exactly M~. Weighted with the fluid's stencil
    (Participant.acceleration_stencil) the same run is stable and follows the tightly
    converged coupled run (amplitude within 15 % over two periods of 20 windows)."""
    fluid = cfd_like_fluid(1.0)
    own = run(1e-2, 20, "explicit-am", windows=40, fluid_factory=fluid, structure_stencil=False)
    assert own["diverged"] and "coupling diverged" in own["message"]
    stencil = run(1e-2, 20, "explicit-am", windows=40, fluid_factory=fluid)
    assert not stencil["diverged"] and stencil["mean_solves"] == 1.0
    ref = run(1e-2, 20, "iqn-ils-am", windows=40, fluid_factory=fluid, tolerance_rel=1e-6)
    tip, tip_ref = np.array(stencil["tip_z_m"]), np.array(ref["tip_z_m"])
    for period in (slice(0, 20), slice(20, 40)):
        amplitude, amplitude_ref = np.ptp(tip[period]) / 2, np.ptp(tip_ref[period]) / 2
        assert abs(amplitude / amplitude_ref - 1) < 0.15


@pytest.mark.slow
def test_the_fluid_consistent_added_mass_changes_the_iterations_not_the_result():
    """The stencil only changes what is moved to the structure's side (g = f + M~ a_fluid),
    so tightly converged coupled runs with and without it agree (CFD-like fluid with 1.5 times
    the preconditioner's added mass)."""
    fluid = cfd_like_fluid(1.5)
    kw = dict(windows=12, fluid_factory=fluid, tolerance_rel=1e-8, max_iterations=200)
    with_stencil = run(1e-2, 20, "iqn-ils-am", **kw)
    without = run(1e-2, 20, "iqn-ils-am", structure_stencil=False, **kw)
    assert with_stencil["unconverged"] == 0 and without["unconverged"] == 0
    a, b = np.array(with_stencil["tip_z_m"]), np.array(without["tip_z_m"])
    np.testing.assert_allclose(a, b, atol=1e-6 * np.abs(b).max())


@pytest.mark.slow
def test_an_explicit_start_up_is_explicit_am_and_then_iterates():
    """coupling.explicit_periods = 1: the first period of iqn-ils-am takes one solve per
    window and is explicit-am exactly (same predictor rules, same structure, no accelerator);
    from the second period on every window is iterated to the tolerance, the predictor
    already choosing among the implicit rules."""
    fluid = cfd_like_fluid(1.0)
    started = run(1e-2, 20, "iqn-ils-am", windows=28, fluid_factory=fluid, explicit_periods=1)
    explicit = run(1e-2, 20, "explicit-am", windows=20, fluid_factory=fluid)
    assert started["solves"][:20] == [1.0] * 20
    assert min(started["solves"][20:]) >= 2 and started["unconverged"] == 0
    np.testing.assert_array_equal(started["tip_z_m"][:20], explicit["tip_z_m"])


# the same 20 windows as two periods, the first one explicit: the resume crosses the switch
EXPLICIT_START = BEAM.replace(
    "periods = 1\nsteps_per_period = 20", "periods = 2\nsteps_per_period = 10"
)
EXPLICIT_START = EXPLICIT_START.replace(
    "partitioned = true", "partitioned = true\nexplicit_periods = 1"
)


@pytest.mark.slow
@pytest.mark.parametrize("text", [BEAM, EXPLICIT_START], ids=["iterated", "explicit-start"])
def test_killed_coupled_run_resumes_to_the_same_result(tmp_path, text):
    """kill -9 a partitioned, added-mass preconditioned IQN run mid-way, --resume: the same
    history (accelerator Jacobian and predictor restored) as an uninterrupted run, to 1e-6."""
    assert "explicit_periods" in EXPLICIT_START and "periods = 2" in EXPLICIT_START
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    ref, case = tmp_path / "ref", tmp_path / "killed"
    for folder in (ref, case):
        folder.mkdir()
        (folder / "case.toml").write_text(text)
    subprocess.run([*cmd, str(ref)], check=True, capture_output=True)
    proc = subprocess.Popen([*cmd, str(case)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    results = case / "output" / "results.h5"
    deadline = time.time() + 120
    while time.time() < deadline:
        time.sleep(0.2)
        if (case / "output" / "checkpoint.h5").exists():
            try:
                with h5py.File(results, "r") as h5:
                    if h5["time_s"].shape[0] >= 8:
                        break
            except (OSError, KeyError):
                pass
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = subprocess.run([*cmd, "--resume", str(case)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    with h5py.File(ref / "output" / "results.h5") as a, h5py.File(results) as b:
        keys = ("shell/tip_displacement_m", "coupling/fluid_solves", "coupling/predictor_miss")
        for key in keys:
            np.testing.assert_allclose(
                b[key][:], a[key][:], rtol=0, atol=1e-6 * (1 + np.abs(a[key][:]).max())
            )
        assert b["time_s"].shape == a["time_s"].shape == (20, 1)
        if text is EXPLICIT_START:
            assert a["coupling/fluid_solves"][:10, 0].tolist() == [1.0] * 10


def test_a_learned_jacobian_that_does_not_fit_is_refused_in_one_line(tmp_path):
    """coupling.jacobian_from: a missing file, a run without a quasi-Newton Jacobian
    (explicit-am) and a run on another shell mesh each stop the run before it starts, with one
    line naming the key and the file."""
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    (tmp_path / "case.toml").write_text(BEAM)
    explicit = ["--set", "coupling.scheme=explicit-am", "--set", "time.periods=0.2"]
    other_mesh = ["--set", "mesh.level=default", "--set", "time.periods=0.2"]
    for folder, extra in (("explicit", explicit), ("other_mesh", other_mesh)):
        made = subprocess.run([*cmd, str(tmp_path), "--output", str(tmp_path / folder), *extra])
        assert made.returncode == 0
    for source, expected in (
        ("missing", "does not exist"),
        ("explicit", 'holds no quasi-Newton Jacobian (that run\'s scheme was not "iqn-ils-am")'),
        ("other_mesh", "shell nodes, this case's shell has"),
    ):
        done = subprocess.run(
            [*cmd, str(tmp_path), "--set", f"coupling.jacobian_from={source}"],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 2 and expected in done.stderr, done.stderr
        line = done.stderr.strip()
        assert "\n" not in line and line.startswith("error: coupling.jacobian_from: ")
        assert str(tmp_path / source) in line


def test_a_warm_started_run_reruns_in_its_own_folder_and_resumes_without_the_source(tmp_path):
    """coupling.jacobian_from may name the folder the run writes to (a rerun: the Jacobian is
    read before anything is overwritten), and --resume takes the Jacobian of the run's own
    checkpoint, so a warm-started run goes on after its source is gone."""
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    (tmp_path / "case.toml").write_text(BEAM)

    def fsi_run(output: str, periods: float, *extra: str) -> dict:
        sets = ["--set", f"time.periods={periods}", "--set", "fluid.mesh_level=default"]
        args = [*cmd, str(tmp_path), "--output", str(tmp_path / output), *sets, *extra]
        done = subprocess.run(args, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    assert "jacobian_from" not in fsi_run("output", 0.5)
    fsi_run("output", 0.5, "--set", "coupling.jacobian_from=output", "--overwrite")
    warm = fsi_run("warm", 0.5, "--set", "coupling.jacobian_from=output")
    assert warm["jacobian_from"] == str(tmp_path / "output" / "checkpoint.h5")  # provenance
    (tmp_path / "output").rename(tmp_path / "gone")
    fsi_run("warm", 1, "--set", "coupling.jacobian_from=output", "--resume")
    with h5py.File(tmp_path / "warm" / "results.h5") as h5:
        assert h5["time_s"].shape == (20, 1)


@pytest.mark.slow
def test_a_run_resumed_with_another_scheme_goes_on_from_where_it_stopped(tmp_path):
    """--resume with another coupling.scheme: the saved state goes on under the new scheme.
    From iqn-ils-am (g = f + M~ a exchanged) to plain IQN-ILS (f) the predictor and the
    structure's load restart from the last window's f, so both tightly converged halves
    continue the uninterrupted iqn-ils-am run to 1e-6; an explicit-am start-up continued with
    iqn-ils-am is iterated from there on (the summary counts its explicit windows)."""
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    (tmp_path / "case.toml").write_text(BEAM)
    tight = ["--set", "coupling.tolerance_rel=1e-8", "--set", "coupling.max_iterations=100"]

    def fsi_run(output: str, *extra: str) -> tuple[dict, str, dict]:
        args = [*cmd, str(tmp_path), "--output", str(tmp_path / output), *extra]
        done = subprocess.run(args, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        with h5py.File(tmp_path / output / "results.h5") as h5:
            keys = ("shell/tip_displacement_m", "coupling/fluid_solves", "coupling/iterated")
            rows = {k: h5[k][:, 0] for k in keys}
        return json.loads(done.stdout), done.stderr, rows

    ref, _, ref_rows = fsi_run("ref", *tight)
    half = ["--set", "time.periods=0.5"]
    first, _, _ = fsi_run("plain", *tight, *half)
    assert "resumed_from_scheme" not in first
    plain, note, rows = fsi_run("plain", *tight, "--set", "coupling.scheme=iqn-ils", "--resume")
    assert plain["resumed_from_scheme"] == "iqn-ils-am" and plain["coupling_scheme"] == "iqn-ils"
    assert 'coupling.scheme = "iqn-ils-am" and went on with "iqn-ils"' in note
    assert plain["unconverged_windows"] == ref["unconverged_windows"] == 0
    tip, ref_tip = rows["shell/tip_displacement_m"], ref_rows["shell/tip_displacement_m"]
    assert tip.shape == ref_tip.shape == (20,)
    np.testing.assert_allclose(tip, ref_tip, rtol=0, atol=1e-6 * np.abs(ref_tip).max())
    assert rows["coupling/fluid_solves"][10:].mean() > ref_rows["coupling/fluid_solves"][10:].mean()

    fsi_run("started", "--set", "coupling.scheme=explicit-am", *half)
    started, _, rows = fsi_run("started", "--resume")
    assert started["resumed_from_scheme"] == "explicit-am"
    assert started["explicit_windows"] == 10 and started["unconverged_windows"] == 0
    assert rows["coupling/iterated"].tolist() == [0.0] * 10 + [1.0] * 10


def test_a_resume_that_does_not_fit_the_case_is_refused_in_one_line(tmp_path):
    """--resume after the case changed (another shell mesh, another time step) or with the
    results file gone stops with one line naming the file and what to do, before anything is
    overwritten."""
    cmd = [sys.executable, "-m", "fishfsi.cli.run", "--quiet", "--json"]
    (tmp_path / "case.toml").write_text(BEAM)
    half = ["--set", "time.periods=0.5"]
    assert subprocess.run([*cmd, str(tmp_path), *half], capture_output=True).returncode == 0
    checkpoint, results = (tmp_path / "output" / f for f in ("checkpoint.h5", "results.h5"))
    before = results.read_bytes()
    for extra, expected in (
        (["--set", "mesh.level=default"], f"{checkpoint}: belongs to another case (mesh.level"),
        (
            ["--set", "actuation.frequency_hz=4"],
            f"{checkpoint}: was written with windows of 0.01 s, this case has 0.0125 s",
        ),
        (["--set", "time.periods=0.5"], f"{results}: holds 6 windows, the checkpoint 10"),
        ([], f"{results}: missing, where the checkpoint holds 10 windows"),
    ):
        if extra == half:  # cut short after the checkpoint was written
            with h5py.File(results, "a") as h5:
                h5.visititems(
                    lambda n, d: d.resize(6, axis=0) if isinstance(d, h5py.Dataset) else None
                )
            before = results.read_bytes()
        if not extra:
            results.unlink()
        args = [*cmd, str(tmp_path), "--resume", *extra]
        done = subprocess.run(args, capture_output=True, text=True)
        line = done.stderr.strip()
        assert done.returncode == 1 and line.startswith(f"error: {expected}"), done.stderr
        assert "\n" not in line and line.endswith(AFRESH), line
        if extra:
            assert results.read_bytes() == before
