"""The plate's planform, which both adapters need: the parametric fish outline (three presets),
the seed's beam model and a plain rectangle, resolved from a case into a :class:`Planform`
(length, height h(x), the x positions where h(x) has kinks).

Coordinates: x along the body (nose at x = 0, tail at L), y across the plate (vertical in the
tank), z normal to the plate (the swing direction). The outline is symmetric about y = 0.

The fish outline is built from the seed's parameters (Tables 3.4, 4.1, 5.2, 5.6): body length,
max height, peduncle height, caudal fin height. The text gives no drawing, so the shape between
them is an assumption documented in docs/geometry.md: an elliptic blunt head up to
``head_length_m``, a constant-height trunk, a cosine taper to the peduncle at ``peduncle_x_m``
and a straight-edged caudal fin flaring linearly to the trailing edge. The laminate on the plate
(materials, sections, clamp) is the shell's: solid_adapter/geometry.py.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import NDArray

from .params import CaseError
from .schema import Case, GeometryKind

Heights = Callable[[NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True, kw_only=True)
class FishParameters:
    """Every fish dimension, SI. Presets below; case keys override single entries."""

    body_length_m: float
    max_height_m: float
    peduncle_height_m: float
    caudal_fin_height_m: float
    head_length_m: float
    taper_start_x_m: float
    peduncle_x_m: float
    nose_height_fraction: float
    thickness_m: float  # CFRP core
    mfc_thickness_m: float
    actuator_length_m: float
    actuator_width_m: float
    active_length_m: float
    active_width_m: float
    actuator_start_x_m: float
    head_weight_radius_m: float
    head_weight_thickness_m: float
    head_weight_x_m: float | None = None  # default: radius + 3 mm

    @property
    def head_weight_centre_x_m(self) -> float:
        if self.head_weight_x_m is not None:
            return self.head_weight_x_m
        return self.head_weight_radius_m + 3e-3


_MM = 1e-3
# Tables 3.4 / 4.1: L 167, H 55, peduncle 30, fin 50, CFRP 0.2, MFC 112 x 40 (active 85 x 28),
# head weight r 2.5 mm, 2.5 mm thick (Table 3.5).
_ORIGINAL = FishParameters(
    body_length_m=167 * _MM,
    max_height_m=55 * _MM,
    peduncle_height_m=30 * _MM,
    caudal_fin_height_m=50 * _MM,
    head_length_m=30 * _MM,
    taper_start_x_m=112 * _MM,
    peduncle_x_m=140 * _MM,
    nose_height_fraction=0.75,
    thickness_m=0.2 * _MM,
    mfc_thickness_m=0.3 * _MM,
    actuator_length_m=112 * _MM,
    actuator_width_m=40 * _MM,
    active_length_m=85 * _MM,
    active_width_m=28 * _MM,
    actuator_start_x_m=3 * _MM,
    head_weight_radius_m=2.5 * _MM,
    head_weight_thickness_m=2.5 * _MM,
)
# Table 5.2: peduncle 3, fin 60, head weight r 7, max height 64, same MFC, CFRP 0.2.
_SERIAL = replace(
    _ORIGINAL,
    max_height_m=64 * _MM,
    peduncle_height_m=3 * _MM,
    caudal_fin_height_m=60 * _MM,
    head_weight_radius_m=7 * _MM,
)
FISH_PRESETS = {
    "original": _ORIGINAL,
    "serial": _SERIAL,
    # Table 5.6: the serial fish with fin 20, MFC 103 x 35, CFRP 0.1.
    "integrative": replace(
        _SERIAL,
        caudal_fin_height_m=20 * _MM,
        thickness_m=0.1 * _MM,
        actuator_length_m=103 * _MM,
        actuator_width_m=35 * _MM,
    ),
}

# Table 3.2: MFC 85 x 7 x 0.3 on CFRP 87 x 8 x 0.2, clamped-free.
BEAM_DEFAULTS = dict(
    length_m=87 * _MM,
    width_m=8 * _MM,
    thickness_m=0.2 * _MM,
    mfc_thickness_m=0.3 * _MM,
    actuator_length_m=85 * _MM,
    actuator_width_m=7 * _MM,
    # The seed (SOLID186) clamps the end face of the CFRP; the MFC's own end is
    # not held, and shear lag frees it over a length of the order of the
    # laminate thickness (0.3-0.5 mm). A shell clamps every layer at once, so
    # the MFC is set back 0.4 mm from the clamp (calibrated inside that range on
    # Table 3.3, see docs/geometry.md). With 0 the first mode is 28.5 Hz.
    actuator_start_x_m=0.4 * _MM,
)


def fish_height(p: FishParameters, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Local plate height h(x) of the fish outline (|y| <= h/2)."""
    x = np.asarray(x, dtype=float)
    H, f = p.max_height_m, p.nose_height_fraction
    s_head = np.clip(x / p.head_length_m, 0.0, 1.0)
    head = H * (f + (1 - f) * np.sqrt(np.clip(1 - (1 - s_head) ** 2, 0.0, 1.0)))
    s_taper = np.clip((x - p.taper_start_x_m) / (p.peduncle_x_m - p.taper_start_x_m), 0.0, 1.0)
    taper = H - (H - p.peduncle_height_m) * (1 - np.cos(np.pi * s_taper)) / 2
    s_fin = np.clip((x - p.peduncle_x_m) / (p.body_length_m - p.peduncle_x_m), 0.0, 1.0)
    fin = p.peduncle_height_m + (p.caudal_fin_height_m - p.peduncle_height_m) * s_fin
    heights: NDArray[np.float64] = np.where(
        x < p.head_length_m,
        head,
        np.where(x < p.taper_start_x_m, H, np.where(x < p.peduncle_x_m, taper, fin)),
    )
    return heights


def check(ok: bool, key: str, message: str) -> None:
    """A case error naming the key when ``ok`` fails."""
    if not ok:
        raise CaseError(f"case.toml: {key} {message}")


def resolve_fish(case: Case) -> FishParameters:
    """The case's fish: its preset with the case's keys over it, checked to fit together."""
    g = case.geometry
    params = FISH_PRESETS[g.preset.value]
    given = {
        f.name: getattr(g, f.name)
        for f in fields(FishParameters)
        if hasattr(g, f.name) and getattr(g, f.name) is not None
    }
    p = replace(params, **given)
    L = p.body_length_m
    check(
        p.head_length_m < p.taper_start_x_m,
        "geometry.head_length_m",
        f"must be < geometry.taper_start_x_m ({p.taper_start_x_m:g}), got {p.head_length_m:g}",
    )
    check(
        p.taper_start_x_m < p.peduncle_x_m,
        "geometry.taper_start_x_m",
        f"must be < geometry.peduncle_x_m ({p.peduncle_x_m:g}), got {p.taper_start_x_m:g}",
    )
    check(
        p.peduncle_x_m < L,
        "geometry.peduncle_x_m",
        f"must be < geometry.body_length_m ({L:g}), got {p.peduncle_x_m:g}",
    )
    check(
        p.peduncle_height_m <= p.max_height_m,
        "geometry.peduncle_height_m",
        f"must be <= geometry.max_height_m ({p.max_height_m:g}), got {p.peduncle_height_m:g}",
    )
    check(
        p.active_length_m <= p.actuator_length_m,
        "geometry.active_length_m",
        f"must be <= geometry.actuator_length_m ({p.actuator_length_m:g})",
    )
    check(
        p.active_width_m <= p.actuator_width_m,
        "geometry.active_width_m",
        f"must be <= geometry.actuator_width_m ({p.actuator_width_m:g})",
    )
    r, x_w = p.head_weight_radius_m, p.head_weight_centre_x_m
    span = np.linspace(max(x_w - r, 0.0), min(x_w + r, L), 21)
    high = float(fish_height(p, span).min()) if 0 <= x_w <= L else 0.0  # the disk's narrowest
    check(
        r <= x_w <= L - r and 2 * r <= high,
        "geometry.head_weight_x_m",
        f"and geometry.head_weight_radius_m put a head weight of radius {r:g} m at x = "
        f"{x_w:g} m, where it does not fit on the plate ({L:g} m long, as little as {high:.4g} m "
        "high under it)",
    )
    x_end = p.actuator_start_x_m + p.actuator_length_m
    check(
        x_end < L,
        "geometry.actuator_length_m",
        f"ends at x = {x_end:g} m, beyond the body length {L:g} m",
    )
    xs = np.linspace(p.actuator_start_x_m, x_end, 200)
    h = fish_height(p, xs)
    bad = h < p.actuator_width_m
    check(
        not bad.any(),
        "geometry.actuator_width_m",
        f"({p.actuator_width_m:g} m) does not fit the planform: the plate is only "
        f"{h[bad].min() if bad.any() else 0:.4g} m high at x = "
        f"{xs[bad][0] if bad.any() else 0:.4g} m (move geometry.actuator_start_x_m or change "
        f"the outline)",
    )
    return p


def beam_dimensions(case: Case) -> dict[str, float]:
    """The beam model's dimensions: the case's keys, else the seed's (BEAM_DEFAULTS)."""
    g = case.geometry
    return {k: getattr(g, k) if getattr(g, k) is not None else v for k, v in BEAM_DEFAULTS.items()}


@dataclass(frozen=True, kw_only=True)
class Planform:
    """The plate's outline: x in [0, length_m], |y| <= h(x)/2."""

    kind: GeometryKind
    length_m: float
    height_fn: Heights
    kinks_m: tuple[float, ...]  # 0 = x_0 < ... < x_n = L, where h(x) has kinks

    def height(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.height_fn(x)


def _constant(width: float) -> Heights:
    return lambda x: np.full(np.shape(x), width)


def planform(case: Case) -> Planform:
    """The case's planform (the fish's keys checked as for the shell)."""
    g = case.geometry
    if g.kind is GeometryKind.FISH:
        p = resolve_fish(case)
        L = p.body_length_m
        return Planform(
            kind=g.kind,
            length_m=L,
            height_fn=lambda x: fish_height(p, x),
            kinks_m=(0.0, p.head_length_m, p.taper_start_x_m, p.peduncle_x_m, L),
        )
    if g.kind is GeometryKind.BEAM:
        val = beam_dimensions(case)
        L = val["length_m"]
        return Planform(
            kind=g.kind, length_m=L, height_fn=_constant(val["width_m"]), kinks_m=(0.0, L)
        )
    assert g.length_m and g.width_m  # checked by the loader
    L = g.length_m
    return Planform(kind=g.kind, length_m=L, height_fn=_constant(g.width_m), kinks_m=(0.0, L))
