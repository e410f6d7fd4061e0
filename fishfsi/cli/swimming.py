"""Swimming figures of a case (``analysis.kind = "swimming"``): self-propelled speed, body
lengths per second, swimming number Sw = V / (f L) (seed eq. 5-15) and turning rate.

The motion is the free fish's linear periodic response about the mean-voltage equilibrium,
as ``fsi-sweep --method linear`` computes it (its recoil included: the head is free), at each
speed the balance tries (swimming.speed_coupling; linear.py); the thrust, drag and yaw
balance are :mod:`fluid_adapter.swimming`'s. ``fsi-run`` prints one
drive's figures; ``fsi-sweep`` adds them to each frequency's row. docs/swimming.md.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fsi_orchestrator.case import Case, CaseError
from fsi_orchestrator.case.planform import resolve_fish
from fsi_orchestrator.case.schema import ThrustModel

from .common import save_figure

if TYPE_CHECKING:
    from fluid_adapter.swimming import BodyDrag, Turning

# the contract of fsi-run --json for a swimming case, and fsi-sweep's extra columns
SWIMMING_KEYS = (
    "swimming_speed_m_s",
    "body_lengths_per_s",
    "swimming_number",
    "turning_rate_deg_s",
)
SLIP_ITERATIONS = 2  # speed with the sideslip of the turn, and again: a change < 1e-6 here


@dataclass(frozen=True, kw_only=True)
class SwimmingModel:
    """What the swimming figures need of one fish: its midline, centre of mass and drag."""

    x_m: NDArray
    half_height_m: NDArray
    x_ref_m: float  # centre of mass: the turning axis
    body_length_m: float
    drag: BodyDrag
    density_kg_m3: float
    added_mass_coefficient: float
    crossflow_drag_coefficient: float
    prescribed_speed_m_s: float | None
    pressure_thrust: bool = False  # swimming.thrust_model = "pressure"
    # the motion's divergence speed where it is solved at each speed (swimming.speed_coupling)
    max_speed_m_s: float = float("inf")

    def past_divergence(self) -> str:
        """Why a prescribed speed at or past the motion's divergence speed has no answer."""
        return (
            f"swimming.speed_m_s = {self.prescribed_speed_m_s:g} is past the plate's divergence "
            f"speed ({self.max_speed_m_s:.3g} m/s), where the load at speed outgrows the "
            "stiffness of its modes and the linear motion means nothing: give a lower speed, "
            "or swimming.speed_coupling = false for the still liquid's motion"
        )

    def row(self, times: NDArray, history: Callable[[float], NDArray], frequency_hz: float) -> dict:
        """The swimming columns of one drive from the midline history at a forward speed,
        ``history(V)`` (len(times), n_x), sampled at ``times`` over one period (the end point
        may repeat the start); the same array at every speed where the motion is taken as
        unchanged by the speed."""
        from fluid_adapter.swimming import (
            MAX_SPEED_M_S,
            SwimmingError,
            mean_pressure_thrust,
            mean_thrust,
            self_propelled_speed,
            turning_rate,
        )

        dt = float(times[1] - times[0])
        period = round(1 / (frequency_hz * dt))

        def motion(v: float) -> NDArray:
            return np.asarray(history(v))[-period:]

        x, b, r = self.x_m, self.half_height_m, self.x_m - self.x_ref_m
        fluid = {
            "density_kg_m3": self.density_kg_m3,
            "added_mass_coefficient": self.added_mass_coefficient,
        }

        thrust_of = mean_pressure_thrust if self.pressure_thrust else mean_thrust

        def speed_with(slip: float) -> tuple[float, float]:
            thrust = lambda v: thrust_of(x, b, motion(v) + slip * r, dt, v, **fluid)  # noqa: E731
            speed = self.prescribed_speed_m_s
            if speed is None:
                limit = min(self.max_speed_m_s, MAX_SPEED_M_S)
                speed = self_propelled_speed(thrust, self.drag.total, max_speed_m_s=limit)
            elif speed >= self.max_speed_m_s:
                raise SwimmingError(self.past_divergence())
            return speed, thrust(speed)

        slip, speed, thrust = 0.0, 0.0, 0.0
        turn: Turning | None = None
        for _ in range(SLIP_ITERATIONS):
            speed, thrust = speed_with(slip)
            h = motion(speed)
            turn = turning_rate(
                x,
                b,
                h,
                dt,
                speed_m_s=speed,
                x_ref_m=self.x_ref_m,
                crossflow_drag_coefficient=self.crossflow_drag_coefficient,
                **fluid,
            )
            slip = turn.slip_rad
        assert turn is not None  # SLIP_ITERATIONS >= 1
        drag = self.drag.parts(speed)
        length = self.body_length_m
        return {
            "swimming_speed_m_s": speed,
            "body_lengths_per_s": speed / length,
            "swimming_number": speed / (frequency_hz * length),
            "turning_rate_deg_s": float(np.degrees(turn.yaw_rate_rad_s)),
            "thrust_at_speed_n": thrust,
            # both thrust models' values at that speed (the flume compares them with CFD)
            "lighthill_thrust_at_speed_n": mean_thrust(x, b, h + slip * r, dt, speed, **fluid),
            "pressure_thrust_at_speed_n": mean_pressure_thrust(
                x, b, h + slip * r, dt, speed, **fluid
            ),
            "drag_at_speed_n": float(sum(drag.values())),
            # 0 at the self-propelled speed; at a prescribed speed, what a flume's balance reads
            "net_force_n": thrust - float(sum(drag.values())),
            **{f"{name}_drag_n": value for name, value in drag.items()},
            "reynolds_number": speed * length / self.drag.kinematic_viscosity_m2_s,
            "slip_deg": float(np.degrees(turn.slip_rad)),
            "yaw_drive_moment_nm": turn.drive_moment_nm,
            "section_added_mass_coefficient": self.added_mass_coefficient,
        }


def swimming_model(case: Case, model, x_m: NDArray) -> SwimmingModel:
    """The case's swimming model on the shell ``model``'s midline nodes ``x_m``."""
    from fluid_adapter.swimming import BodyDrag, FormDrag

    s, fluid = case.swimming, case.fluid
    mass, x_cm, volume = _mass_and_volume(model)
    float_volume = s.float_volume_m3
    if float_volume is None:  # neutral buoyancy: the float carries what the liquid does not
        excess = max(mass - fluid.density_kg_m3 * volume, 0.0)
        lift = fluid.density_kg_m3 - s.float_density_kg_m3
        if excess > 0 and not lift > 0:
            raise CaseError(
                f"swimming.float_density_kg_m3 = {s.float_density_kg_m3:g} is not below "
                f"fluid.density_kg_m3 = {fluid.density_kg_m3:g}: a float that does not rise "
                f"cannot carry the robot's {1e3 * excess:.3g} g beyond its buoyancy; give a "
                "lighter float or its volume (swimming.float_volume_m3)"
            )
        float_volume = excess / lift if excess > 0 else 0.0
    p = resolve_fish(case)
    form = (
        FormDrag(
            name="head_weight",
            frontal_area_m2=2 * p.head_weight_radius_m * p.head_weight_thickness_m,
            drag_coefficient=s.head_weight_drag_coefficient,
        ),
        FormDrag(
            name="float",
            frontal_area_m2=float_volume ** (2 / 3),  # a cube face-on
            drag_coefficient=s.float_drag_coefficient,
        ),
    )
    planform = float(model.area_matrix.sum())
    drag = BodyDrag(
        density_kg_m3=fluid.density_kg_m3,
        kinematic_viscosity_m2_s=fluid.kinematic_viscosity_m2_s,
        length_m=model.layout.length_m,
        wetted_area_m2=2 * planform,
        skin_friction=s.skin_friction.value,
        form=form,
    )
    return SwimmingModel(
        x_m=x_m,
        half_height_m=model.layout.height(x_m) / 2,
        x_ref_m=x_cm,
        body_length_m=model.layout.length_m,
        drag=drag,
        density_kg_m3=fluid.density_kg_m3,
        added_mass_coefficient=fluid.added_mass_coefficient,
        crossflow_drag_coefficient=s.crossflow_drag_coefficient,
        prescribed_speed_m_s=s.speed_m_s,
        pressure_thrust=s.thrust_model is ThrustModel.PRESSURE,
    )


def _mass_and_volume(model) -> tuple[float, float, float]:
    """The plate's mass (kg), the x of its centre of mass (m) and its volume (m^3), from the
    laminate of each region (head weight and MFCs included)."""
    quad = model.mesh.dense
    pts, weights = quad.points, quad.weights
    sections = model.layout.sections
    codes = model.layout.region(pts[..., 0], pts[..., 1])
    rho = np.array([sec.rho[0] for sec in sections])[codes]
    thickness = np.array(
        [max(ly.z1_m for ly in sec.layers) - min(ly.z0_m for ly in sec.layers) for sec in sections]
    )[codes]
    mass = float(np.sum(rho * weights))
    return (
        mass,
        float(np.sum(rho * weights * pts[..., 0]) / mass),
        float(np.sum(thickness * weights)),
    )


# The seed's measured swimming (square wave, -500..+1500 V unless noted); the body length of
# each robot is 0.167 m (Table 4.1; Tables 5.2, 5.6 keep it).
MEASURED = {
    "original": {
        "speed_m_s": 0.72,  # Sec. 4.4, Fig. 4.11: the maximum, at 18 Hz
        "frequency_hz": 18.0,
        # Sec. 4.5: 18 Hz, left -500..+1500 V, right -500..+500 V turns right (and mirrored)
        "turning_deg_s": -27.0,
        "turning_frequency_hz": 18.0,
    },
    "serial": {
        "speed_m_s": 0.792,  # Sec. 5.3.2, Fig. 5.15: the maximum, at 25 Hz
        "frequency_hz": 25.0,
        "body_lengths_per_s": 4.6,  # Table 5.8
        "swimming_number": 0.6,  # Table 5.8 (maximum)
    },
    "integrative": {
        "body_lengths_per_s": 3.5,  # Table 5.8 (maximum; its frequency is not given)
        "swimming_number": 0.75,  # Table 5.8 (maximum)
        "turning_deg_s": 53.0,  # Sec. 5.4.2: 15 Hz, turning left (51.6 deg/s turning right)
        "turning_frequency_hz": 15.0,
    },
}


def plot_swimming_sweep(csv_path: Path, output: Path) -> Path | None:
    """``swimming.png`` from a swimming sweep's table (None for another sweep): speed, swimming
    number and turning rate against frequency per waveform, with the seed's measured points."""
    import csv

    import matplotlib.pyplot as plt

    with open(csv_path, newline="") as table:
        rows = list(csv.DictReader(table))
    if not rows or SWIMMING_KEYS[0] not in rows[0]:
        return None
    keys = ("swimming_speed_m_s", "swimming_number", "turning_rate_deg_s")
    labels = ("speed [m/s]", "swimming number V/(f L)", "turning rate [deg/s] (+ left)")
    fig, axes = plt.subplots(3, 1, figsize=(6.5, 8.0), sharex=True)
    for waveform in sorted({r["waveform"] for r in rows}):
        sel = [r for r in rows if r["waveform"] == waveform]
        f = [float(r["frequency_hz"]) for r in sel]
        for ax, key in zip(axes, keys, strict=True):
            ax.plot(f, [float(r[key] or "nan") for r in sel], "o-", label=f"model, {waveform}")
    for robot, m in MEASURED.items():  # the seed's robots, square wave
        if "frequency_hz" in m:
            axes[0].plot(m["frequency_hz"], m["speed_m_s"], "s", label=f"seed, {robot}")
        if "swimming_number" in m:
            axes[1].axhline(m["swimming_number"], ls=":", color="grey")
            axes[1].annotate(f"seed max, {robot}", (0, m["swimming_number"]), fontsize=7)
        if "turning_deg_s" in m:
            axes[2].plot(m["turning_frequency_hz"], m["turning_deg_s"], "s", label=f"seed, {robot}")
    for ax, label in zip(axes, labels, strict=True):
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[-1].set_xlabel("driving frequency [Hz]")
    fig.tight_layout()
    target = output / "swimming.png"
    save_figure(fig, target)
    return target
