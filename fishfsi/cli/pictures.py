"""3D pictures of a run's flow, drawn off-screen with pyvista from OpenFOAM's flow surfaces
(``vtk/flow_body.pvd``, ``vtk/flow_vortices.pvd``; ``output.flow_every``): the deformed fish
coloured by its pressure, with the wake's Q-criterion iso-surfaces coloured by the vertical
vorticity, what the seed showed from CFD-Post (Sec. 3.5.3, Figs. 3.30-3.31).

- ``fish3d.png``: the last written time;
- ``period.gif``: the frames of the last period (all frames when the run is shorter), one
  camera and one colour scale for all, so the swing and the shed vortices read as motion.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .common import replaced_atomically

BODY_SERIES = "flow_body.pvd"
VORTEX_SERIES = "flow_vortices.pvd"
WINDOW = [1200, 700]
GIF_FRAME_MS = 120
VIEW = (0.3, 0.9, 1.0)  # from the side, above and a little behind (y is up in the tank)
UP = (0.0, 1.0, 0.0)
ZOOM = 1.3
VIEW_ANGLE_DEG = 30.0  # VTK's default camera


@dataclass(frozen=True)
class Frame:
    time_s: float
    body: Path
    vortices: Path | None  # no Q reached the level at this time


def series(pvd: Path) -> dict[float, Path]:
    """{time: file} of a PVD series (empty when the file is missing)."""
    if not pvd.is_file():
        return {}
    return {
        float(d.get("timestep", "0")): pvd.parent / d.get("file", "")
        for d in ET.parse(pvd).iter("DataSet")
    }


def frames(vtk: Path) -> list[Frame]:
    """The run's flow frames in time order, matched by time across the two series."""
    vortices = series(vtk / VORTEX_SERIES)
    return [
        Frame(t, body, vortices.get(t)) for t, body in sorted(series(vtk / BODY_SERIES).items())
    ]


def last_period(all_frames: list[Frame], period_s: float | None) -> list[Frame]:
    """The frames within one period before the last (inclusive of the last, exclusive of the
    one a period earlier); all of them when the period is unknown or longer than the run."""
    if not all_frames or period_s is None:
        return all_frames
    end = all_frames[-1].time_s
    return [f for f in all_frames if f.time_s > end - period_s * (1 - 1e-9)]


def _symmetric_limit(values: NDArray, percentile: float = 98.0) -> float:
    return float(np.percentile(np.abs(values), percentile)) or 1.0


def draw(vtk: Path, output: Path, period_s: float | None) -> list[Path]:
    """fish3d.png and period.gif from the flow surfaces under ``vtk``; [] where there are
    none (a run without OpenFOAM, or output.flow_every = 0)."""
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkLogger

    # without a display VTK warns "bad X server connection" and renders off-screen anyway
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    found = frames(vtk)
    if not found:
        return []
    shown = last_period(found, period_s)
    meshes = [(f, pv.read(f.body), pv.read(f.vortices) if f.vortices else None) for f in shown]
    _, last_body, last_vortices = meshes[-1]
    p_limit = _symmetric_limit(last_body.point_data["p"])
    w_limit = (
        _symmetric_limit(last_vortices.point_data["vorticity"][:, 1])
        if last_vortices is not None and last_vortices.n_points
        else 1.0
    )
    # one camera for every frame: the fish at the first frame and a body length of wake behind
    lo, hi = np.asarray(meshes[0][1].bounds[::2]), np.asarray(meshes[0][1].bounds[1::2])
    hi[0] += 0.5 * (hi[0] - lo[0])
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    view = np.asarray(VIEW) / np.linalg.norm(VIEW)
    distance = radius / np.sin(np.radians(VIEW_ANGLE_DEG / 2)) / ZOOM  # fits the box, zoomed
    camera = [tuple(centre + distance * view), tuple(centre), UP]

    def render(plotter: pv.Plotter, frame: Frame, body: pv.DataSet, vortices) -> None:
        plotter.clear()
        plotter.add_mesh(
            body,
            scalars=np.asarray(body.point_data["p"]),
            cmap="coolwarm",
            clim=(-p_limit, p_limit),
            scalar_bar_args={"title": "p / rho [m2/s2]", "position_y": 0.02},
        )
        if vortices is not None and vortices.n_points:
            plotter.add_mesh(
                vortices,
                scalars=np.asarray(vortices.point_data["vorticity"])[:, 1],
                cmap="RdBu_r",
                clim=(-w_limit, w_limit),
                opacity=0.55,
                scalar_bar_args={"title": "vertical vorticity [1/s]", "position_y": 0.12},
            )
        plotter.add_text(f"t = {frame.time_s:.4f} s", font_size=12)
        plotter.camera_position = camera

    written = []
    plotter = pv.Plotter(off_screen=True, window_size=WINDOW)
    render(plotter, *meshes[-1])
    still = output / "fish3d.png"
    with replaced_atomically(still, keep_suffix=True) as tmp:
        plotter.screenshot(str(tmp))
    written.append(still)
    images = []
    for frame, body, vortices in meshes:
        render(plotter, frame, body, vortices)
        image = plotter.screenshot(return_img=True)
        if image is not None:
            images.append(np.asarray(image))
    plotter.close()
    gif = output / "period.gif"
    _write_gif(gif, images)
    written.append(gif)
    return written


def _write_gif(target: Path, images: list[NDArray]) -> None:
    from PIL import Image

    first, *rest = (Image.fromarray(np.asarray(image)) for image in images)
    with replaced_atomically(target) as tmp:
        first.save(
            tmp, format="GIF", save_all=True, append_images=rest, duration=GIF_FRAME_MS, loop=0
        )
