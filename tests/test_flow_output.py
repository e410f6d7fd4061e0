"""Flow fields a fluid writes itself (OpenFOAM's slices; tests/test_openfoam_coupled.py runs
the real ones): the loop collects them every ``output.flow_every`` windows into PVD series on
the run's clock, keeps them on resume, and a failing sampler costs the pictures, not the run.

Toy participant (the claim is about the loop): a structure whose window is a time step and
whose "flow field" is a small file naming its time.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from fsi_orchestrator.loop import OutputSettings, Schedule, WindowLoop
from fsi_orchestrator.participant import DISPLACEMENT, InterfaceMesh

POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])


class Clock:
    name = "solid"

    def __init__(self, scratch: Path, fail: bool = False) -> None:
        self.time, self.scratch, self.fail, self.sampled = 0.0, scratch, fail, 0

    def interface(self):
        return InterfaceMesh(POINTS.copy(), np.array([[0, 1, 2, 3]]), "quad")

    def read_data(self, data):
        pass

    def solve(self, dt):
        self.time += dt

    def write_data(self):
        return {DISPLACEMENT: np.zeros((4, 3))}

    def flow_fields(self):
        self.sampled += 1
        if self.fail:
            raise RuntimeError("postProcess failed (exit 1); see log.postProcess.flowSlices")
        self.scratch.mkdir(exist_ok=True)
        path = self.scratch / "plane.vtp"
        path.write_text(f"{self.time:.6f}")
        return {"flow_plane": path}

    def monitor(self):
        return {"t": self.time}

    def save_state(self):
        return {"time": self.time}

    def load_state(self, state):
        self.time = float(state["time"])


def run(tmp_path: Path, n_windows: int, fail: bool = False, resume: bool = False) -> Clock:
    solid = Clock(tmp_path / "scratch", fail)
    output = OutputSettings(directory=tmp_path / "out", vtk=False, flow_every=3, checkpoint_every=3)
    WindowLoop(solid, Schedule(dt=0.5, n_windows=n_windows), output).run(resume=resume)
    return solid


def entries(tmp_path: Path) -> list[tuple[float, str]]:
    root = ET.parse(tmp_path / "out" / "vtk" / "flow_plane.pvd").getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


def test_flow_fields_are_collected_every_n_windows_on_the_runs_clock(tmp_path):
    run(tmp_path, 7)
    assert entries(tmp_path) == [(1.5, "flow_plane_000003.vtp"), (3.0, "flow_plane_000006.vtp")]
    text = (tmp_path / "out" / "vtk" / "flow_plane_000006.vtp").read_text()
    assert text == "3.000000"  # moved, not copied: the file of that window
    assert not (tmp_path / "scratch" / "plane.vtp").exists()


def test_a_resumed_run_keeps_the_flow_series_up_to_its_checkpoint(tmp_path):
    run(tmp_path, 4)  # checkpoint at window 3; window 4 wrote no slice
    run(tmp_path, 7, resume=True)
    assert [f for _, f in entries(tmp_path)] == ["flow_plane_000003.vtp", "flow_plane_000006.vtp"]


def test_a_failing_flow_sampler_warns_once_and_the_run_goes_on(tmp_path):
    with pytest.warns(RuntimeWarning, match=r"flow fields of window 3 not written.*postProcess"):
        solid = run(tmp_path, 7, fail=True)
    assert solid.sampled == 1  # not attempted again
    with h5py.File(tmp_path / "out" / "results.h5") as h5:
        assert len(h5["time_s"]) == 7
