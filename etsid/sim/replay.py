"""Replay: drive the simulated vehicle with a recorded flight's commands (its "twin").

Two modes, both through the compiled loop of :mod:`etsid.sim.engine`:

* ``mode="loop"`` — the recorded loop commands (sticks ``u_roll u_pitch u_yaw``, or rate
  setpoints ``sp_p sp_q sp_r``, or torque demands) go through the simulator's own
  angle/rate loops and mixer, the simulated pilot off; the collective is the recorded
  ``u_thrust`` straight to the mixer (``thrust="command"``) or the simulator's altitude
  hold tracking the recorded altitude (``thrust="alt_hold"``). One run from the log's
  first sample.
* ``mode="motors"`` — the recorded motor outputs ``m1..mN`` open loop, over horizons of
  ``horizon`` seconds, each re-initialised from the recorded state (open-loop attitude
  drifts within seconds).

Commands are held between log samples (zero-order hold); physics runs at the smallest
integer multiple of the log rate ≥ 1000 Hz. What comes from where is in
:attr:`ReplayResult.sources`: a log has no pilot model, no controller gains and no rotor
speeds; those are the vehicle file's. :func:`replay_many` runs many candidate vehicles at
once (numba ``prange``, common random numbers) for fitting by simulation.

This module takes a FlightTable; reading log files is the CLI's job.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import SimError
from etsid.sim.body import euler_to_quat
from etsid.sim.engine import MEAS_COLUMNS, ROTOR_BLOCKS, TRUTH_COLUMNS, state_offsets
from etsid.sim.estimator import EST_Q, EST_V
from etsid.sim.jobs import advance_jobs, motor_speed_history
from etsid.sim.params import (
    CELLS,
    DELAY,
    LOOP_MOTORS,
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
    X_VEL,
    X_W,
)
from etsid.sim.plant import Plant, initial_state, make_plant
from etsid.sim.stepper import LOOP_INPUTS
from etsid.sim.vehicle import Vehicle, load_vehicle, resolve_vehicle_key

MODES = ("loop", "motors")
THRUST_MODES = ("command", "alt_hold")
MIN_PHYSICS_HZ = 1000.0
COMMAND_COLUMNS = {"sticks": ("u_roll", "u_pitch", "u_yaw"), "rates": ("sp_p", "sp_q", "sp_r"),
                   "torque": ("u_roll", "u_pitch", "u_yaw")}


@dataclass
class ReplayResult:
    """A recorded flight's simulated twin.

    Attributes
    ----------
    table : pandas.DataFrame
        The twin's measured signals on the log's time index (FlightTable columns).
    truth : pandas.DataFrame
        The twin's true states (``true_*``), same index.
    vehicle : Vehicle
        The vehicle flown.
    mode, loop_input, thrust : str
        How it was driven.
    sources : dict
        For each part of the twin, where it came from (the log or the vehicle file).
    errors : dict
        Per channel present in both: ``rmse`` (twin − log, in the channel's unit), ``std``
        of the log and ``ratio`` = rmse / std.
    horizons : ndarray
        Start times of the re-initialisations, s (``[t0]`` in loop mode).
    divergence : dict or None
        Where the twin leaves the recording (:func:`divergence`): ``t`` (s from the start),
        ``what`` differs there, ``ground_t`` when it ends on the ground while the log flies.
    """

    table: pd.DataFrame
    truth: pd.DataFrame
    vehicle: Vehicle
    mode: str
    loop_input: str
    thrust: str
    sources: dict[str, str] = field(default_factory=dict)
    errors: dict[str, dict[str, float]] = field(default_factory=dict)
    horizons: np.ndarray = field(default_factory=lambda: np.zeros(0))
    divergence: dict[str, Any] | None = None


NOISE_COLUMNS = {"p": NZ_GYRO, "q": NZ_GYRO + 1, "r": NZ_GYRO + 2, "roll": NZ_ATT,
                 "pitch": NZ_ATT + 1, "yaw": NZ_ATT + 2, "vx": NZ_VEL, "vy": NZ_VEL + 1,
                 "vz": NZ_VEL + 2, "alt": NZ_ALT, "ax": NZ_ACC, "ay": NZ_ACC + 1,
                 "az": NZ_ACC + 2, "vbat": NZ_VBAT}
"""Log column → the simulator's measurement-noise column it sets (:func:`log_noise_std`)."""


def log_noise_std(table: pd.DataFrame, fallback: np.ndarray) -> np.ndarray:
    """(N_NOISE,) white-noise standard deviation of each sensor of a log, from its
    second differences (``var(x[k+1] − 2x[k] + x[k−1]) = 6 σ²`` for white noise; the
    median absolute deviation keeps manoeuvres out). ``fallback`` where the log lacks a
    column or it is quantised flat."""
    std = np.array(fallback, dtype=float)
    for column, i in NOISE_COLUMNS.items():
        if column not in table:
            continue
        x = table[column].to_numpy(dtype=float)
        if column == "yaw":
            x = np.unwrap(x[np.isfinite(x)])
        x = x[np.isfinite(x)]
        if x.size < 20:
            continue
        d2 = np.diff(x, 2)
        sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
        if sigma > 0:
            std[i] = sigma
    return std


DIVERGE_ALT_M = 5.0
DIVERGE_ANGLE_RAD = math.radians(30.0)
"""A twin has diverged where its altitude is this far from the recording's, or its roll or
pitch this far (after its first second: the loops settle), or it is on the ground while the
recording flies. The altitude limit is wide: with the recorded collective replayed open
loop, an exact twin of etsid's own hover drifts about 2 m in 20 s."""


def divergence(twin: pd.DataFrame, table: pd.DataFrame) -> dict[str, Any] | None:
    """Where the twin leaves the recording: the first time (s) its altitude or attitude is
    beyond :data:`DIVERGE_ALT_M` / :data:`DIVERGE_ANGLE_RAD` of the log's, what differs
    there, and whether it ends on the ground while the log is airborne. None if it follows."""
    t = np.asarray(twin.index, dtype=float)
    settle = t >= t[0] + 1.0
    bad = np.zeros(t.size, dtype=bool)
    what = np.full(t.size, "", dtype=object)
    for col, limit, unit in (("alt", DIVERGE_ALT_M, "m"), ("roll", DIVERGE_ANGLE_RAD, "rad"),
                             ("pitch", DIVERGE_ANGLE_RAD, "rad")):
        if col not in twin or col not in table:
            continue
        diff = twin[col].to_numpy(dtype=float) - table[col].to_numpy(dtype=float)
        if col != "alt":
            diff = np.angle(np.exp(1j * diff))
        off = settle & np.isfinite(diff) & (np.abs(diff) > limit)
        what[off & ~bad] = [f"{col} {v:+.2f} {unit} from the recording" for v in diff[off & ~bad]]
        bad |= off
    ground_t = None
    if "alt" in twin and "alt" in table:
        alt_twin, alt_log = twin["alt"].to_numpy(float), table["alt"].to_numpy(float)
        # resting: within 5 cm of its lowest height and still (1 s spread below 2 cm)
        span = pd.Series(alt_twin).rolling(max(int(1.0 / np.median(np.diff(t))), 2),
                                           min_periods=2)
        still = (span.max() - span.min()).to_numpy() < 0.02
        base = float(np.nanmin(alt_twin))
        down = np.flatnonzero(settle & still & (alt_twin < base + 0.05)
                              & (alt_log > base + 0.5))
        if down.size:
            ground_t = int(down[0])
            if not bad[ground_t]:
                what[ground_t] = (f"on the ground while the recording is at "
                                  f"{alt_log[ground_t]:.2f} m")
            bad[ground_t] = True
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad)[0])
    out: dict[str, Any] = {"t": float(t[i] - t[0]), "what": str(what[i])}
    if ground_t is not None:
        out["ground_t"] = float(t[ground_t] - t[0])
    return out


def uniform_grid(table: pd.DataFrame) -> tuple[pd.DataFrame, str | None]:
    """The table on a uniform grid at its median period (linear interpolation; booleans
    held), and a note saying so, or the table itself and None when it already is."""
    t = np.asarray(table.index, dtype=float)
    if t.size < 2:
        return table, None
    d = np.diff(t)
    period = float(np.median(d))
    if period > 0 and np.max(np.abs(d - period)) <= 1e-6 * period + 1e-9:
        return table, None
    grid = np.arange(t[0], t[-1] + 0.5 * period, period)
    cols = {}
    for c in table.columns:
        v = table[c]
        if v.dtype == bool:
            idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1)
            cols[c] = v.to_numpy()[idx]
            continue
        x = v.to_numpy(dtype=float)
        ok = np.isfinite(x)
        cols[c] = np.interp(grid, t[ok], x[ok]) if ok.sum() >= 2 else np.full(grid.size, np.nan)
    out = pd.DataFrame(cols, index=pd.Index(grid, name="t"))
    out.attrs = dict(table.attrs)
    return out, (f"time grid: the log's samples are not evenly spaced; resampled to "
                 f"{1.0 / period:.4g} Hz (its median period) by linear interpolation")


def _grid(table: pd.DataFrame) -> tuple[np.ndarray, float]:
    t = np.asarray(table.index, dtype=float)
    if t.size < 2:
        raise SimError("replay: the table has fewer than two samples")
    d = np.diff(t)
    period = float(np.median(d))
    if period <= 0 or np.max(np.abs(d - period)) > 1e-6 * max(period, 1e-9) + 1e-9:
        raise SimError("replay: the table is not on a uniform time grid (a FlightTable "
                       "from etsid ingest is; resample it first)")
    return t, period


def _column(table: pd.DataFrame, name: str, default: float | None, sources: dict[str, str],
            what: str) -> np.ndarray:
    """A column with gaps filled (held), or ``default`` everywhere; records its source."""
    if name in table and table[name].notna().any():
        return table[name].ffill().bfill().to_numpy(dtype=float)
    if default is None:
        raise SimError(f"replay: the table has no '{name}' column ({what})")
    sources[name] = f"not in the log: {default:g} assumed"
    return np.full(len(table), float(default))


def _initial_state(plant: Plant, table_vals: dict[str, np.ndarray], row: int,
                   omega: np.ndarray | None, ground_effect: bool, capacity: int,
                   history: np.ndarray | None) -> np.ndarray:
    """Full state at log row ``row``: recorded attitude, rates, velocity, altitude, battery;
    rotor speeds from the motor history; delay line from the recorded commands."""
    n_rot = plant.n_rotors
    alt = float(table_vals["alt"][row])
    S = initial_state(plant, max(alt, 1e-3), ground_effect=ground_effect)
    _, _, o_est, _, o_buf = state_offsets(n_rot)
    if S.size != o_buf + capacity * n_rot:
        S = np.concatenate([S[:o_buf], np.full(capacity * n_rot, S[o_buf])])
    q = euler_to_quat(table_vals["roll"][row], table_vals["pitch"][row], table_vals["yaw"][row])
    S[X_Q:X_Q + 4] = q
    S[o_est + EST_Q:o_est + EST_Q + 4] = q
    for j, name in enumerate(("p", "q", "r")):
        S[X_W + j] = table_vals[name][row]
    for j, name in enumerate(("vx", "vy", "vz")):
        S[X_VEL + j] = table_vals[name][row]
        S[o_est + EST_V + j] = table_vals[name][row]
    v = table_vals["vbat"][row]
    if np.isfinite(v):
        cells = plant.P[CELLS]
        S[X_SOC] = min(max((v / cells - 3.5) / 0.7, 0.0), 1.0)
    if omega is not None:
        S[X_OM:X_OM + n_rot] = omega[row]
    if history is not None:
        S[o_buf:] = history.ravel()
    S[X_POS + 2] = -alt
    return S


def _sources(mode: str, loop_input: str, thrust: str, ground_effect: bool, noise: bool | str,
             vehicle: Vehicle) -> dict[str, str]:
    src = {
        "initial state": "log: roll pitch yaw, p q r, vx vy vz, alt, vbat (state of charge "
                         "from the open-circuit law); position x y = 0",
        "rotor speeds": "vehicle file: recorded motor outputs through its motor model "
                        "(not in the log)",
        "physics": f"vehicle file {vehicle.source}: mass, inertia, rotors, drag, battery, "
                   f"effects; ground effect {'on' if ground_effect else 'off'}",
        "sensors": {"log": "the log's own sensor noise (estimated from its sample-to-sample "
                           "variation; the vehicle file's where the log lacks a sensor)",
                    "vehicle": "vehicle file noise levels", True: "vehicle file noise levels"
                    }.get(noise, "exact (noise off)"),
        "pilot": "none (the recorded commands replace it)",
    }
    if mode == "loop":
        cols = ", ".join(COMMAND_COLUMNS[loop_input])
        src["loop commands"] = f"log: {cols} as {loop_input}, held between samples"
        src["controller"] = ("vehicle file: the simulator's own angle/rate loops, gains and "
                             "mixer (the real autopilot's are unknown); integrators start "
                             "at zero")
        src["collective"] = ("log: u_thrust straight to the mixer" if thrust == "command"
                             else "vehicle file: the simulator's altitude hold tracking the "
                                  "recorded alt")
    else:
        src["motor outputs"] = "log: m1..mN open loop, held between samples"
        src["controller"] = "none (open loop)"
    return src


@dataclass
class _Prepared:
    plant: Plant
    vehicle: Vehicle
    t: np.ndarray
    period: float
    k_out: int
    vals: dict[str, np.ndarray]
    motors: np.ndarray | None
    sources: dict[str, str]


def _prepare(table: pd.DataFrame, vehicle: Vehicle, mode: str, loop_input: str, thrust: str,
             ground_effect: bool, noise: bool | str) -> _Prepared:
    if mode not in MODES:
        raise SimError(f"replay: mode must be one of {', '.join(MODES)}, got {mode!r}")
    if thrust not in THRUST_MODES:
        raise SimError(f"replay: thrust must be one of {', '.join(THRUST_MODES)}, "
                       f"got {thrust!r}")
    if loop_input not in COMMAND_COLUMNS:
        raise SimError(f"replay: loop_input must be one of {', '.join(COMMAND_COLUMNS)}, "
                       f"got {loop_input!r}")
    t, period = _grid(table)
    k_out = max(1, math.ceil(MIN_PHYSICS_HZ * period - 1e-9))
    dt = period / k_out
    sources: dict[str, str] = {}
    vals: dict[str, np.ndarray] = {}
    for name in ("roll", "pitch", "yaw", "alt"):
        vals[name] = _column(table, name, None, sources, "needed for the initial state")
    for name in ("p", "q", "r", "vx", "vy", "vz"):
        vals[name] = _column(table, name, 0.0, sources, "")
    vals["vbat"] = (table["vbat"].ffill().bfill().to_numpy(dtype=float) if "vbat" in table
                    and table["vbat"].notna().any() else np.full(len(table), np.nan))
    n_rot = vehicle.n_rotors
    motor_cols = [f"m{i}" for i in range(1, n_rot + 1)]
    motors = None
    logged = [c for c in table if c.startswith("m") and c[1:].isdigit()
              and table[c].notna().any()]
    if len(logged) >= 3 and len(logged) != n_rot:
        raise SimError(f"replay: the log has {len(logged)} motor outputs but the vehicle "
                       f"{vehicle.name!r} has {n_rot} rotors; a twin needs a vehicle file "
                       f"with {len(logged)} rotors (--vehicle)")
    if all(c in table and table[c].notna().any() for c in motor_cols):
        motors = table[motor_cols].ffill().bfill().to_numpy(dtype=float)
    elif mode == "motors":
        raise SimError(f"replay: mode 'motors' needs the motor outputs {', '.join(motor_cols)}")
    if mode == "loop":
        for name in COMMAND_COLUMNS[loop_input]:
            vals[name] = _column(table, name, None, sources, f"loop input {loop_input}")
        if thrust == "command":
            vals["u_thrust"] = _column(table, "u_thrust", None, sources, "collective")
    plant = make_plant(vehicle, dt=dt, ground_effect=ground_effect,
                       alt_hold=mode == "loop" and thrust == "alt_hold", pilot=False,
                       loop_input=LOOP_MOTORS if mode == "motors" else LOOP_INPUTS[loop_input])
    if noise == "log":
        plant.noise_std = log_noise_std(table, plant.noise_std)
    elif noise in (False, "none"):
        plant.noise_std = np.zeros(N_NOISE)
    sources = {**_sources(mode, loop_input, thrust, ground_effect, noise, vehicle), **sources}
    return _Prepared(plant, vehicle, t, period, k_out, vals, motors, sources)


def _vehicle(vehicle: str | Path | Vehicle | None, settings: Mapping[str, Any] | None
             ) -> Vehicle:
    veh = load_vehicle(vehicle)
    if settings:
        clean = {str(k).removeprefix("vehicle."): v for k, v in settings.items()}
        for key in clean:
            resolve_vehicle_key(key)
        veh = veh.with_settings(clean)
    return veh


def _delayed(motors: np.ndarray, delay_samples: float) -> np.ndarray:
    """Held motor commands as the motors see them ``delay_samples`` log samples later
    (the mean over each sample of the shifted held signal)."""
    lag = math.floor(delay_samples)
    frac = delay_samples - lag
    n = motors.shape[0]
    pad = np.vstack([np.repeat(motors[:1], lag + 1, axis=0), motors])  # pad[i+1] = m[i-lag]
    return np.ascontiguousarray((1.0 - frac) * pad[1:n + 1] + frac * pad[:n])


def _jobs(prep: _Prepared, plant: Plant, mode: str, horizon: float, ground_effect: bool,
          capacity: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial states, physics-step ranges and start rows of the runs of one candidate."""
    n_rows = prep.t.size
    k = prep.k_out
    vbat = prep.vals["vbat"]
    omega = None
    if prep.motors is not None:
        v_hist = np.where(np.isfinite(vbat), vbat, plant.P[CELLS] * 4.165)
        omega = motor_speed_history(_delayed(prep.motors, float(plant.P[DELAY]) / k), v_hist,
                                    plant.P, prep.period)
    span = n_rows if mode == "loop" else max(1, round(horizon / prep.period))
    starts = np.arange(0, n_rows, span)
    slot = np.arange(capacity)
    steps_back = np.where(slot == 0, 0, capacity - slot)  # slot cap-s: s physics steps ago
    S0, a, b = [], [], []
    for row in starts:
        history = None
        if prep.motors is not None:
            rows = np.clip(row - np.ceil(steps_back / k).astype(int), 0, n_rows - 1)
            history = prep.motors[rows] if mode == "motors" else prep.motors[np.zeros_like(rows)]
        S0.append(_initial_state(plant, prep.vals, int(row), omega, ground_effect, capacity,
                                 history))
        a.append(int(row) * k)
        b.append(min(int(row) + span, n_rows) * k)
    return np.array(S0), np.array(a, dtype=np.int64), np.array(b, dtype=np.int64), starts


def _inputs(prep: _Prepared, mode: str, loop_input: str, thrust: str
            ) -> tuple[np.ndarray, ...]:
    k = prep.k_out
    n = prep.t.size * k
    n_rot = prep.vehicle.n_rotors
    hold = lambda x: np.ascontiguousarray(np.repeat(x, k, axis=0))  # noqa: E731

    def ramp(x: np.ndarray) -> np.ndarray:
        """Loop commands between log samples: linear from each sample to the next (the
        sticks are samples of a continuous signal; holding them delays it by half a log
        period, 10 ms at 50 Hz)."""
        steps = np.arange(n) / k
        cols = np.atleast_2d(np.asarray(x, dtype=float).T)
        out = np.column_stack([np.interp(steps, np.arange(col.size), col) for col in cols])
        return np.ascontiguousarray(out if np.ndim(x) > 1 else out[:, 0])

    exc = np.zeros((n, 3))
    thr = np.zeros(n)
    alt_sp = np.zeros(n)
    alt_rate = np.zeros(n)
    motors = np.zeros((0, n_rot))
    if mode == "loop":
        exc = ramp(np.column_stack([prep.vals[c] for c in COMMAND_COLUMNS[loop_input]]))
        if thrust == "command":
            thr = ramp(prep.vals["u_thrust"])
        else:
            alt = prep.vals["alt"]
            alt_sp = hold(alt)
            alt_rate = hold(np.gradient(alt, prep.period))
    else:
        motors = hold(prep.motors)
    return exc, alt_sp, alt_rate, np.zeros((n, 2)), thr, motors


def _errors(twin: pd.DataFrame, table: pd.DataFrame) -> dict[str, dict[str, float]]:
    out = {}
    for name in ("p", "q", "r", "roll", "pitch", "yaw", "alt", "vx", "vy", "vz", "ax", "ay",
                 "az"):
        if name in table and name in twin:
            log = table[name].to_numpy(dtype=float)
            diff = twin[name].to_numpy() - log
            if name == "yaw":
                diff = np.angle(np.exp(1j * diff))
            ok = np.isfinite(diff)
            if not ok.any():
                continue
            rmse = float(np.sqrt(np.mean(diff[ok] ** 2)))
            std = float(np.std(log[ok]))
            out[name] = {"rmse": rmse, "std": std, "ratio": rmse / std if std > 0 else math.inf}
    return out


def replay_many(
    table: pd.DataFrame, candidates: Sequence[Mapping[str, Any]],
    vehicle: str | Path | Vehicle | None = None, *, mode: str = "loop",
    loop_input: str = "sticks", thrust: str = "command", horizon: float = 2.0,
    ground_effect: bool = True, noise: bool | str = False, seed: int = 0,
) -> list[ReplayResult]:
    """Replay ``table`` once per candidate vehicle setting, all in one parallel call.

    Parameters
    ----------
    table : pandas.DataFrame
        Recorded FlightTable on a uniform grid, with at least ``roll pitch yaw alt`` and the
        commands of the chosen mode.
    candidates : sequence of mapping
        Vehicle settings per candidate (``{"time_delay": 0.02}``, ``{"thrust_scale": 1.1}``
        …; ``{}`` is the vehicle as it is). Same rotor count for all.
    vehicle : str, Path, Vehicle or None
        Base vehicle (default ``tarot680``).
    mode, loop_input, thrust, horizon, ground_effect, noise, seed
        See :func:`replay`. All candidates see the same noise (common random numbers).

    Returns
    -------
    list of ReplayResult
        One twin per candidate, in order.
    """
    if not candidates:
        raise SimError("replay: no candidates given")
    table, regridded = uniform_grid(table)
    base = load_vehicle(vehicle)
    vehicles = [_vehicle(base, c) for c in candidates]
    if len({v.n_rotors for v in vehicles}) != 1:
        raise SimError("replay: all candidates must have the same number of rotors")
    if not (isinstance(horizon, int | float) and horizon > 0):
        raise SimError(f"replay: horizon must be a positive number of s, got {horizon!r}")
    preps = [_prepare(table, v, mode, loop_input, thrust, ground_effect, noise)
             for v in vehicles]
    first = preps[0]
    capacity = max(p.plant.delay_capacity for p in preps)
    S0, P, inertia, runs, starts, stops = [], [], [], [], [], []
    horizons = np.zeros(0)
    for c, prep in enumerate(preps):
        S, a, b, rows = _jobs(prep, prep.plant, mode, horizon, ground_effect, capacity)
        S0.append(S)
        starts.append(a)
        stops.append(b)
        runs.append(np.full(len(a), c, dtype=np.int64))
        P.append(np.repeat(prep.plant.P[None], len(a), axis=0))
        inertia.append(np.repeat(prep.plant.inertia[None], len(a), axis=0))
        horizons = first.t[rows]
    exc, alt_sp, alt_rate, vel_sp, thr, motors = _inputs(first, mode, loop_input, thrust)
    n_steps = exc.shape[0]
    noise_arr = (first.plant.draw_noise(np.random.default_rng(seed), n_steps)
                 if noise not in (False, "none") else np.zeros((n_steps, N_NOISE)))
    n_rot = first.vehicle.n_rotors
    n_rows = first.t.size
    meas = np.empty((len(preps), n_rows, len(MEAS_COLUMNS) + n_rot))
    truth = np.empty((len(preps), n_rows, len(TRUTH_COLUMNS) + 5 * n_rot))
    pl = first.plant
    advance_jobs(np.vstack(S0), np.vstack(P), np.concatenate(inertia), pl.rpos, pl.spin,
                 pl.dists, pl.mix, np.concatenate(runs), np.concatenate(starts),
                 np.concatenate(stops), exc, alt_sp, alt_rate, vel_sp, thr, motors, noise_arr,
                 first.k_out, pl.rf_every, meas, truth)
    index = pd.Index(first.t, name="t")
    mcols = [*MEAS_COLUMNS, *(f"m{i + 1}" for i in range(n_rot))]
    tcols = [*(f"true_{c}" for c in TRUTH_COLUMNS),
             *(f"true_{b}{i + 1}" for b in ROTOR_BLOCKS for i in range(n_rot))]
    results = []
    for c, prep in enumerate(preps):
        twin = pd.DataFrame(meas[c], index=index.copy(), columns=mcols)
        twin.attrs = {"source": "etsid.sim.replay", "format": "sim",
                      "vehicle": prep.vehicle.name, "rate_hz": 1.0 / prep.period,
                      "physics_hz": prep.k_out / prep.period, "replay_mode": mode,
                      "replay_of": str(table.attrs.get("source", "?"))}
        tr = pd.DataFrame(truth[c], index=index.copy(), columns=tcols)
        tr.attrs = dict(twin.attrs)
        sources = dict(prep.sources)
        if regridded:
            sources["time grid"] = regridded
        left = divergence(twin, table) if mode == "loop" else None
        if left is not None:
            twin.attrs["replay_divergence"] = left
        results.append(ReplayResult(table=twin, truth=tr, vehicle=prep.vehicle, mode=mode,
                                    loop_input=loop_input, thrust=thrust,
                                    sources=sources, errors=_errors(twin, table),
                                    horizons=horizons, divergence=left))
    return results


def replay(
    table: pd.DataFrame, vehicle: str | Path | Vehicle | None = None, *, mode: str = "loop",
    loop_input: str = "sticks", thrust: str = "command", horizon: float = 2.0,
    ground_effect: bool = True, noise: bool | str = False, seed: int = 0,
    settings: Mapping[str, Any] | None = None,
) -> ReplayResult:
    """Fly ``vehicle`` with the commands of a recorded flight: the flight's simulated twin.

    Parameters
    ----------
    table : pandas.DataFrame
        Recorded FlightTable (uniform grid). Needs ``roll pitch yaw alt`` (initial states);
        ``p q r vx vy vz vbat`` are used when present (else 0 / the vehicle's charge).
    vehicle : str, Path, Vehicle or None
        Vehicle model (default ``tarot680``).
    mode : str
        ``"loop"``: recorded loop commands through the simulator's own loops (pilot off).
        ``"motors"``: recorded ``m1..mN`` open loop over horizons of ``horizon`` s, each
        re-initialised from the recorded state.
    loop_input : str
        ``"sticks"`` (``u_roll u_pitch u_yaw``, angle mode), ``"rates"``
        (``sp_p sp_q sp_r``, rad/s) or ``"torque"`` (``u_*`` as torque demands −1..1).
    thrust : str
        ``"command"``: recorded ``u_thrust`` to the mixer; ``"alt_hold"``: the simulator's
        altitude hold tracks the recorded ``alt``.
    horizon : float
        Re-initialisation period of ``mode="motors"``, s.
    ground_effect : bool
        Vehicle's ground-effect model on.
    noise : bool or str
        Sensor noise of the twin: ``"log"`` the log's own (estimated per sensor by
        :func:`log_noise_std`), ``"vehicle"`` or True the vehicle file's, ``"none"`` or
        False an exact twin.
    seed : int
        Noise seed.
    settings : mapping, optional
        Vehicle settings (effects …) as for :meth:`Vehicle.with_settings`.

    Returns
    -------
    ReplayResult
        The twin (measured and true), the sources of each part, and its errors against the
        log per channel.

    Raises
    ------
    SimError
        Missing columns, a non-uniform grid, a rotor count that does not match the log.
    """
    base = _vehicle(vehicle, settings)
    return replay_many(table, [{}], base, mode=mode, loop_input=loop_input, thrust=thrust,
                       horizon=horizon, ground_effect=ground_effect, noise=noise,
                       seed=seed)[0]
