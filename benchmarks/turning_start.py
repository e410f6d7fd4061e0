"""The start of the seed's turn (Sec. 4.5: 18 Hz square, left -500..+1500 V, right -500..+500 V)
as a manoeuvre: the rigid body's surge, sway and yaw from rest, driven by the swimming model's
mean loads (fluid_adapter/swimming.py) at each instant's speed, sway velocity and yaw rate.

The seed reports "the maximum turning velocity" over about a second of film (Fig. 4.14);
fsi-run gives the steady turn. This asks whether the way into the turn passes a faster rate,
and whether the steady turn is stable (the eigenvalues of sway and yaw about it).

Equations (body axes, nose forward, +z to the left, yaw Omega about +y):

    m dU/dt           = T(U) - D(U) + m v Omega
    (m + m22) dv/dt - m26 dOmega/dt = F(U, v, Omega) - m U Omega
    -m26 dv/dt + (I + m66) dOmega/dt = -N(U, v, Omega)

F and N are the mean side force and the moment int (x - x_r) l dx of side_force_and_moment (the
physical yaw torque about +y is -N), T Lighthill's thrust, D the body's drag, m22, m26, m66 the
strips' added masses int A r^k dx and I the plate's own yaw inertia. The periodic motion at each
speed is interpolated from a grid of speeds. Quasi-steady: the mean loads of each period act at
once. At a forward speed the sway velocity v enters the loads as the slip v / U of the steady
model (the same stream met at an angle), whose forces lie along and across the path: written
in body axes they leave out (T - D) v / U across it, nothing in the steady turn and little
while the fish gathers speed (v is still small then).

    python benchmarks/turning_start.py          # about 1 min on 2 cores
"""

from __future__ import annotations

import dataclasses
import sys
from functools import partial
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp, trapezoid

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fishfsi.cli.fast_model import linear_model, midline_nodes, without_cfd  # noqa: E402
from fishfsi.cli.linear import (  # noqa: E402
    SAMPLES_PER_PERIOD,
    _history_at_speed,
    _motion_at_speed,
)
from fishfsi.cli.swimming import _mass_and_volume, swimming_model  # noqa: E402
from fluid_adapter.slender_body import added_mass_per_length  # noqa: E402
from fluid_adapter.swimming import (  # noqa: E402
    mean_pressure_thrust,
    mean_thrust,
    side_force_and_moment,
)
from fsi_orchestrator.case import load_case  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RIGHT_TURN = ("actuation.frequency_hz=18", "actuation.right_volts=[-500.0, 500.0]")
SPEEDS = np.linspace(0.0, 1.0, 21)  # the motion's grid, m/s
SECONDS = 1.5


def yaw_inertia(model, x_cm: float) -> float:
    """The plate's own moment of inertia about the vertical axis through its centre of mass."""
    quad = model.mesh.dense
    codes = model.layout.region(quad.points[..., 0], quad.points[..., 1])
    rho = np.array([sec.rho[0] for sec in model.layout.sections])[codes]
    return float(np.sum(rho * quad.weights * (quad.points[..., 0] - x_cm) ** 2))


def manoeuvre(case_dir: Path, overrides: tuple[str, ...]) -> dict:
    case = without_cfd(load_case(case_dir, overrides))
    a = case.actuation
    linear = linear_model(case)
    model = linear.model
    midline = midline_nodes(model)
    x = model.mesh.nodes[midline, 0]
    swim = swimming_model(case, model, x)
    swim = dataclasses.replace(
        swim,
        max_speed_m_s=linear.divergence_speed_m_s,
        added_mass_coefficient=linear.section_added_mass_coefficient,
    )
    times = np.arange(SAMPLES_PER_PERIOD + 1) / (SAMPLES_PER_PERIOD * a.frequency_hz)
    still = linear.response(a.frequency_hz, a.waveform)
    at_speed = _motion_at_speed(linear, a.frequency_hz, a.waveform, still)
    history = partial(_history_at_speed, at_speed, midline * 5 + 2, times)
    steady = swim.row(times, history, a.frequency_hz)

    dt = float(times[1] - times[0])
    grid = np.array([np.asarray(history(v))[:-1] for v in SPEEDS])  # one period each

    def motion(speed: float) -> np.ndarray:
        v = min(max(speed, 0.0), SPEEDS[-1])
        j = min(int(v / SPEEDS[1]), len(SPEEDS) - 2)
        w = (v - SPEEDS[j]) / SPEEDS[1]
        return (1 - w) * grid[j] + w * grid[j + 1]

    mass, x_cm, _ = _mass_and_volume(model)
    r = x - swim.x_ref_m
    area = added_mass_per_length(
        swim.half_height_m, swim.density_kg_m3, swim.added_mass_coefficient
    )
    m22, m26, m66 = (trapezoid(area * r**k, x) for k in (0, 1, 2))
    inertia = np.array([[mass + m22, -m26], [-m26, yaw_inertia(model, x_cm) + m66]])
    fluid = {
        "density_kg_m3": swim.density_kg_m3,
        "added_mass_coefficient": swim.added_mass_coefficient,
    }

    def loads(speed: float, sway: float, rate: float) -> tuple[float, float, float]:
        h = motion(speed)
        yaw = side_force_and_moment(
            x,
            swim.half_height_m,
            h,
            dt,
            speed_m_s=max(speed, 0.0),
            x_ref_m=swim.x_ref_m,
            yaw_rate_rad_s=rate,
            lateral_velocity_m_s=sway,
            crossflow_drag_coefficient=swim.crossflow_drag_coefficient,
            **fluid,
        )
        thrust = mean_pressure_thrust if swim.pressure_thrust else mean_thrust
        surge = thrust(x, swim.half_height_m, h, dt, max(speed, 0.0), **fluid)
        surge -= swim.drag.total(max(speed, 0.0))
        return yaw.side_force_n, yaw.yaw_moment_nm, surge

    def rhs(_t, y):
        speed, sway, rate = y
        side, moment, surge = loads(speed, sway, rate)
        d_sway, d_rate = np.linalg.solve(inertia, [side - mass * speed * rate, -moment])
        return [(surge + mass * sway * rate) / mass, d_sway, d_rate]

    run = solve_ivp(rhs, (0.0, SECONDS), [0.0, 0.0, 0.0], max_step=0.005, rtol=1e-6)
    rate_deg = np.degrees(run.y[2])
    peak = int(np.argmax(np.abs(rate_deg)))

    # the steady turn's stability: sway and yaw linearized about where the start ends
    speed, sway0, rate0 = (float(v) for v in run.y[:, -1])

    def lateral(sway: float, rate: float) -> np.ndarray:
        side, moment, _ = loads(speed, sway, rate)
        return np.array([side - mass * speed * rate, -moment])

    dv, dr = 1e-5, 1e-4
    jac = np.column_stack(
        [
            (lateral(sway0 + dv, rate0) - lateral(sway0 - dv, rate0)) / (2 * dv),
            (lateral(sway0, rate0 + dr) - lateral(sway0, rate0 - dr)) / (2 * dr),
        ]
    )
    eig = np.linalg.eigvals(np.linalg.solve(inertia, jac))
    within = run.t <= 1.0
    return {
        "steady_rate_deg_s": float(steady["turning_rate_deg_s"]),
        "steady_speed_m_s": float(steady["swimming_speed_m_s"]),
        "peak_rate_deg_s": float(rate_deg[peak]),
        "peak_at_s": float(run.t[peak]),
        "rate_at_1s_deg_s": float(np.interp(1.0, run.t, rate_deg)),
        "speed_at_1s_m_s": float(np.interp(1.0, run.t, run.y[0])),
        "heading_after_1s_deg": float(np.degrees(trapezoid(run.y[2][within], run.t[within]))),
        "eigenvalues_per_s": [complex(e) for e in eig],
        "trace": [
            (t, float(np.interp(t, run.t, run.y[0])), float(np.interp(t, run.t, rate_deg)))
            for t in (0.05, 0.1, 0.2, 0.3, 0.5, 1.0)
        ],
    }


def main() -> None:
    found = manoeuvre(ROOT / "cases" / "swim_original_18Hz", RIGHT_TURN)
    print("original robot, right turn, 18 Hz square, from rest:")
    print(
        f"  steady turn {found['steady_rate_deg_s']:+.2f} deg/s at {found['steady_speed_m_s']:.3f}"
        f" m/s; the start's fastest rate {found['peak_rate_deg_s']:+.2f} deg/s at "
        f"{found['peak_at_s']:.2f} s; after 1 s {found['rate_at_1s_deg_s']:+.2f} deg/s at "
        f"{found['speed_at_1s_m_s']:.3f} m/s, heading {found['heading_after_1s_deg']:+.1f} deg"
    )
    eig = ", ".join(f"{e.real:.2f}{e.imag:+.2f}i" for e in found["eigenvalues_per_s"])
    print(f"  sway and yaw about the steady turn: eigenvalues {eig} 1/s")
    for t, u, rate in found["trace"]:
        print(f"  t = {t:.2f} s: speed {u:.3f} m/s, yaw rate {rate:+.2f} deg/s")


if __name__ == "__main__":
    main()
