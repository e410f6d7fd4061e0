"""Potential-flow (structure-acoustic, c -> inf) fluid: added mass, wet modes, 3 Hz amplitude."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from fishfsi.cli import run as run_cli
from fishfsi.cli.modal import modal_summary
from fluid_adapter.potential.mesh import MeshSizes, SphereDomain, build_fluid_mesh
from fluid_adapter.potential.model import added_mass
from fsi_orchestrator.case import load_case

ROOT = Path(__file__).resolve().parents[1]
# Table 3.7: original robot, free-free, sphere 0.2 m, FC-3283
TABLE_3_7_WET_HZ = {"first bending": 5.99, "second bending": 24.99}
# Sec. 3.4.3 / 4.2.2: tail-tip amplitude at 3 Hz, sine -500..+1500 V, head clamped
SEED_3HZ_SIMULATION_M, SEED_3HZ_EXPERIMENT_M = 0.020, 0.019


def wet_summary(diameter: float) -> dict:
    case = load_case(
        ROOT / "cases/fish_modal_free",
        ["fluid.model=potential", f"fluid.domain_diameter_m={diameter}", "analysis.num_modes=4"],
    )
    return modal_summary(case)


@pytest.fixture(scope="module")
def wet_02():
    return wet_summary(0.2)


def bending(summary: dict, key: str = "wet") -> list[float]:
    return [
        f
        for f, k in zip(summary[f"{key}_hz"], summary[f"{key}_kinds"], strict=True)
        if k == "bending"
    ]


def test_wet_bending_modes_match_table_3_7(wet_02):
    first, second = bending(wet_02)[:2]
    assert first == pytest.approx(TABLE_3_7_WET_HZ["first bending"], rel=0.05)
    assert second == pytest.approx(TABLE_3_7_WET_HZ["second bending"], rel=0.10)
    assert bending(wet_02, "dry")[0] / first > 5  # the liquid is far denser than the plate


@pytest.mark.slow
def test_wet_frequencies_barely_change_from_0p2_to_0p4_m_sphere(wet_02):
    """Table 3.8: the domain size has little effect (the seed: -1.2 % on mode 1)."""
    wet_04 = wet_summary(0.4)
    np.testing.assert_allclose(wet_04["wet_hz"], wet_02["wet_hz"], rtol=0.01)


@pytest.mark.slow
def test_clamped_head_3Hz_tail_amplitude_matches_the_seed(tmp_path, capsys):
    assert (
        run_cli.main(
            [
                str(ROOT / "cases/fixed_head_3Hz"),
                "--json",
                "--quiet",
                "--output",
                str(tmp_path),
                "--set",
                "fluid.model=potential",
                "--set",
                "time.periods=1",
                "--set",
                "time.steps_per_period=20",
                "--set",
                "output.vtk=false",
            ]
        )
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    # the issue's --json contract holds for a fast fluid too (its added mass is in the
    # structure's equations: one monolithic solve per window)
    for key in ("tip_amplitude_m", "mean_thrust_n", "mean_fluid_solves_per_window", "wall_s"):
        assert np.isfinite(summary[key]), key
    assert summary["coupling_scheme"] == "monolithic"
    assert summary["mean_fluid_solves_per_window"] == 1.0
    amplitude = summary["tip_amplitude_m"]
    assert amplitude == pytest.approx(SEED_3HZ_SIMULATION_M, rel=0.15)
    assert amplitude == pytest.approx(SEED_3HZ_EXPERIMENT_M, rel=0.15)


def test_rigid_disk_added_mass_is_8_thirds_rho_a_cubed():
    """Disk of radius a translating normal to itself in unbounded fluid: m = 8/3 rho a^3
    (Lamb, Hydrodynamics, art. 108). Sphere of radius 10 a with p = 0 on it."""
    a, rho = 0.05, 1000.0
    theta = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    polygon = np.column_stack([a * np.cos(theta), a * np.sin(theta)])
    fluid = build_fluid_mesh(
        polygon,
        SphereDomain(centre=(0, 0, 0), radius_m=10 * a),
        MeshSizes(near_plate_m=0.15 * a, far_m=2 * a, growth_distance_m=3 * a, edge_m=0.03 * a),
    )

    def rigid(points):  # one structural DOF: the disk's normal translation
        return sp.csr_matrix(np.ones((points.shape[1], 1)))

    m = added_mass(fluid, rigid, rho)
    assert m.total() == pytest.approx(8 / 3 * rho * a**3, rel=0.03)


def test_the_commands_own_sigterm_handler_holds_while_gmsh_meshes(monkeypatch):
    """gmsh's initialize resets SIGTERM to the C default: a scheduler's time limit during the
    meshing would kill the command without a word. The Python handler is put back at once,
    so a SIGTERM there is handled when gmsh returns."""
    import signal

    import gmsh

    def handler(signum, frame):
        raise KeyboardInterrupt

    def caught() -> bool:  # the kernel's view: Python's getsignal() does not see gmsh's reset
        status = Path("/proc/self/status").read_text().splitlines()
        mask = int(next(line for line in status if line.startswith("SigCgt")).split()[1], 16)
        return bool(mask >> (signal.SIGTERM - 1) & 1)

    seen = []
    generate = gmsh.model.mesh.generate

    def watched(dim):
        seen.append(caught())
        return generate(dim)

    previous = signal.signal(signal.SIGTERM, handler)
    monkeypatch.setattr(gmsh.model.mesh, "generate", watched)
    try:
        a = 0.05
        theta = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        build_fluid_mesh(
            np.column_stack([a * np.cos(theta), a * np.sin(theta)]),
            SphereDomain(centre=(0, 0, 0), radius_m=4 * a),
            MeshSizes(near_plate_m=0.5 * a, far_m=2 * a, growth_distance_m=2 * a, edge_m=0.3 * a),
        )
        assert seen == [True]
        assert caught() and signal.getsignal(signal.SIGTERM) is handler
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_rectangular_plate_carries_less_added_mass_than_the_strip_theory():
    """A rectangular plate, height a and length b = 3 a, translating normal to itself:
    m = C_A rho pi a^2 b / 4 with C_A = 0.830 (DNV-RP-C205, 2010, Table A-2), where strip
    theory (rho pi (a/2)^2 per length) gives C_A = 1: the liquid flows round the ends of a
    plate a few heights long (docs/swimming.md). The outline's element size converges
    slowest: three sizes, extrapolated with their observed ratio (the wet-mode study's)."""
    a, rho = 0.05, 1000.0
    b = 3 * a
    polygon = np.array([[0, -a / 2], [b, -a / 2], [b, a / 2], [0, a / 2]]) - [b / 2, 0]

    def rigid(points):
        return sp.csr_matrix(np.ones((points.shape[1], 1)))

    c = []
    for near, edge in ((0.15, 0.03), (0.1, 0.015), (0.07, 0.0075)):
        sizes = MeshSizes(
            near_plate_m=near * a, far_m=2 * b, growth_distance_m=3 * a, edge_m=edge * a
        )
        fluid = build_fluid_mesh(polygon, SphereDomain(centre=(0, 0, 0), radius_m=10 * b), sizes)
        c.append(added_mass(fluid, rigid, rho).total() / (rho * np.pi * a**2 * b / 4))
    assert c[0] < c[1] < c[2] < 1.0
    ratio = (c[2] - c[1]) / (c[1] - c[0])
    assert 0.3 < ratio < 0.8
    assert c[2] + (c[2] - c[1]) * ratio / (1 - ratio) == pytest.approx(0.830, rel=0.015)
