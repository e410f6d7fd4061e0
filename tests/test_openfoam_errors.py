"""Errors that say what failed, where, and how to fix it; and the parallel path (real OpenFOAM)."""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from foamlib import FoamFile

from fishfsi.cli.prescribed import mode_motion
from fluid_adapter.openfoam import (
    MeshQualityError,
    OpenFoamNotFoundError,
    OpenFoamRunError,
    build_openfoam_participant,
    runner,
)
from fluid_adapter.openfoam.checkmesh import check_mesh, folded_mesh
from fluid_adapter.openfoam.foamio import read_points, update_dict, write_dict
from fluid_adapter.openfoam.interface import face_centroids
from fluid_adapter.openfoam.loads import face_order
from fsi_orchestrator.case.loader import case_from_dict
from fsi_orchestrator.case.schema import FluidDriver
from fsi_orchestrator.participant import DISPLACEMENT

needs_openfoam = pytest.mark.skipif(
    shutil.which("pimpleFoam") is None, reason="OpenFOAM not installed"
)
DT = 1 / 120


def small_participant(folder: Path, **fluid):
    sections = {"fluid": {"model": "openfoam", "mesh_level": "coarse", **fluid}}
    if fluid.get("driver") == "persistent":  # one solve per window: no prelaunched process
        sections["coupling"] = {"scheme": "explicit-am"}
    case = case_from_dict(sections, folder)
    return case, build_openfoam_participant(
        case, folder / "fluid", dt=DT, n_windows=4, mesh_scale=1.5, reuse=False
    )


def test_missing_openfoam_says_how_to_install(monkeypatch, tmp_path):
    monkeypatch.setattr(runner, "DEFAULT_PROJECT_DIR", tmp_path / "nowhere")
    monkeypatch.setenv("WM_PROJECT_DIR", str(tmp_path / "nowhere"))
    with pytest.raises(OpenFoamNotFoundError, match="apt-get install -y openfoam"):
        runner.project_dir()
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(OpenFoamNotFoundError, match="`pimpleFoam` is not on PATH"):
        runner.executable("pimpleFoam")


@needs_openfoam
@pytest.mark.skipif(not runner.is_root(), reason="only root hands the solver to nobody")
def test_persistent_driver_behind_a_closed_folder_says_so_and_relaunches(tmp_path):
    # pytest's tmp_path lies under a 0700 folder: nobody cannot reach it
    assert runner.unreachable_for_nobody(tmp_path) is not None
    with pytest.warns(UserWarning, match=r"cannot pass .*relaunch driver.*--output"):
        _, p = small_participant(tmp_path, driver="persistent")
    assert not p.driver.persistent
    p.read_data({DISPLACEMENT: np.zeros_like(p.run.interface.points0)})
    p.solve(DT)  # runs
    p.finalize()


def test_divergence_is_recognised_in_a_log():
    # Lines of a real v1912 crash (pimpleFoam, FOAM_SIGFPE) and of an exploding run.
    fpe = "#0  Foam::error::printStack(Foam::Ostream&) at ??:?\n#1  Foam::sigFpe::sigHandler(int)"
    nan = "smoothSolver:  Solving for Ux, Initial residual = nan, Final residual = nan"
    big = "Courant Number mean: 0.01 max: 2.5e+05"
    fine = "Courant Number mean: 0.01 max: 1.7\ntrapFpe: Floating point exception trapping enabled"
    assert runner.diverged(fpe) and runner.diverged(nan) and runner.diverged(big)
    assert not runner.diverged(fine)
    # a linear solve that diverged while its initial residual was small (k-omega SST at the
    # default level, before k and omega were convected upwind): OpenFOAM bounds and goes on
    omega = (
        "smoothSolver:  Solving for omega, Initial residual = 0.00860792179467, "
        "Final residual = 8.08686645762e+21, No Iterations 1000"
    )
    assert runner.divergence(omega) == "the final residual of omega is 8.08686645762e+21"
    assert runner.divergence(nan) == "the initial residual of Ux is nan"


@pytest.mark.openfoam
@needs_openfoam
def test_solver_crash_quotes_the_log_and_keeps_the_case(tmp_path):
    _, p = small_participant(tmp_path)
    update_dict(p.run.path / "system" / "fvSchemes", {"divSchemes": {"default": "none"}})
    p.read_data({DISPLACEMENT: np.zeros_like(p.interface().points)})
    with pytest.raises(OpenFoamRunError, match=r"(?s)pimpleFoam failed.*case folder kept.*FATAL"):
        p.solve(DT)
    assert (p.run.path / "log.pimpleFoam").is_file() and (p.run.path / "0").is_dir()


@pytest.mark.openfoam
@needs_openfoam
def test_a_fin_folded_past_the_mesh_motion_is_named_with_where(tmp_path):
    """The clamped integrative robot's fin swung its trailing edge 15 mm forward and 22 mm
    sideways (docs/benchmarks.md): the cells behind the edge turned inside out, and pimpleFoam
    ran on them for windows. ``folded_mesh`` (checked every 10 windows, and on a divergence)
    names the fold and where it is; a whole moved mesh passes."""
    _, p = small_participant(tmp_path)
    mesh = p.run.path / "constant" / "polyMesh"
    points = read_points(mesh / "points")
    plate = p.run.interface.mesh_points
    edge = plate[points[plate, 0] > points[plate, 0].max() - 1e-9]
    for name, shift in (("1", (0.0, 0.0, 1e-3)), ("2", (-15e-3, 0.0, 22e-3))):
        moved = points.copy()
        moved[edge] += shift
        folder = p.run.path / name / "polyMesh"
        folder.mkdir(parents=True)
        shutil.copy(mesh / "points", folder / "points")
        with FoamFile(folder / "points") as f:
            f[None] = moved
    assert folded_mesh(p.run.path, "1") is None
    found = folded_mesh(p.run.path, "2")
    assert found is not None
    assert re.search(r"t=2 is folded: \d+ faces inside out at x \d+", found), found
    x_mm = 1e3 * (points[edge, 0].max() - 15e-3)
    x_named = float(re.search(r"inside out at x (\d+)", found).group(1))
    assert abs(x_named - x_mm) < 10.0, found  # at the moved edge


@pytest.mark.openfoam
@needs_openfoam
def test_inverted_mesh_fails_check_mesh_with_a_fix(tmp_path):
    _, p = small_participant(tmp_path)
    mesh = p.run.path / "constant" / "polyMesh"
    points = read_points(mesh / "points")
    points[p.run.interface.mesh_points, 2] += 0.2  # plate pushed through the side wall
    broken = p.run.path / "1" / "polyMesh"
    broken.mkdir(parents=True)
    shutil.copy(mesh / "points", broken / "points")
    with FoamFile(broken / "points") as f:
        f[None] = points
    with pytest.raises(MeshQualityError, match=r"(?s)failed check.*Fix:"):
        check_mesh(p.run.path, time="1")


@pytest.mark.parametrize("n", [1, 2, 3, 6, 9])
def test_scalar_field_lists_of_any_length_stay_scalar_lists(tmp_path, n):
    """foamlib 1.7 writes a list of 3, 6 or 9 numbers as a uniform vector/tensor; in a scalar
    field (the plate diffusivity of a processor patch with 3 faces: 4 MPI ranks, default
    level) pimpleFoam then stopped with "expected scalar value, found '('"."""
    values = np.arange(1.0, n + 1)
    write_dict(
        tmp_path / "gamma",
        {
            "FoamFile": {"class": "surfaceScalarField"},
            "dimensions": [0, 0, 0, 0, 0, 0, 0],
            "internalField": values,
            "boundaryField": {"fishPlusZ": {"type": "calculated", "value": values}},
        },
        field=True,
    )
    text = (tmp_path / "gamma").read_text()
    assert text.count(f"nonuniform List<scalar> {n}(") == 2
    assert "uniform (" not in text
    with FoamFile(tmp_path / "gamma") as f:
        np.testing.assert_array_equal(f["internalField"], values)
        np.testing.assert_array_equal(f["boundaryField"]["fishPlusZ"]["value"], values)


def test_a_dictionary_updated_every_window_does_not_grow(tmp_path):
    """foamlib 1.7.10 left blank lines behind on each update: a 4-period coupled run's
    controlDict had 9,139 of them."""
    path = tmp_path / "controlDict"
    write_dict(path, {"startTime": 0.0, "endTime": 1.0, "functions": {"f": {"type": "x"}}})
    size = len(path.read_text())
    for k in range(200):
        update_dict(path, {"startTime": float(k), "endTime": float(k + 1)})
    assert len(path.read_text()) < size + 20
    with FoamFile(path) as f:
        assert f["startTime"] == 199.0 and f["functions"]["f"]["type"] == "x"


@pytest.mark.openfoam
@needs_openfoam
@pytest.mark.parametrize("driver", [FluidDriver.RELAUNCH, FluidDriver.PERSISTENT])
def test_two_ranks_give_the_serial_forces(driver):
    root = Path(tempfile.mkdtemp(prefix="fishfsi-parallel-"))
    root.chmod(0o755)  # as root, the persistent driver runs OpenFOAM as `nobody`
    try:
        forces = {}
        for ranks in (1, 2):
            case, p = small_participant(root / str(ranks), driver=driver.value, processes=ranks)
            motion = mode_motion(case, p.interface().points, 0.02, 3.0, ramp_periods=0.5)
            history = []
            for k in (1, 2):
                p.read_data({DISPLACEMENT: motion.displacement(k * DT)})
                p.solve(DT)
                history.append(p.monitor()["force_n"])
            p.finalize()
            forces[ranks] = np.array(history)
        scale = np.abs(forces[1]).max()
        assert np.abs(forces[2] - forces[1]).max() / scale < 1e-4
        assert (root / "2" / "fluid" / "processor1").is_dir()
    finally:
        shutil.rmtree(root, ignore_errors=True)


@pytest.mark.openfoam
@needs_openfoam
def test_two_ranks_restore_a_window_as_serial():
    """Implicit coupling on MPI ranks: a window solved with a wrong iterate, restored (every
    processor folder goes back) and solved again gives the serial run's force."""
    root = Path(tempfile.mkdtemp(prefix="fishfsi-parallel-restore-"))
    try:
        forces = {}
        for ranks in (1, 2):
            case, p = small_participant(root / str(ranks), processes=ranks)
            motion = mode_motion(case, p.interface().points, 0.02, 3.0, ramp_periods=0.5)
            for k in (1, 2):
                p.read_data({DISPLACEMENT: motion.displacement(k * DT)})
                p.solve(DT)
            p.store_checkpoint()
            p.read_data({DISPLACEMENT: 1.5 * motion.displacement(3 * DT)})  # a wrong iterate
            p.solve(DT)
            wrong = p.monitor()["force_n"]
            p.restore_checkpoint()
            p.read_data({DISPLACEMENT: motion.displacement(3 * DT)})
            p.solve(DT)
            forces[ranks] = p.monitor()["force_n"]
            p.finalize()
            assert np.abs(wrong - forces[ranks]).max() > 1e-2 * np.abs(forces[ranks]).max()
        scale = np.abs(forces[1]).max()
        assert np.abs(forces[2] - forces[1]).max() / scale < 1e-4
    finally:
        shutil.rmtree(root, ignore_errors=True)


def test_a_fluid_plate_that_left_the_structure_is_one_line_naming_the_step(tmp_path):
    """The sampled faces' centres can no longer be matched one to one with the interface's (a
    failed mesh motion): an OpenFoamRunError (one line from the commands), not a ValueError
    traceback."""
    expected = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [2e-3, 0.0, 0.0]])
    sampled = np.array([[0.0, 0.0, 5e-3], [0.1e-3, 0.0, 5e-3], [0.2e-3, 0.0, 5e-3]])
    with pytest.raises(OpenFoamRunError, match=r"fishPlusZ: the fluid mesh's plate no longer"):
        face_order(sampled, expected, tmp_path / "fishPlusZ")
    with pytest.raises(OpenFoamRunError, match="2 faces sampled, expected 3"):
        face_order(sampled[:2], expected, tmp_path / "fishPlusZ")
    # a processor merge's reordering is still matched
    np.testing.assert_array_equal(face_order(expected[::-1], expected, tmp_path), [2, 1, 0])


def test_face_centres_are_openfoams_area_centroids_on_tapered_faces(tmp_path):
    """A face tapering from 3 mm to 0.1 mm over 8 mm (the integrative robot's graded peduncle):
    the area centroid, x = L (H + 2 h) / (3 (H + h)), is 1.25 mm from the points' mean, more
    than the 0.1-face tolerance of the serial order check. The interface's centres are the
    centroids, so the sampled faces of a plate that follows the structure match one to one."""
    L, H, h = 8e-3, 3e-3, 0.1e-3
    points = np.array([[0, -H / 2, 0], [L, -h / 2, 0], [L, h / 2, 0], [0, H / 2, 0]], dtype=float)
    # a strip of such faces, shifted along x, bent out of plane (a fin at 30 degrees)
    shift = np.array([L, 0.0, 0.0])
    strip = np.concatenate([points + k * shift for k in range(6)])
    strip[:, 2] = 0.5 * strip[:, 0]
    faces = np.arange(len(strip)).reshape(-1, 4)
    centres = face_centroids(strip, faces)
    x_exact = L * (H + 2 * h) / (3 * (H + h)) + np.arange(6) * L
    np.testing.assert_allclose(centres[:, 0], x_exact, rtol=0, atol=1e-15)
    np.testing.assert_allclose(centres[:, 1], 0.0, atol=1e-18)
    np.testing.assert_allclose(centres[:, 2], 0.5 * x_exact, rtol=0, atol=1e-15)
    assert np.abs(strip[faces].mean(axis=1)[:, 0] - x_exact).max() > 1.2e-3
    np.testing.assert_array_equal(face_order(centres, centres, tmp_path), np.arange(6))


def test_a_lead_in_that_diverges_says_so_and_names_the_start_from_rest():
    """The lead-in moves the liquid along the fast model's orbit before window 1; undamped near
    a wet resonance that orbit can be far larger than the coupled motion (the hinged thrust
    rig at 3 Hz: 27 mm, where the run from rest swings 13 mm), and pimpleFoam blew up in it
    with the advice to shorten the time step. The error says where it diverged and that a
    start from rest avoids it, with the solver's log lines still after the first line."""
    from types import SimpleNamespace

    from fluid_adapter.openfoam.errors import DivergenceError
    from fluid_adapter.openfoam.participant import OpenFoamParticipant

    class Diverging:
        time = 0.0

        def advance_prescribed(self, displacements, dt):
            raise DivergenceError("pimpleFoam diverged in CASE: NaN; reduce the time step\nLOG")

    run = SimpleNamespace(interface=SimpleNamespace(points0=np.zeros((4, 3))))
    fluid = OpenFoamParticipant(run, Diverging(), dt=DT, n_windows=40)
    with pytest.raises(DivergenceError) as caught:
        fluid.follow([np.zeros((4, 3))], DT)
    first, _, rest = str(caught.value).partition("\n")
    assert "in the lead-in" in first and "time.start=rest" in first
    assert rest == "LOG"
