"""Shared helpers: build cases from dicts without files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsi_orchestrator.case.loader import case_from_dict

ROOT = Path(__file__).resolve().parents[1]

# the beam in the liquid, coupled partitioned to the potential flow with iqn-ils-am: a coupled
# run of seconds (coupling, resume and periodic-stop tests)
PARTITIONED_BEAM = """
[geometry]
kind = "beam"
[actuation]
frequency_hz = 5.0
[time]
periods = 1
steps_per_period = 20
[mesh]
level = "coarse"
[fluid]
model = "potential"
mesh_level = "coarse"
[coupling]
scheme = "iqn-ils-am"
partitioned = true
[output]
vtk = false
checkpoint_every = 3
"""


def _refuse(constant: str) -> Any:
    raise ValueError(f"not strict JSON: {constant}")


def strict_json(text: str) -> Any:
    """JSON as jq reads it: NaN and Infinity refused."""
    return json.loads(text, parse_constant=_refuse)


@pytest.fixture
def make_case(tmp_path):
    def make(**sections):
        return case_from_dict(sections, tmp_path)

    return make


# Table 3.2's strip (87 x 8 mm) with an MFC over its whole length on both faces: a uniform
# bimorph, whose free-strain curvature is analytic
BIMORPH_STRIP = {
    "kind": "beam",
    "actuator_sides": "both",
    "actuator_length_m": 87e-3,
    "actuator_width_m": 8e-3,
    "actuator_start_x_m": 0.0,
}


def rectangle(length=10.0, width=1.0, thickness=0.1, E=1.2e6, nu=0.0, rho=1.0, **extra):
    sections = {
        "geometry": {
            "kind": "rectangle",
            "length_m": length,
            "width_m": width,
            "thickness_m": thickness,
        },
        "material": {"youngs_modulus_pa": E, "poisson_ratio": nu, "density_kg_m3": rho},
    }
    for key, value in extra.items():
        sections.setdefault(key, {}).update(value)
    return sections
