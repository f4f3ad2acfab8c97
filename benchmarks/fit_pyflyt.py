"""Known-truth check of ``etsid fit`` on another simulator: PyFlyt's Crazyflie ``cf2x``
(issue 40).

    python benchmarks/fit_pyflyt.py --seeds 600 601

Each seed flies one 60 s hover of the PyFlyt set of ``benchmarks/thirdparty`` (PyFlyt's
own motor, thrust and drag laws, its cascade at 120 Hz on 240 Hz physics, the set's sensor
model and 1S battery; no physics effect) with its 3-2-1-1 system-identification inputs at
the mixer switched on. Those inputs are written to the table as ``u_roll u_pitch u_yaw``:
they are the known, noise-free commands the fit instruments its moment equations with (the
set's own tables carry no pilot command). The truths come from PyFlyt's parameters as the
flight used them: mass and inertia of the URDF (× the seed's spread), hub positions, thrust
and torque coefficients, top speed at the median pack voltage, and the motor ramp's time
constant as PyFlyt steps it (Euler at the physics rate: τ_eff = −dt / ln(1 − dt/τ)).
``time_delay``: truth −dt/2 of the physics step (−2.1 ms), from PyFlyt's step order (its
``Aviary.step``: control, motor step, state read, then ``stepSimulation``): the logged rates
are read before the control period's last physics step, half a control period early
(−h/2); the command is held over the period where the fit's law interpolates it (+h/2);
the Euler motor step applies each step's end value over the whole step (−dt/2). There is
no transport delay. Scored like
``benchmarks/fit.py``: a parameter called identified scores when the truth lies in its 95 %
interval and within its accuracy class.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from thirdparty import fit_truth
from thirdparty import pyflyt_pairs as pf
from thirdparty.common import to_table

DURATION = 60.0


def fly(seed: int) -> tuple[Any, dict[str, Any]]:
    """(FlightTable, PyFlyt's parameters as flown) of one excited hover."""
    from PyFlyt.core import Aviary

    rng = np.random.default_rng(seed)
    vehicle = pf.random_vehicle(rng)
    sens = pf.sensors(rng, False, {})
    cls = pf._quadx_class()
    env = Aviary(start_pos=np.array([[0.0, 0.0, 0.05]]), start_orn=np.zeros((1, 3)),
                 drone_type="effquad", drone_type_mappings={"effquad": cls},
                 drone_options={"control_hz": pf.CONTROL_HZ}, render=False,
                 physics_hz=pf.PHYSICS_HZ, seed=seed)
    try:
        drone = env.drones[0]
        base = np.array(env.getBasePositionAndOrientation(drone.Id)[0])
        hubs = np.array([env.getLinkState(drone.Id, i)[0] for i in drone.motors.motor_ids])
        pf.excite_flights = True
        rec = pf._fly(env, "hover", DURATION, rng, vehicle, {}, sens, seed)
        mass = float(env.getDynamicsInfo(drone.Id, -1)[0])
        inertia = np.asarray(drone.inertia, dtype=float)
        m = drone.motors
        truth_in = {"mass": mass, "inertia": inertia, "hubs_flu": hubs - base,
                    "thrust_coef": np.asarray(m.thrust_coef, dtype=float).ravel(),
                    "torque_coef": np.asarray(m.torque_coef, dtype=float).ravel(),
                    "max_rpm0": np.asarray(drone.max_rpm0, dtype=float).ravel(),
                    "tau": float(np.mean(m.tau)), "spin": np.asarray(drone.spin, dtype=float)}
    finally:
        pf.excite_flights = False
        env.disconnect()
    table = to_table(rec, sens, rng, f"pyflyt seed {seed}")
    inputs = pf.excitation(rec.t, (4.0, DURATION - 6.0), seed)
    # FLU mixer inputs → FRD commands (roll keeps its sign, pitch and yaw flip)
    for j, (name, sign) in enumerate((("u_roll", 1.0), ("u_pitch", -1.0), ("u_yaw", -1.0))):
        table[name] = sign * inputs[:, j]
    hubs = truth_in["hubs_flu"]
    # spin: +1 counter-clockwise seen from above, whose reaction torque is clockwise
    # (PyFlyt's torque coefficient is the reaction about FLU z: negative)
    table.attrs["motor_layout"] = {"x": hubs[:, 0].tolist(), "y": (-hubs[:, 1]).tolist(),
                                   "spin": (-truth_in["spin"]).tolist()}
    return table, truth_in


def truth_of(t: dict[str, Any], v0: float) -> dict[str, float]:
    """The fit's combinations from PyFlyt's parameters at pack voltage ``v0``."""
    g = 9.81
    mass, inertia = t["mass"], t["inertia"]
    top = float(np.mean(t["max_rpm0"])) * v0 / pf.V_REF
    kt = float(np.mean(t["thrust_coef"]))
    k = kt * top ** 2 / mass
    n = t["thrust_coef"].size
    x_h = math.sqrt(g / (k * n))
    arm = float(np.median(np.hypot(t["hubs_flu"][:, 0], t["hubs_flu"][:, 1])))
    kappa = float(np.mean(np.abs(t["torque_coef"]))) / kt
    dt = 1.0 / pf.PHYSICS_HZ
    eff = {"roll": mass * arm / inertia[0], "pitch": mass * arm / inertia[1],
           "yaw": mass * kappa / inertia[2]}
    dfdm = 2.0 * k * x_h
    return {"hover_command": x_h, "thrust_to_weight": k * n / g, "idle_ratio": 0.0,
            "motor_time_constant": -dt / math.log(1.0 - dt / t["tau"]),
            "time_delay": -0.5 * dt,
            **{f"{a}_effectiveness": e for a, e in eff.items()},
            **{f"{a}_accel_per_command": e * dfdm for a, e in eff.items()},
            "inertia_ratio_yx": inertia[1] / inertia[0]}


if __name__ == "__main__":
    fit_truth.main(__doc__.splitlines()[0], fly, truth_of, [600, 601])
