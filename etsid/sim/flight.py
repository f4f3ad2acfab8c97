"""``simulate()``: fly a named scenario with a vehicle and return the logged flight."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid import progress
from etsid.errors import SimError
from etsid.sim.engine import MEAS_COLUMNS, ROTOR_BLOCKS, TRUTH_COLUMNS, advance, run_flight
from etsid.sim.params import LOG_MEAN, N_NOISE
from etsid.sim.plant import initial_state, make_plant, noise_levels, noise_std
from etsid.sim.scenarios import build_references, resolve_params
from etsid.sim.settings import split_settings
from etsid.sim.trim import hover_trim
from etsid.sim.vehicle import Vehicle, load_vehicle

MIN_PHYSICS_HZ = 1000.0
COMMAND_LOGS = ("sample", "mean")
"""What a log row's motor outputs may hold (:func:`simulate`'s ``command_log``)."""
MAX_SIM_BYTES = 2 * 2**30
"""Memory a simulation may take (arrays of every physics step): 3600 s at 250 Hz needs
about 0.6 GiB."""


def refuse_non_finite(table: pd.DataFrame, what: str,
                      hint: str = "check the vehicle's fields and the settings") -> None:
    """Refuse a simulated table holding a NaN or infinity: the physics left its domain.
    One check for every table the simulator writes (scenarios and ``--replay`` twins).

    Raises
    ------
    SimError
        Naming the first channel (in column order) that is not finite and the time, s.
    """
    values = table.to_numpy(dtype=float, na_value=np.nan)
    bad = ~np.isfinite(values)
    if not bad.any():
        return
    rows, cols = np.nonzero(bad)
    first = int(np.argmin(rows))
    share = 100.0 * bad.any(axis=1).mean()
    raise SimError(f"{what}: the simulation left the physics' domain: {table.columns[cols[first]]} "
                   f"is not finite from t = {table.index[rows[first]]:.3f} s ({share:.0f} % of "
                   f"the rows); {hint}")

PROGRESS_STEPS = 50
"""Pieces a flight is flown in when the CLI shows progress (the same flight, bit for bit)."""


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


def simulate(
    scenario: str,
    vehicle: str | Path | Vehicle | None = None,
    duration: float | None = None,
    seed: int = 0,
    ground_effect: bool = True,
    rate_hz: float = 250.0,
    settings: Mapping[str, Any] | None = None,
    command_log: str = "sample",
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
    settings : mapping, optional
        Dotted settings, the mechanism of ``etsid simulate --set``: ``vehicle.KEY`` changes
        the vehicle (an effect such as ``vehicle.thrust_scale``, ``vehicle.mass``,
        ``vehicle.rotor.radius``; see :meth:`Vehicle.with_settings`), ``scenario.KEY`` a
        scenario setting (``scenario.altitude``). Keyword overrides win over them.
    command_log : str
        What a row's motor outputs ``m1..mN`` hold: ``"sample"``, the command of the row's
        first control step (a logger's snapshot); ``"mean"``, the mean of the commands of
        the control steps in the row's period (what the motors received over it). The
        control loop answers gyro noise at the physics rate, so a snapshot carries command
        jitter that acted for one physics step but reads as held for a whole log period.
        The flight itself is the same either way.
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
    veh_settings, scen_settings = split_settings(settings)
    veh = load_vehicle(vehicle)
    if veh_settings:
        veh = veh.with_settings(veh_settings)
    params = resolve_params(scenario, duration, {**scen_settings, **scenario_params})
    if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
        raise SimError(f"rate_hz must be a positive number, got {rate_hz!r}")
    if not isinstance(seed, int | np.integer) or isinstance(seed, bool) or seed < 0:
        raise SimError(f"seed must be a non-negative integer, got {seed!r}")
    if command_log not in COMMAND_LOGS:
        raise SimError(f"command_log must be one of {', '.join(COMMAND_LOGS)}, "
                       f"got {command_log!r}")
    k_out = max(1, math.ceil(MIN_PHYSICS_HZ / rate_hz))
    dt = 1.0 / (rate_hz * k_out)
    n_out = round(params["duration"] * rate_hz)
    if n_out < 2:
        raise SimError(f"duration {params['duration']!r} s is too short for rate {rate_hz} Hz")
    n_steps = n_out * k_out
    need = n_steps * 8.0 * (N_NOISE + 12) + n_out * 8.0 * (60 + 6 * veh.n_rotors)
    if need > MAX_SIM_BYTES:
        raise SimError(f"{params['duration']:g} s at {rate_hz:g} Hz ({n_steps} physics steps) "
                       f"needs about {need / 2**30:.1f} GiB, more than the "
                       f"{MAX_SIM_BYTES / 2**30:.0f} GiB a simulation may use: fly a shorter "
                       "flight or a lower --rate")
    t = np.arange(n_steps) * dt

    alt0 = float(params["altitude"])
    trim_oge = hover_trim(veh)
    trim = hover_trim(veh, alt0) if ground_effect else trim_oge
    throttle = trim.command if params["throttle"] is None else float(params["throttle"])
    rng = np.random.default_rng(seed)
    refs = build_references(scenario, params, t, rng, throttle, hold=k_out)

    lv = noise_levels(veh)
    noise = rng.standard_normal((n_steps, N_NOISE)) * noise_std(veh)
    bias = rng.normal(0.0, lv["gyro_bias_std"], 3)  # drawn always: same stream either way
    if veh.effects["gyro_bias"] is not None:
        bias = np.asarray(veh.effects["gyro_bias"], dtype=float)
    plant = make_plant(veh, dt=dt, ground_effect=ground_effect, alt_hold=params["alt_hold"],
                       pilot=params["pilot"], wind=tuple(params["wind"]), gyro_bias=bias)
    plant.P[LOG_MEAN] = 1.0 if command_log == "mean" else 0.0
    S0 = initial_state(plant, alt0, ground_effect=ground_effect,
                       command=None if params["alt_hold"] else throttle)
    n_rot = veh.n_rotors
    args = (plant.P, plant.inertia, plant.rpos, plant.spin, plant.dists, plant.mix, refs.exc,
            refs.alt_sp, refs.alt_rate, refs.vel_sp, refs.thr_manual, np.zeros((0, n_rot)),
            noise, k_out, plant.rf_every)
    if progress.enabled():
        meas, truth = _fly_in_steps(S0, args, n_out, k_out, rate_hz, scenario)
    else:
        meas, truth = run_flight(S0, *args)
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
        "rotor_radius_m": float(veh.params["rotor"]["radius"]),
        "seed": int(seed),
        "ground_effect": bool(ground_effect),
        "rate_hz": float(rate_hz),
        "physics_hz": float(1.0 / dt),
        "command_log": command_log,
        "params": {k: v for k, v in params.items()},
        "noise": lv,
        "hover_command": float(trim_oge.command),
        # motor m(i+1) = rotor i: hub x, y (m, FRD), spin (+1 CCW seen from above)
        "motor_layout": {"x": veh.rotor_positions[:, 0].tolist(),
                         "y": veh.rotor_positions[:, 1].tolist(),
                         "spin": veh.spin.tolist()},
    }
    truth_df.attrs = dict(table.attrs)
    refuse_non_finite(table, f"scenario {scenario!r} with vehicle {veh.name!r}")
    return SimFlight(table=table, truth=truth_df, vehicle=veh, params=params)


def _fly_in_steps(S0: np.ndarray, args: tuple[Any, ...], n_out: int, k_out: int,
                  rate_hz: float, scenario: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`run_flight` in pieces of whole output rows, with progress in flight seconds.

    :func:`advance` continues from the state it leaves, so the rows are those of one call.
    """
    (P, inertia, rpos, spin, dists, mix, exc, alt_sp, alt_rate, vel_sp, thr_manual, motors,
     noise, _, rf_every) = args
    n_rot = rpos.shape[0]
    meas = np.empty((n_out, len(MEAS_COLUMNS) + n_rot))
    truth = np.empty((n_out, len(TRUTH_COLUMNS) + 5 * n_rot))
    S = S0.copy()
    rows = max(1, -(-n_out // PROGRESS_STEPS))
    seconds = round(n_out / rate_hz)
    with progress.progress(seconds, f"simulating {scenario} (flight s)", True) as bar:
        said = 0
        for a in range(0, n_out, rows):
            b = min(n_out, a + rows)
            i, j = a * k_out, b * k_out
            piece = motors[i:j] if len(motors) else motors
            advance(S, P, inertia, rpos, spin, dists, mix, exc[i:j], alt_sp[i:j],
                    alt_rate[i:j], vel_sp[i:j], thr_manual[i:j], piece, noise[i:j], k_out,
                    rf_every, meas[a:b], truth[a:b])
            now = round(b / rate_hz)
            bar.update(now - said)
            said = now
    return meas, truth
