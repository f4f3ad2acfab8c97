"""The identifiable combinations of a vehicle file: what a perfect fit of its logs returns.

Used three ways: the truth of the known-answer benchmark (``benchmarks/fit.py``), the
default of every parameter a log does not determine (the template vehicle's value), and
the controller gains of a fitted vehicle (scaled by its control effectiveness).
"""

from __future__ import annotations

import numpy as np

from etsid.fit.layout import geometry_rows
from etsid.sim.trim import hover_trim
from etsid.sim.vehicle import Vehicle


def _scales(vehicle: Vehicle) -> np.ndarray:
    s = vehicle.effects["inertia_scale"]
    return np.asarray(s if isinstance(s, list) else [s, s, s], dtype=float)


def vehicle_truth(vehicle: Vehicle, v0: float | None = None) -> dict[str, float]:
    """Identifiable combinations of ``vehicle`` at pack voltage ``v0`` (V; default: the
    voltage of its hover trim), in the units of :mod:`etsid.fit.result`'s parameters.

    Keys: ``k`` (m/s² per rotor at full command), ``idle_ratio``, ``thrust_to_weight``,
    ``hover_command``, ``thrust_slope`` (d(T/W)/dm at hover), ``motor_time_constant`` (s),
    ``time_delay`` (s), ``roll_effectiveness`` / ``pitch_effectiveness`` (m l/I, 1/m),
    ``yaw_effectiveness`` (m κ_Q/Izz, 1/m), ``roll_accel_per_command`` … (the
    effectiveness × ∂f/∂m at hover, rad/s²), ``inertia_ratio_yx`` (Iyy/Ixx), ``drag_x``,
    ``drag_y`` (1/s), ``drag_quad_x``, ``drag_quad_y`` (1/m), ``arm`` (m), ``kappa_q`` (m).
    """
    trim = hover_trim(vehicle)
    v0 = trim.vbat if v0 is None else v0
    mass = vehicle.mass
    g = vehicle["environment"]["gravity"]
    n = vehicle.n_rotors
    mot = vehicle["motor"]
    top = mot["omega_max"] * v0 / mot["v_ref"]
    k = trim.thrust / trim.omega ** 2 * top ** 2 / mass
    idle = mot["omega_idle"] / top
    x_h = trim.omega / top
    arm = vehicle["frame"]["arm_length"]
    inertia = vehicle.inertia * np.sqrt(np.outer(_scales(vehicle), _scales(vehicle)))
    kappa_q = trim.torque / trim.thrust
    lag = vehicle.effects["motor_lag"]
    tau = float(np.mean(lag)) if lag is not None else mot["time_constant"]
    drag = vehicle["drag"]
    rotor_h = drag["rotor_drag"] * n * trim.omega
    dfdm = 2.0 * k * x_h * (1.0 - idle)
    eff = {"roll": mass * arm / inertia[0, 0], "pitch": mass * arm / inertia[1, 1],
           "yaw": mass * trim.torque / trim.thrust / inertia[2, 2]}
    return {
        **{f"{a}_accel_per_command": e * dfdm for a, e in eff.items()},
        "k": k, "idle_ratio": idle, "thrust_to_weight": k * n / g,
        "hover_command": (x_h - idle) / (1.0 - idle),
        "thrust_slope": 2.0 * k * n * x_h * (1.0 - idle) / g,
        "motor_time_constant": tau, "time_delay": vehicle.effects["time_delay"],
        "roll_effectiveness": mass * arm / inertia[0, 0],
        "pitch_effectiveness": mass * arm / inertia[1, 1],
        "yaw_effectiveness": mass * kappa_q / inertia[2, 2],
        "inertia_ratio_yx": inertia[1, 1] / inertia[0, 0],
        "drag_x": (drag["linear"][0] + rotor_h) / mass,
        "drag_y": (drag["linear"][1] + rotor_h) / mass,
        "drag_quad_x": drag["quadratic"][0] / mass, "drag_quad_y": drag["quadratic"][1] / mass,
        "arm": arm, "kappa_q": kappa_q, "hover_omega": trim.omega, "top": top, "v0": v0,
    }


def effectiveness(vehicle: Vehicle, truth: dict[str, float]) -> np.ndarray:
    """Angular acceleration per unit torque demand at hover, rad/s² (roll, pitch, yaw):
    coefficient × Σ_j (moment row_j × mixer column_j) × ∂f/∂m at hover."""
    layout = {"angles_deg": vehicle["frame"]["angles_deg"], "spin": vehicle["frame"]["spin"]}
    geom = geometry_rows(layout)
    mix = vehicle.mixer[:, 1:]
    x_h = truth["hover_command"] * (1 - truth["idle_ratio"]) + truth["idle_ratio"]
    dfdm = 2.0 * truth["k"] * x_h * (1.0 - truth["idle_ratio"])
    coef = np.array([truth["roll_effectiveness"], truth["pitch_effectiveness"],
                     truth["yaw_effectiveness"]])
    return coef * np.sum(geom.T * mix, axis=0) * dfdm
