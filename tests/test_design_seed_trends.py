"""The seed's serial optimisation (Sec. 5.3.1, Figs. 5.5-5.8) in its own set-up: a free body in
a liquid without separated-flow damping (studies/serial_seed_setup). The seed's trends, read
from its text: the tail amplitude at 3 Hz falls with the caudal peduncle height (Fig. 5.5,
"inverse proportion", best at 3 mm), rises with the fin height (Fig. 5.6, best at 60 mm), peaks
at a 0.2 mm CFRP core (Fig. 5.7) and rises a little with the head weight's radius (Fig. 5.8,
best at 7 mm). The base design is the seed's outcome (3 / 60 / 0.2 / 7 mm); each test moves one
parameter off it (linear evaluation, default shell level, about 3 s each)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pytest

from fishfsi.design.evaluate import linear_figures
from fishfsi.design.study import load_study
from fsi_orchestrator.case import load_case

ROOT = Path(__file__).resolve().parents[1]
STUDY = load_study(ROOT / "studies/serial_seed_setup")
SEED_OUTCOME = {  # Sec. 5.3.1's last paragraph and Table 5.2 (the fin: Fig. 5.6's best)
    "geometry.peduncle_height_m": 0.003,
    "geometry.caudal_fin_height_m": 0.060,
    "geometry.thickness_m": 0.0002,
    "geometry.head_weight_radius_m": 0.007,
}


@cache
def amplitude(key: str = "", value: float = 0.0) -> float:
    values = {**SEED_OUTCOME, **({key: value} if key else {})}
    lines = [*STUDY.overrides, *(f"{k}={v!r}" for k, v in values.items())]
    return linear_figures(load_case(STUDY.base_case, lines))["tip_amplitude_m"]


@pytest.mark.slow
@pytest.mark.parametrize(
    "key, other, figure",
    [
        ("geometry.peduncle_height_m", 0.030, "Fig. 5.5: best at the smallest peduncle, 3 mm"),
        ("geometry.caudal_fin_height_m", 0.030, "Fig. 5.6: best at the tallest fin, 60 mm"),
        ("geometry.thickness_m", 0.0001, "Fig. 5.7: the 0.2 mm core beats 0.1 mm"),
        ("geometry.thickness_m", 0.0003, "Fig. 5.7: the 0.2 mm core beats 0.3 mm"),
        ("geometry.head_weight_radius_m", 0.001, "Fig. 5.8: best at the largest weight, 7 mm"),
    ],
)
def test_the_seeds_serial_choices_are_the_best_in_its_set_up(key, other, figure):
    assert amplitude() > amplitude(key, other), figure


@pytest.mark.slow
def test_the_peduncle_trend_is_monotonic_as_fig_5_5_draws_it():
    heights = (0.003, 0.012, 0.021, 0.030)
    tails = [amplitude("geometry.peduncle_height_m", h) for h in heights]
    assert all(a > b for a, b in zip(tails, tails[1:], strict=False)), tails
