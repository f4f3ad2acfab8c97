"""Known-truth check of ``etsid fit`` on a third simulator: the ``multirotor`` package's
Tarot T18 octocopter (issue 40).

    python benchmarks/fit_multirotor.py --seeds 700 701

Each seed flies one 60 s hover of the octocopter set of ``benchmarks/thirdparty`` (the
package's k ω² thrust and k_d ω² yaw torque, its ArduPilot-style cascade at 100 Hz, the
set's 40 ms rotor lag, quadratic body drag, 6S battery and sensor model; no physics effect).
The set's flights have no pilot input and no system-identification injection, so the fit
runs uninstrumented (it says so); the motor outputs are the controller's own outputs at the
log's rate, without sampling jitter. Truths from the package's parameters as flown: mass and
inertia (× the seed's spread), hub positions and spins, thrust and drag coefficients, top
speed OMEGA_MAX × V0 / V_REF, no idle offset (a command floor is not an idle speed: the rotor
speed is the command × V / V_REF), and the rotor lag as the set steps it (Euler over 10 ms:
τ_eff = −dt / ln(1 − dt/τ)). The log stamps each state after the step its
command already drove, so the rotors lead the logged command by one log period: the truth
of ``time_delay`` is minus that period (no transport delay). Scored like ``benchmarks/fit.py``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from thirdparty import fit_truth
from thirdparty import multirotor_pairs as mp
from thirdparty.common import to_table

DURATION = 60.0


def fly(seed: int) -> tuple[Any, dict[str, Any]]:
    """(FlightTable, the package's parameters as flown) of one hover."""
    from multirotor.models.tarott18 import VP

    rng = np.random.default_rng(seed)
    vehicle = mp.random_vehicle(rng)
    sens = mp.sensors(rng, False, {})
    rec = mp.fly("hover", DURATION, seed, vehicle, {}, sens)
    table = to_table(rec, sens, rng, f"multirotor seed {seed}")
    arms = np.asarray(VP.propeller_vectors, dtype=float).T       # (n, 3) FLU
    spin = -np.asarray(VP.clockwise, dtype=float)                 # +1 counter-clockwise
    table.attrs["motor_layout"] = {"x": arms[:, 0].tolist(), "y": (-arms[:, 1]).tolist(),
                                   "spin": spin.tolist()}
    truth_in = {"mass": VP.mass * vehicle["mass"],
                "inertia": np.diag(np.asarray(VP.inertia_matrix, dtype=float)) *
                vehicle["inertia"], "arm": float(np.median(np.hypot(arms[:, 0], arms[:, 1]))),
                "k_thrust": float(np.mean([p.k_thrust for p in VP.propellers])),
                "k_drag": float(np.mean([p.k_drag for p in VP.propellers])),
                "n": arms.shape[0]}
    return table, truth_in


def truth_of(t: dict[str, Any], v0: float) -> dict[str, float]:
    """The fit's combinations from the package's parameters at pack voltage ``v0``."""
    g = 9.81
    mass, inertia, n = t["mass"], t["inertia"], t["n"]
    top = mp.OMEGA_MAX * v0 / mp.V_REF
    k = t["k_thrust"] * top ** 2 / mass
    x_h = math.sqrt(g / (k * n))
    eff = {"roll": mass * t["arm"] / inertia[0], "pitch": mass * t["arm"] / inertia[1],
           "yaw": mass * t["k_drag"] / t["k_thrust"] / inertia[2]}
    dfdm = 2.0 * k * x_h
    return {"hover_command": x_h, "thrust_to_weight": k * n / g, "idle_ratio": 0.0,
            "motor_time_constant": -mp.DT / math.log(1.0 - mp.DT / mp.MOTOR_TAU),
            "time_delay": -mp.DT,
            **{f"{a}_effectiveness": e for a, e in eff.items()},
            **{f"{a}_accel_per_command": e * dfdm for a, e in eff.items()},
            "inertia_ratio_yx": inertia[1] / inertia[0]}


if __name__ == "__main__":
    fit_truth.main(__doc__.splitlines()[0], fly, truth_of, [700, 701])
