"""What the pilot's sticks meant: the attitude (and yaw rate) one unit of stick commands.

A twin replays the recorded sticks through the simulator's angle loop, which reads a stick
as a fraction of ``max_tilt_deg`` (roll, pitch) and ``max_yaw_rate_deg`` (yaw); the real
autopilot's scale (PX4 ``MPC_MAN_TILT_MAX``, ArduPilot ``ANGLE_MAX``) is rarely in the log.
It is fitted as the slope of the attitude setpoint on the stick where the log has the
setpoint, else of the low-passed attitude itself (angle mode settles on the setpoint).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfiltfilt

from etsid.fit.regress import robust_lstsq

SLOW_HZ = 1.0
"""Hz: low-pass of attitude and stick when no setpoint is logged (the loop's settled part)."""


def _slope(pairs: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float] | None:
    x = np.concatenate([p[0] for p in pairs]) if pairs else np.zeros(0)
    y = np.concatenate([p[1] for p in pairs]) if pairs else np.zeros(0)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 100 or np.std(x[ok]) < 0.02:
        return None
    fit = robust_lstsq(np.column_stack([x[ok], np.ones(ok.sum())]), y[ok])
    return float(fit.coef[0]), float(fit.se[0])


def _airborne(t: pd.DataFrame, motors: list[str]) -> np.ndarray:
    m = t[motors].to_numpy(dtype=float).mean(axis=1)
    mask = np.isfinite(m) & (m > 0.4 * np.nanmedian(m))
    if "landed" in t:
        mask &= ~(t["landed"].to_numpy(dtype=float) > 0.5)
    return mask


def stick_scales(tables: list[pd.DataFrame], motors: list[str]
                 ) -> dict[str, tuple[float, float]]:
    """``{"max_tilt_deg": (value, se), "max_yaw_rate_deg": (value, se)}`` where the logs
    determine them (airborne rows: motors spinning, not landed)."""
    out: dict[str, tuple[float, float]] = {}
    tilt_pairs, yaw_pairs = [], []
    for t in tables:
        mask = _airborne(t, motors)
        if len(t) < 50:
            continue
        dt = float(np.median(np.diff(t.index.to_numpy(dtype=float))))
        sos = butter(2, min(SLOW_HZ, 0.4 / dt), fs=1.0 / dt, output="sos")

        def slow(x: np.ndarray, sos: np.ndarray = sos) -> np.ndarray:
            x = pd.Series(x).interpolate(limit_direction="both").to_numpy()
            return sosfiltfilt(sos, x) if np.isfinite(x).all() and len(x) > 20 else x
        for stick, sp, att, sign in (("u_roll", "sp_roll", "roll", 1.0),
                                     ("u_pitch", "sp_pitch", "pitch", 1.0)):
            if stick not in t:
                continue
            u = t[stick].to_numpy(dtype=float)
            y = (t[sp].to_numpy(dtype=float) if sp in t and t[sp].notna().mean() > 0.5
                 else slow(t[att].to_numpy(dtype=float)) if att in t else None)
            if y is None:
                continue
            u_s = u if sp in t and t[sp].notna().mean() > 0.5 else slow(u)
            tilt_pairs.append((u_s[mask], sign * y[mask]))
        if "u_yaw" in t and ("sp_r" in t or "r" in t):
            r = t["sp_r"] if "sp_r" in t and t["sp_r"].notna().mean() > 0.5 else t["r"]
            yaw_pairs.append((slow(t["u_yaw"].to_numpy(dtype=float))[mask],
                              slow(r.to_numpy(dtype=float))[mask]))
    tilt = _slope(tilt_pairs)
    if tilt is not None and tilt[0] > 0:
        out["max_tilt_deg"] = (math.degrees(tilt[0]), math.degrees(tilt[1]))
    yaw = _slope(yaw_pairs)
    if yaw is not None and yaw[0] > 0:
        out["max_yaw_rate_deg"] = (math.degrees(yaw[0]), math.degrees(yaw[1]))
    return out
