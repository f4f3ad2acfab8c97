"""Named flights: their settings, validation and the reference signals they feed the loop.

``SCENARIOS`` maps a name to ``{"description": str, "params": {setting: default}}``; the
CLI lists it. :func:`resolve_params` merges user settings into the defaults and checks
them; :func:`build_references` turns them into per-step stick excitation, altitude and
speed targets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from etsid.errors import SimError
from etsid.sim.excitation import EXCITATIONS, stick_excitation, taper_window
from etsid.sim.vehicle_params import SCENARIO as SCENARIO_PARAMS
from etsid.sim.vehicle_params import check_number

_COMMON: dict[str, Any] = {
    "duration": 60.0,        # s
    "altitude": 3.0,         # m, CG height above ground (initial and held)
    "amplitude": 0.4,        # peak roll/pitch stick excitation, 0..1
    "yaw_amplitude": 0.5,    # peak yaw stick excitation, 0..1
    "excitation": "mixed",   # one of EXCITATIONS
    "f_min": 0.1,            # Hz
    "f_max": 8.0,            # Hz
    "alt_wander": 0.0,       # m, amplitude of a slow (0.03-0.25 Hz) altitude-setpoint wander
    "settle": 2.0,           # s of quiet flight before the excitation
    "alt_hold": True,        # False: fixed collective `throttle`
    "pilot": True,           # simulated pilot keeps position/speed and heading
    "throttle": None,        # collective 0..1 when alt_hold is off (None: hover trim)
    "wind": [0.0, 0.0, 0.0],  # NED m/s, constant
}

SCENARIOS: dict[str, dict[str, Any]] = {
    "hover-ige": {
        "description": "low hover in ground effect (CG 0.28 m above ground, below 0.40 m) "
                       "with rich roll/pitch/yaw stick excitation, altitude hold on the "
                       "rangefinder (the chapter's Fig. 1.8 flight)",
        "params": {**_COMMON, "altitude": 0.28, "amplitude": 0.35, "alt_wander": 0.06},
    },
    "hover-oge": {
        "description": "hover out of ground effect at 3 m with the same excitation",
        "params": {**_COMMON},
    },
    "sine-altitude": {
        "description": "altitude follows a sine (vertical-loop tracking task, Fig. 1.12) "
                       "with light attitude excitation",
        "params": {**_COMMON, "altitude": 1.5, "amplitude": 0.1, "yaw_amplitude": 0.2,
                   "alt_amplitude": 1.0, "alt_period": 10.0},
    },
    "forward-flight": {
        "description": "pilot accelerates to a forward speed and holds it, with excitation",
        "params": {**_COMMON, "altitude": 5.0, "amplitude": 0.2, "speed": 6.0, "ramp": 8.0},
    },
    "ige-oge": {
        "description": "dwells in ground effect (CG 0.25 m) and out of it (1-2.5 m) joined by "
                       "climbs and descents, with rich roll/pitch/yaw stick excitation "
                       "throughout (the chapter's regime-change flight)",
        "params": {**_COMMON, "duration": 150.0, "altitude": 0.25, "amplitude": 0.35,
                   "high_altitudes": [1.0, 2.5, 1.75], "dwell": 12.0, "transition": 3.0},
    },
    "steps": {
        "description": "held roll, pitch and yaw stick steps in turn (step responses)",
        "params": {**_COMMON, "duration": 16.0, "altitude": 2.0, "excitation": "steps",
                   "amplitude": 0.4, "yaw_amplitude": 0.4, "pilot": False},
    },
}

_RANGED = {k: p for k, p in SCENARIO_PARAMS.items() if p.kind == "num"}
"""Number settings and their ranges: one declaration (etsid/sim/vehicle_params.py)."""


@dataclass
class References:
    """Per-step inputs of the flight loop (n = number of physics steps)."""

    exc: np.ndarray         # (n, 3) roll/pitch/yaw stick excitation
    alt_sp: np.ndarray      # (n,) altitude setpoint, m
    alt_rate: np.ndarray    # (n,) altitude setpoint rate, m/s
    vel_sp: np.ndarray      # (n, 2) pilot forward/right speed target, m/s
    thr_manual: np.ndarray  # (n,) manual collective (alt_hold off)


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def resolve_params(scenario: str, duration: float | None, settings: dict[str, Any]
                   ) -> dict[str, Any]:
    """Defaults of ``scenario`` updated with ``settings`` (and ``duration``), validated.

    Raises
    ------
    SimError
        Unknown scenario or setting, or a setting with a wrong type or value.
    """
    if scenario not in SCENARIOS:
        raise SimError(f"unknown scenario {scenario!r}: choose one of {', '.join(SCENARIOS)}")
    params = dict(SCENARIOS[scenario]["params"])
    unknown = sorted(set(settings) - set(params))
    if unknown:
        raise SimError(f"scenario {scenario!r}: unknown setting {unknown[0]!r} "
                       f"(known: {', '.join(sorted(params))})")
    params.update(settings)
    where = f"scenario {scenario!r}: setting"
    for key, value in [*params.items(), *([("duration", duration)] if duration is not None
                                          else [])]:  # a setting is checked even when
        if key in _RANGED and not (key == "throttle" and value is None):  # --duration wins
            wrong = check_number(_RANGED[key], value)
            if wrong:
                raise SimError(f"{where} {key!r} {wrong}, got {value!r}")
    if duration is not None:
        params["duration"] = duration
    if params["excitation"] not in EXCITATIONS:
        raise SimError(f"{where} 'excitation' must be one of {', '.join(EXCITATIONS)}, "
                       f"got {params['excitation']!r}")
    for key in ("alt_hold", "pilot"):
        if not isinstance(params[key], bool):
            raise SimError(f"{where} {key!r} must be true or false, got {params[key]!r}")
    thr = params["throttle"]
    if thr is not None and not (_is_number(thr) and 0 <= thr <= 1):
        raise SimError(f"{where} 'throttle' must be None or lie in 0..1, got {thr!r}")
    wind = params["wind"]
    if not (isinstance(wind, list | tuple) and len(wind) == 3 and all(map(_is_number, wind))):
        raise SimError(f"{where} 'wind' must be three numbers (NED m/s), got {wind!r}")
    if any(check_number(SCENARIO_PARAMS["wind"], w) for w in wind):
        raise SimError(f"{where} 'wind' must be three numbers "
                       f"{SCENARIO_PARAMS['wind'].describe()}, got {wind!r}")
    params["wind"] = [float(w) for w in wind]
    if "high_altitudes" in params:
        highs = params["high_altitudes"]
        if not (isinstance(highs, list | tuple) and 0 < len(highs) <= 100
                and all(map(_is_number, highs))
                and not any(check_number(SCENARIO_PARAMS["high_altitudes"], h)
                            for h in highs)):
            raise SimError(f"{where} 'high_altitudes' must be a list of positive numbers "
                           f"(m), got {highs!r}")
        params["high_altitudes"] = [float(h) for h in highs]
    if params["f_max"] <= params["f_min"]:
        raise SimError(f"{where} 'f_max' must exceed 'f_min', got {params['f_max']!r}")
    return params


def build_references(scenario: str, params: dict[str, Any], t: np.ndarray,
                     rng: np.random.Generator, throttle: float, hold: int = 1) -> References:
    """Per-step reference signals of a scenario.

    Parameters
    ----------
    scenario : str
        Scenario name.
    params : dict
        Resolved settings (:func:`resolve_params`).
    t : ndarray
        Time of every physics step, s.
    rng : numpy.random.Generator
        Seeded generator for the random parts of the excitation.
    throttle : float
        Collective used when altitude hold is off.
    hold : int
        The sticks are computed on every ``hold``-th step and held in between (a radio
        link sends frames at a fixed rate; also much cheaper than per physics step).
    """
    n = t.size
    amp = (params["amplitude"], params["amplitude"], params["yaw_amplitude"])
    exc = stick_excitation(t[::hold], rng, params["excitation"], amp, params["f_min"],
                           params["f_max"], t_start=params["settle"],
                           t_end=params["duration"] - 1.0)
    exc = np.repeat(exc, hold, axis=0)[:n]
    alt_sp = np.full(n, float(params["altitude"]))
    alt_rate = np.zeros(n)
    vel_sp = np.zeros((n, 2))
    if params["alt_wander"] > 0:
        freqs = np.array([0.03, 0.07, 0.13, 0.25])
        phases = rng.uniform(0.0, 2.0 * np.pi, freqs.size)
        wander = np.sum(np.sin(2.0 * np.pi * freqs[:, None] * t + phases[:, None]), axis=0)
        wander /= max(float(np.max(np.abs(wander))), 1e-12)
        wander *= taper_window(t, params["settle"], params["duration"] - 1.0, ramp=3.0)
        dw = np.gradient(wander, t) if n > 1 else np.zeros(n)
        scale = params["alt_wander"]
        alt_sp = alt_sp + scale * wander
        alt_rate = alt_rate + scale * dw
    if scenario == "sine-altitude":
        w = 2.0 * np.pi / params["alt_period"]
        ramp = np.clip((t - params["settle"]) / params["alt_period"], 0.0, 1.0)
        alt_sp = params["altitude"] + params["alt_amplitude"] * ramp * np.sin(w * t)
        alt_rate = params["alt_amplitude"] * ramp * w * np.cos(w * t)
    if scenario == "ige-oge":
        alt_sp, alt_rate = regime_profile(t, params["altitude"], params["high_altitudes"],
                                          params["settle"], params["dwell"],
                                          params["transition"])
    if scenario == "forward-flight":
        vel_sp[:, 0] = params["speed"] * np.clip((t - params["settle"]) / params["ramp"], 0, 1)
    return References(exc=exc, alt_sp=alt_sp, alt_rate=alt_rate, vel_sp=vel_sp,
                      thr_manual=np.full(n, float(throttle)))


def regime_profile(t: np.ndarray, low: float, highs: list[float], settle: float,
                   dwell: float, transition: float) -> tuple[np.ndarray, np.ndarray]:
    """Altitude setpoint (m) and its rate (m/s) of the ``ige-oge`` flight.

    Dwell at ``low`` for ``settle + dwell`` s, then a smooth (raised-cosine) climb of
    ``transition`` s to the next of ``highs`` (cycled), a dwell there, a descent back to
    ``low``, a dwell, and so on until the end of ``t``.
    """
    levels = [low]
    start = [0.0]
    tk = settle + dwell
    i = 0
    while tk < t[-1]:
        target = highs[i % len(highs)] if i % 2 == 0 else low
        levels.append(target)
        start.append(tk)
        tk += transition + dwell
        i += 1
    alt = np.full(t.size, float(low))
    rate = np.zeros(t.size)
    for a, b, t0 in zip(levels[:-1], levels[1:], start[1:], strict=True):
        u = np.clip((t - t0) / transition, 0.0, 1.0)
        alt += (b - a) * 0.5 * (1.0 - np.cos(np.pi * u))
        inside = (u > 0.0) & (u < 1.0)
        rate[inside] += (b - a) * 0.5 * np.pi / transition * np.sin(np.pi * u[inside])
    return alt, rate
