"""The laminate on the plate: each geometry (the fish planform's three presets, the seed's beam
model, a plain rectangle) resolved into a :class:`PlateLayout` (outline, laminate regions, clamp).

The outline itself, which the fluid side needs too, is the core's:
fsi_orchestrator/case/planform.py (the fish's dimensions, presets and h(x)).

Coordinates: x along the body (nose at x = 0, tail at L), y across the plate (vertical in the
tank), z normal to the plate (the swing direction). The outline is symmetric about y = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.planform import (
    beam_dimensions,
    check,
    fish_height,
    resolve_fish,
)
from fsi_orchestrator.case.schema import ActuatorSides, GeometryKind, HeadCondition

from .materials import (
    CFRP,
    MFC,
    MFC_BORDER,
    STEEL_HEAD_WEIGHT,
    Material,
    PiezoConstants,
    Section,
    stack,
)


@dataclass(frozen=True)
class Rect:
    x0: float
    x1: float
    half_width: float

    def contains(self, x: NDArray, y: NDArray) -> NDArray:
        return (x >= self.x0) & (x <= self.x1) & (np.abs(y) <= self.half_width)


@dataclass(frozen=True)
class Disk:
    xc: float
    radius: float

    def contains(self, x: NDArray, y: NDArray) -> NDArray:
        return (x - self.xc) ** 2 + y**2 <= self.radius**2


@dataclass(frozen=True, kw_only=True)
class PlateLayout:
    """Everything the shell needs to know about the plate, independent of the mesh."""

    kind: GeometryKind
    length_m: float
    height_fn: object  # callable x -> h(x)
    breakpoints_m: tuple[float, ...]  # x positions the mesh must have element edges at
    # (half-width, x0, x1): lines y = +-half-width the mesh follows exactly for x0 <= x <= x1
    y_breaks: tuple[tuple[float, float, float], ...] = ()
    sections: tuple[Section, ...]  # laminate per region code
    region_rules: tuple[tuple[str, object], ...]  # (name, shape) flags used by region()
    clamp_x_m: float | None  # nodes with x <= clamp_x are clamped; None: free
    head_weight_mass_kg: float = 0.0
    description: str = ""
    drive_model: str = "induced-strain"  # or "seed-stress" (ShellModel.dead_drive_per_volt)
    # elastic head support: nodes with x <= support_x_m rest on springs (total N/m)
    support_x_m: float | None = None
    support_stiffness_n_per_m: float = 0.0
    # hinge (the thrust rig's stick): the nodes on the line x = pin_x_m are held in
    # translation and free to turn, one rigid mode (yaw about the line) left
    pin_x_m: float | None = None

    @property
    def rigid_modes(self) -> int:
        """Rigid-body modes the supports leave: 6 for a free plate, 1 on a hinge."""
        if self.pin_x_m is not None:
            return 1
        return 6 if self.clamp_x_m is None and self.support_x_m is None else 0

    def height(self, x: NDArray) -> NDArray:
        return self.height_fn(x)  # type: ignore[operator]

    def region(self, x: NDArray, y: NDArray) -> NDArray:
        """Region code per point: bit k set when point lies in region_rules[k]."""
        code = np.zeros(np.shape(x), dtype=np.int64)
        for k, (_, shape) in enumerate(self.region_rules):
            code |= shape.contains(x, y).astype(np.int64) << k  # type: ignore[attr-defined]
        return code

    @property
    def tip_point(self) -> tuple[float, float]:
        """Tail tip / free-edge mid-point: trailing edge at y = 0."""
        return (self.length_m, 0.0)


def _fish_layout(case: Case, piezo: PiezoConstants) -> PlateLayout:
    p = resolve_fish(case)
    core = _core_material(case, default="fsi")
    weight = Disk(xc=p.head_weight_centre_x_m, radius=p.head_weight_radius_m)  # fits: resolve_fish
    package = Rect(
        p.actuator_start_x_m, p.actuator_start_x_m + p.actuator_length_m, p.actuator_width_m / 2
    )
    x_active = p.actuator_start_x_m + (p.actuator_length_m - p.active_length_m) / 2
    active = Rect(x_active, x_active + p.active_length_m, p.active_width_m / 2)
    sides = _sides(case, ActuatorSides.BOTH)
    tw = p.head_weight_thickness_m

    sections = []
    for code in range(8):  # bit 0: package, bit 1: active area, bit 2: head weight
        in_package, in_active, in_weight = bool(code & 1), bool(code & 2), bool(code & 4)
        outer: dict[int, list[tuple[Material, float, bool]]] = {0: [], 1: []}
        for side in (0, 1):
            if in_package and side in sides:
                outer[side].append((MFC if in_active else MFC_BORDER, p.mfc_thickness_m, in_active))
            if in_weight and tw > 0:
                outer[side].append((STEEL_HEAD_WEIGHT, tw / 2, False))
        sections.append(Section.from_layers(stack(core, p.thickness_m, outer), piezo))

    clamp = _clamp_x(case, default=weight.xc + weight.radius)
    breaks = {
        0.0,
        p.body_length_m,
        package.x0,
        package.x1,
        active.x0,
        active.x1,
        p.head_length_m,
        p.taper_start_x_m,
        p.peduncle_x_m,
        weight.xc + weight.radius,
    }
    if clamp is not None:
        breaks.add(clamp)
    pin = _pin_x(case, p.body_length_m, breaks)
    if pin is not None:
        breaks.add(pin)
    mass = STEEL_HEAD_WEIGHT.density_kg_m3 * np.pi * weight.radius**2 * tw
    return PlateLayout(
        kind=GeometryKind.FISH,
        length_m=p.body_length_m,
        height_fn=lambda x: fish_height(p, x),
        breakpoints_m=tuple(sorted(breaks)),
        sections=tuple(sections),
        region_rules=(("actuator", package), ("active", active), ("head_weight", weight)),
        y_breaks=(
            (active.half_width, active.x0, active.x1),
            (package.half_width, package.x0, package.x1),
        ),
        clamp_x_m=clamp,
        pin_x_m=pin,
        head_weight_mass_kg=float(mass),
        description=f"fish preset {case.geometry.preset.value}",
    )


def _beam_layout(case: Case, piezo: PiezoConstants) -> PlateLayout:
    val = beam_dimensions(case)
    L, W = val["length_m"], val["width_m"]
    core = _core_material(case, default="beam")
    mfc = Rect(
        val["actuator_start_x_m"],
        val["actuator_start_x_m"] + val["actuator_length_m"],
        val["actuator_width_m"] / 2,
    )
    check(
        mfc.x1 <= L + 1e-12,
        "geometry.actuator_length_m",
        f"ends at x = {mfc.x1:g} m, beyond geometry.length_m = {L:g} m",
    )
    check(
        val["actuator_width_m"] <= W + 1e-12,
        "geometry.actuator_width_m",
        f"must be <= geometry.width_m ({W:g})",
    )
    sides = _sides(case, ActuatorSides.TOP)
    breaks = {0.0, L, mfc.x0, min(mfc.x1, L)}
    pin = _pin_x(case, L, breaks)
    sections = []
    for code in range(2):
        outer = {
            s: [(MFC, val["mfc_thickness_m"], True)] if (code and s in sides) else []
            for s in (0, 1)
        }
        sections.append(Section.from_layers(stack(core, val["thickness_m"], outer), piezo))
    return PlateLayout(
        kind=GeometryKind.BEAM,
        length_m=L,
        height_fn=lambda x: np.full(np.shape(x), W),
        breakpoints_m=tuple(sorted(breaks | ({pin} if pin is not None else set()))),
        sections=tuple(sections),
        region_rules=(("actuator", mfc),),
        clamp_x_m=_clamp_x(case, default=0.0),
        pin_x_m=pin,
        y_breaks=((mfc.half_width, mfc.x0, mfc.x1),) if mfc.half_width < W / 2 else (),
        description="seed beam model (Table 3.2)",
    )


def _rectangle_layout(case: Case) -> PlateLayout:
    g, m = case.geometry, case.material
    assert g.length_m and g.width_m and g.thickness_m  # checked by the loader
    E, nu, rho = m.youngs_modulus_pa, m.poisson_ratio, m.density_kg_m3
    assert E is not None and nu is not None and rho is not None  # ... and these
    mat = Material.isotropic("rectangle", E, nu, rho)
    t = g.thickness_m
    section = Section.from_layers(stack(mat, t, {}), None)
    W = g.width_m
    pin = _pin_x(case, g.length_m, {0.0, g.length_m})
    return PlateLayout(
        kind=GeometryKind.RECTANGLE,
        length_m=g.length_m,
        height_fn=lambda x: np.full(np.shape(x), W),
        breakpoints_m=tuple(sorted({0.0, g.length_m} | ({pin} if pin is not None else set()))),
        sections=(section,),
        region_rules=(),
        clamp_x_m=_clamp_x(case, default=0.0),
        pin_x_m=pin,
        description="isotropic rectangle",
    )


def _core_material(case: Case, default: str) -> Material:
    m = case.material
    base = CFRP[m.cfrp.value if m.cfrp is not None else default]
    if m.youngs_modulus_pa is None and m.poisson_ratio is None and m.density_kg_m3 is None:
        return base
    e = m.youngs_modulus_pa or base.e1_pa
    nu = m.poisson_ratio if m.poisson_ratio is not None else base.nu12
    rho = m.density_kg_m3 or base.density_kg_m3
    return Material.isotropic(base.name + " (overridden)", e, nu, rho)


def _sides(case: Case, default: ActuatorSides) -> tuple[int, ...]:
    sides = case.geometry.actuator_sides or default
    return (0, 1) if sides is ActuatorSides.BOTH else (0,)


def _clamp_x(case: Case, default: float) -> float | None:
    if case.boundary.head is not HeadCondition.CLAMPED:
        return None
    return case.boundary.clamp_length_m if case.boundary.clamp_length_m is not None else default


def piezo_constants(case: Case) -> PiezoConstants:
    a = case.actuation
    return PiezoConstants(a.d33_m_per_v, a.d31_m_per_v, a.electrode_spacing_m)


def build_layout(case: Case) -> PlateLayout:
    piezo = piezo_constants(case)
    if case.geometry.kind is GeometryKind.FISH:
        layout = _fish_layout(case, piezo)
    elif case.geometry.kind is GeometryKind.BEAM:
        layout = _beam_layout(case, piezo)
    else:
        return _rectangle_layout(case)
    layout = replace(layout, drive_model=case.actuation.drive_model.value)
    if case.boundary.head is HeadCondition.ELASTIC:
        held = replace(case, boundary=replace(case.boundary, head=HeadCondition.CLAMPED))
        region = _fish_layout(held, piezo) if layout.kind is GeometryKind.FISH else None
        layout = replace(
            layout,
            support_x_m=region.clamp_x_m if region is not None else _clamp_x(held, 0.0),
            support_stiffness_n_per_m=case.boundary.support_stiffness_n_per_m,
        )
    return layout


# a hinge this close (share of the length) to an edge the mesh has anyway stands on it: a
# sliver of a column beside it would only slow the fluid's mesh (2e-9 m: 75 s for fsi-modal)
HINGE_SNAP = 1e-3


def _pin_x(case: Case, length: float, breaks: set[float]) -> float | None:
    """The hinge's x (boundary.pin_x_m) on the plate, on a nearby breakpoint if within
    HINGE_SNAP of the length; None unless the head is pinned."""
    if case.boundary.head is not HeadCondition.PINNED:
        return None
    pin = case.boundary.pin_x_m
    check(pin <= length, "boundary.pin_x_m", f"({pin:g} m) must lie on the plate (0-{length:g} m)")
    near = min(breaks, key=lambda b: abs(b - pin))
    return near if abs(near - pin) <= HINGE_SNAP * length else pin
