"""Hover trim: rotor speed, induced velocity and collective command for steady hover."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from etsid.errors import SimError
from etsid.sim.ground import CHEESEMAN_BENNETT, SANCHEZ_CUEVAS, ground_ratio
from etsid.sim.params import open_circuit_voltage
from etsid.sim.rotor import ground_effect_torque, hover_omega, rotor_forces
from etsid.sim.vehicle import Vehicle


@dataclass(frozen=True)
class HoverTrim:
    """Steady level hover of a vehicle (all rotors equal)."""

    omega: float      # rotor speed, rad/s
    thrust: float     # thrust per rotor including ground effect, N
    torque: float     # shaft torque per rotor, N m
    v_i: float        # induced velocity (out of ground effect solution), m/s
    lam_i: float      # induced inflow ratio v_i/(ΩR)
    ge_ratio: float   # T_IGE/T_OGE at the hover height (1 without ground effect)
    vbat: float       # battery voltage at the hover current, V
    command: float    # motor command 0..1 giving omega at vbat


def hover_trim(vehicle: Vehicle, height: float | None = None) -> HoverTrim:
    """Trim ``vehicle`` for level hover, optionally in ground effect.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.
    height : float, optional
        CG height above ground, m; None means out of ground effect.

    Returns
    -------
    HoverTrim
        Rotor speed where N·T = m g, with T = thrust_scale · ratio · T_OGE(Ω) (the
        vehicle's effects included: thrust and torque scale, ground-effect torque).
    """
    r = vehicle["rotor"]
    env = vehicle["environment"]
    n = vehicle.n_rotors
    weight_share = vehicle.mass * env["gravity"] / n
    ratio = 1.0
    if height is not None:
        g = vehicle["ground"]
        pos = vehicle.rotor_positions
        model = SANCHEZ_CUEVAS if g["model"] == "sanchez-cuevas" else CHEESEMAN_BENNETT
        dists = np.sqrt(np.sum((pos[:, None, :2] - pos[None, :, :2]) ** 2, axis=-1))
        ratio = ground_ratio(height - pos[0, 2], r["radius"], model, dists[0],
                             float(np.hypot(pos[0, 0], pos[0, 1])), g["k_body"],
                             g["min_height_ratio"], g["max_ratio"])
    args = (env["air_density"], r["radius"], vehicle.solidity, r["lift_slope"],
            vehicle.theta_0, r["twist"])
    fx = vehicle.effects
    try:
        omega = hover_omega(weight_share / (ratio * fx["thrust_scale"]), *args)
    except ValueError as err:  # brentq: no rotor speed up to its bracket gives the thrust
        raise SimError(f"vehicle {vehicle.name!r}: its rotors cannot lift {vehicle.mass:g} kg "
                       "(no hover rotor speed); check mass and rotor fields") from err
    t_oge, torque, lam = rotor_forces(omega, 0.0, 0.0, *args, r["cd0"], r["kappa"], 0.05)
    if fx["ground_effect_torque"] and ratio != 1.0:
        torque = ground_effect_torque(t_oge, lam, ratio, omega, 0.0, 0.0, env["air_density"],
                                      r["radius"], vehicle.solidity, r["lift_slope"], r["cd0"],
                                      r["kappa"])
    torque *= fx["torque_scale"]
    m = vehicle["motor"]
    b = vehicle["battery"]
    voc = open_circuit_voltage(b["cells"], b["soc0"])
    vbat = voc
    if b["sag"]:
        vbat = voc - b["r_internal"] * n * torque * omega / (b["efficiency"] * voc)
    top = m["omega_max"] * vbat / m["v_ref"]
    if omega >= top:
        raise SimError(f"vehicle {vehicle.name!r}: its rotors cannot lift {vehicle.mass:g} kg "
                       f"at full command (hover needs {omega:.0f} rad/s, the motors reach "
                       f"{top:.0f} rad/s at {vbat:.1f} V); check mass, rotor and motor fields")
    command = (omega - m["omega_idle"]) / (top - m["omega_idle"])
    return HoverTrim(omega=omega, thrust=t_oge * ratio * fx["thrust_scale"], torque=torque,
                     v_i=lam * omega * r["radius"], lam_i=lam, ge_ratio=ratio, vbat=vbat,
                     command=command)


def momentum_hover_velocity(thrust: float, rho: float, radius: float) -> float:
    """Momentum-theory hover induced velocity sqrt(T / (2 ρ A)), m/s."""
    return math.sqrt(thrust / (2.0 * rho * math.pi * radius**2))
