"""``simulate()``: fly a named scenario with a vehicle and return the logged flight."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import SimError
from etsid.sim.controller import CS_IVZ, INT_LIMIT, N_CS
from etsid.sim.engine import MEAS_COLUMNS, ROTOR_BLOCKS, TRUTH_COLUMNS, run_flight
from etsid.sim.params import (
    N_NOISE,
    NZ_ACC,
    NZ_ALT,
    NZ_ATT,
    NZ_GYRO,
    NZ_VBAT,
    NZ_VEL,
    X_OM,
    X_POS,
    X_Q,
    X_SOC,
    geometry,
    pack,
)
from etsid.sim.scenarios import build_references, resolve_params
from etsid.sim.trim import hover_trim
from etsid.sim.vehicle import Vehicle, load_vehicle

MIN_PHYSICS_HZ = 1000.0
NO_PILOT = {"pilot_kv": 0.0, "pilot_ki": 0.0, "pilot_kpsi": 0.0}


@dataclass
class SimFlight:
    """A simulated flight.

    Attributes
    ----------
    table : pandas.DataFrame
        FlightTable of measured (noisy) signals, index ``t`` in s.
    truth : pandas.DataFrame
        Noise-free states on the same index, columns prefixed ``true_``.
    vehicle : Vehicle
        The vehicle flown.
    params : dict
        Resolved scenario settings.
    """

    table: pd.DataFrame
    truth: pd.DataFrame
    vehicle: Vehicle
    params: dict[str, Any]


def _noise_levels(vehicle: Vehicle) -> dict[str, float]:
    s = vehicle["sensors"]
    return {k: float(s[k]) for k in ("gyro_std", "gyro_bias_std", "accel_std", "att_std",
                                       "vel_std", "alt_std", "vbat_std", "rangefinder_hz")}


def simulate(
    scenario: str,
    vehicle: str | Path | Vehicle | None = None,
    duration: float | None = None,
    seed: int = 0,
    ground_effect: bool = True,
    rate_hz: float = 250.0,
    **scenario_params: Any,
) -> SimFlight:
    """Fly ``scenario`` closed loop and log it like a flight controller would.

    Parameters
    ----------
    scenario : str
        Name in :data:`etsid.sim.SCENARIOS` (``hover-ige``, ``hover-oge``,
        ``sine-altitude``, ``forward-flight``, ``steps``).
    vehicle : str, Path, Vehicle or None
        Packaged vehicle name, TOML file or :class:`Vehicle`; None is ``tarot680``.
    duration : float, optional
        Flight length, s (default: the scenario's).
    seed : int
        Seed of every random part (excitation noise, sensor noise, gyro bias); the same
        seed gives bit-identical tables.
    ground_effect : bool
        Apply the vehicle's ground-effect model.
    rate_hz : float
        Logging rate of the table, Hz. Physics and control run at an integer multiple
        of it, at least 1000 Hz, with RK4.
    **scenario_params
        Overrides of the scenario's settings (see ``SCENARIOS[name]["params"]``).

    Returns
    -------
    SimFlight
        Measured table, true states, vehicle and settings.

    Raises
    ------
    SimError
        Unknown scenario or setting, invalid vehicle file or rate.
    """
    veh = load_vehicle(vehicle)
    params = resolve_params(scenario, duration, scenario_params)
    if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
        raise SimError(f"rate_hz must be a positive number, got {rate_hz!r}")
    if not isinstance(seed, int | np.integer) or isinstance(seed, bool) or seed < 0:
        raise SimError(f"seed must be a non-negative integer, got {seed!r}")
    k_out = max(1, math.ceil(MIN_PHYSICS_HZ / rate_hz))
    dt = 1.0 / (rate_hz * k_out)
    n_out = round(params["duration"] * rate_hz)
    if n_out < 2:
        raise SimError(f"duration {params['duration']!r} s is too short for rate {rate_hz} Hz")
    n_steps = n_out * k_out
    t = np.arange(n_steps) * dt

    alt0 = float(params["altitude"])
    trim_oge = hover_trim(veh)
    trim = hover_trim(veh, alt0) if ground_effect else trim_oge
    throttle = trim.command if params["throttle"] is None else float(params["throttle"])
    rng = np.random.default_rng(seed)
    refs = build_references(scenario, params, t, rng, throttle, hold=k_out)

    P = pack(veh, dt=dt, ground_effect=ground_effect, thr_hover=trim_oge.command,
             alt_hold=params["alt_hold"], wind=tuple(params["wind"]),
             **({} if params["pilot"] else NO_PILOT))
    pos, spin, dists, mix = geometry(veh)
    n_rot = veh.n_rotors
    x0 = np.zeros(X_OM + n_rot)
    x0[X_POS + 2] = -alt0
    x0[X_Q] = 1.0
    x0[X_SOC] = veh["battery"]["soc0"]
    x0[X_OM:] = trim.omega
    cs0 = np.zeros(N_CS)
    cs0[CS_IVZ] = np.clip(trim.command - trim_oge.command, -INT_LIMIT, INT_LIMIT)
    lam0 = np.full(n_rot, trim.lam_i)

    lv = _noise_levels(veh)
    std = np.zeros(N_NOISE)
    std[NZ_GYRO:NZ_GYRO + 3] = lv["gyro_std"]
    std[NZ_ATT:NZ_ATT + 3] = lv["att_std"]
    std[NZ_VEL:NZ_VEL + 3] = lv["vel_std"]
    std[NZ_ALT] = lv["alt_std"]
    std[NZ_ACC:NZ_ACC + 3] = lv["accel_std"]
    std[NZ_VBAT] = lv["vbat_std"]
    noise = rng.standard_normal((n_steps, N_NOISE)) * std
    bias = rng.normal(0.0, lv["gyro_bias_std"], 3)
    rf_every = max(1, round(1.0 / (lv["rangefinder_hz"] * dt)))

    meas, truth = run_flight(x0, P, veh.inertia, pos, spin, dists, mix, lam0, cs0, refs.exc,
                             refs.alt_sp, refs.alt_rate, refs.vel_sp, refs.thr_manual, noise,
                             bias, k_out, rf_every)
    index = pd.Index(np.arange(n_out) / rate_hz, name="t")
    motors = [f"m{i + 1}" for i in range(n_rot)]
    table = pd.DataFrame(meas, index=index, columns=[*MEAS_COLUMNS, *motors])
    rotor_cols = [f"true_{b}{i + 1}" for b in ROTOR_BLOCKS for i in range(n_rot)]
    truth_df = pd.DataFrame(truth, index=index.copy(),
                            columns=[*(f"true_{c}" for c in TRUTH_COLUMNS), *rotor_cols])
    truth_df["true_alt_sp"] = refs.alt_sp[::k_out]
    lv["gyro_bias"] = [float(b) for b in bias]
    table.attrs = {
        "source": "etsid.sim",
        "format": "sim",
        "scenario": scenario,
        "vehicle": veh.name,
        "seed": int(seed),
        "ground_effect": bool(ground_effect),
        "rate_hz": float(rate_hz),
        "physics_hz": float(1.0 / dt),
        "params": {k: v for k, v in params.items()},
        "noise": lv,
        "hover_command": float(trim_oge.command),
    }
    truth_df.attrs = dict(table.attrs)
    return SimFlight(table=table, truth=truth_df, vehicle=veh, params=params)
