"""3D pictures of a run's flow (fsi-post, fishfsi.cli.pictures) and the OpenFOAM
sampling dictionary behind them (fluid_adapter.openfoam.slices), on synthetic surfaces: the
frames of the last period, one frame per picture, the Q-criterion level from the drive."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from foamlib import FoamFile

from fishfsi.cli import pictures
from fluid_adapter.openfoam.slices import IsoSurface, Patch, fish_surfaces, write_slice_dict


def write_series(vtk: Path, name: str, meshes: dict[float, object]) -> None:
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1"><Collection>']
    for k, (t, mesh) in enumerate(meshes.items()):
        file = f"{name}_{k:06d}.vtp"
        mesh.save(vtk / file)
        lines.append(f'<DataSet timestep="{t!r}" file="{file}"/>')
    (vtk / f"{name}.pvd").write_text("\n".join([*lines, "</Collection></VTKFile>"]))


@pytest.fixture
def run_output(tmp_path):
    """Flow surfaces at 5 times, 0.1 s apart; vortices at all but the first."""
    import pyvista as pv

    vtk = tmp_path / "vtk"
    vtk.mkdir()
    times = [0.1 * k for k in range(1, 6)]
    bodies, vortices = {}, {}
    for k, t in enumerate(times):
        body = pv.Plane(
            center=(0.08, 0.0, 0.01 * math.sin(k)), direction=(0, 0, 1), i_size=0.16, j_size=0.05
        )
        body.point_data["p"] = np.asarray(body.points)[:, 0] - 0.08
        bodies[t] = body
        if k:
            blob = pv.Sphere(radius=0.01, center=(0.18, 0.0, 0.0))
            blob.point_data["vorticity"] = np.tile([0.0, 50.0 * k, 0.0], (blob.n_points, 1))
            vortices[t] = blob
    write_series(vtk, "flow_body", bodies)
    write_series(vtk, "flow_vortices", vortices)
    return tmp_path, times


def test_frames_pair_the_series_by_time_and_keep_the_last_period(run_output):
    out, times = run_output
    frames = pictures.frames(out / "vtk")
    assert [f.time_s for f in frames] == pytest.approx(times)
    assert frames[0].vortices is None and all(f.vortices for f in frames[1:])
    # a 0.25 s period: the frames after t = 0.5 - 0.25
    assert [f.time_s for f in pictures.last_period(frames, 0.25)] == pytest.approx([0.3, 0.4, 0.5])
    assert pictures.last_period(frames, None) == frames  # period unknown: all of them
    assert pictures.last_period(frames, 10.0) == frames  # run shorter than a period


def test_the_pictures_show_the_fish_and_animate_the_last_period(run_output):
    from PIL import Image

    out, _ = run_output
    written = pictures.draw(out / "vtk", out, period_s=0.25)
    assert written == [out / "fish3d.png", out / "period.gif"]
    still = np.asarray(Image.open(out / "fish3d.png").convert("RGB"))
    assert still.shape == (pictures.WINDOW[1], pictures.WINDOW[0], 3)
    # the pressure's diverging map: both its blue and its red ends are on the plate
    r, g, b = (still[..., i].astype(int) for i in range(3))
    assert np.count_nonzero(b - r > 80) > 500 and np.count_nonzero(r - b > 80) > 500
    gif = Image.open(out / "period.gif")
    assert gif.n_frames == 3


def test_no_flow_surfaces_no_pictures(tmp_path):
    assert pictures.draw(tmp_path, tmp_path, period_s=0.25) == []


def test_the_sampling_dictionary_holds_q_its_iso_surface_and_the_fish(tmp_path):
    points0 = np.array([[0.0, 0.0, 0.0], [0.167, 0.0, 0.0], [0.1, 0.05, 0.0]])
    surfaces = fish_surfaces(points0, ("fishPlusZ", "fishMinusZ"), 1066.0)
    (tmp_path / "system").mkdir()
    write_slice_dict(tmp_path, surfaces)
    functions = FoamFile(tmp_path / "system" / "flowSlices")["functions"]
    assert functions["Q"]["type"] == "Q"
    sampled = functions["flowSlices"]["surfaces"]
    vortices = sampled["vortices"]
    assert (vortices["type"], vortices["isoField"], vortices["isoValue"]) == (
        "isoSurface",
        "Q",
        1066.0,
    )
    assert sampled["body"]["type"] == "patch"
    assert list(sampled["body"]["patches"]) == ["fishPlusZ", "fishMinusZ"]
    assert [s.name for s in surfaces] == ["midheight", "wake", "body", "vortices"]
    assert isinstance(surfaces[2], Patch) and isinstance(surfaces[3], IsoSurface)
    # level 0: no iso-surface
    assert [s.name for s in fish_surfaces(points0, ("fishPlusZ",), 0.0)][-1] == "body"


def test_the_q_level_is_in_units_of_the_drives_omega_squared():
    from fluid_adapter.openfoam.build import flow_surfaces
    from fsi_orchestrator.case import load_case

    class Interface:
        points0 = np.array([[0.0, 0.0, 0.0], [0.167, 0.05, 0.0]])

    case = load_case(Path(__file__).resolve().parents[1] / "cases" / "fixed_head_3Hz")
    (*_, vortices) = flow_surfaces(case, Interface())  # type: ignore[arg-type]
    assert vortices.value == pytest.approx(0.1 * (2 * math.pi * 3.0) ** 2)  # 35.5 1/s^2


def test_the_les_wake_case_is_the_seeds_scene_with_twenty_frames_a_period():
    """Sec. 3.5.3: the original fish, head clamped, 10 Hz, Smagorinsky LES in the tank."""
    from fsi_orchestrator.case import load_case
    from fsi_orchestrator.case.schema import HeadCondition, Turbulence

    case = load_case(Path(__file__).resolve().parents[1] / "cases" / "les_wake_10Hz")
    assert case.geometry.preset == "original" and case.boundary.head is HeadCondition.CLAMPED
    assert case.actuation.frequency_hz == 10.0
    assert case.fluid.turbulence is Turbulence.SMAGORINSKY
    assert case.time.steps_per_period / case.output.flow_every == 20


@pytest.mark.parametrize(
    "line, period",
    [
        ("frequency_hz = 7.0", 1 / 7),
        ("# frequency_hz = 3.0  (default)", 1 / 3),  # a key at its default is a comment
        ("frequency_hz = np.float64(5.0)", 1 / 5),  # what sweeps wrote before the fix
    ],
)
def test_the_pictures_period_is_the_drives_from_the_recorded_case(tmp_path, line, period):
    """The animation spans the last drive period, read from results.h5's resolved case."""
    import h5py

    from fishfsi.cli.post import drive_period_s

    with h5py.File(tmp_path / "results.h5", "w") as h5:
        h5.attrs["case_toml"] = f'[actuation]\n{line}\n# waveform = "sine"  (default)\n'
    assert drive_period_s(tmp_path / "results.h5") == pytest.approx(period)
