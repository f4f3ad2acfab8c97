"""Prepare one flight for the gap analysis: uniform grid, body velocity, airborne mask.

Both logs go through exactly the same steps, so whatever the processing does to one it
does to the other: resample to :data:`MODEL_HZ` (or the log's own rate if slower), rotate
the NED velocity into body axes, find the airborne part, and keep the raw motor outputs
(the candidates filter or delay them before the nominal model sees them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfilt, sosfilt_zi, sosfiltfilt

from etsid.errors import GapError
from etsid.gap.zero_phase import filtfilt_columns

MODEL_HZ = 100.0
ANTIALIAS_SHARE = 0.4
"""A log faster than the analysis grid is low-passed at this share of the grid rate
(40 Hz for 100 Hz) before resampling."""
"""Rate of the gap analysis, Hz (a slower log is analysed at its own rate)."""
ANALYSIS_CUTOFF_HZ = 8.0
"""Zero-phase low-pass applied to measured outputs and to predictions alike, Hz."""
EDGE_S = 1.0
"""Seconds dropped at both ends of every airborne stretch (take-off/landing transients)."""
MIN_AIRBORNE_S = 12.0
"""Least airborne time a verdict needs, s: three of the criterion's 4 s blocks, the fewest
that give both folds a block with one to spare for the edges."""
REQUIRED = ("p", "q", "r", "az")


@dataclass
class Flight:
    """One flight on the analysis grid (all arrays share the length ``n``).

    Attributes
    ----------
    name : str
        File name, for messages.
    t : ndarray
        Time, s.
    fs : float
        Sample rate, Hz.
    motors : ndarray
        (n, N) motor outputs 0..1 (or the four stick commands when the log has no motors).
    inputs : str
        ``"motors"`` or ``"commands"``.
    rates, acc, att : ndarray
        (n, 3) gyro p q r (rad/s), specific force ax ay az (m/s², NaN where absent),
        Euler angles roll pitch yaw (rad, NaN where absent).
    v_body : ndarray
        (n, 3) velocity in body axes, m/s (zeros if the log has none).
    alt, vbat : ndarray
        Height above ground (m) and battery voltage (V); NaN where absent.
    airborne : ndarray
        Boolean mask of the samples used as evidence.
    have : set of str
        Which optional signals the log has (``alt``, ``vbat``, ``vel``, ``att``, ``ax``...).
    """

    name: str
    t: np.ndarray
    fs: float
    motors: np.ndarray
    inputs: str
    rates: np.ndarray
    acc: np.ndarray
    att: np.ndarray
    v_body: np.ndarray
    alt: np.ndarray
    vbat: np.ndarray
    airborne: np.ndarray
    have: set[str] = field(default_factory=set)
    command_source: str = ""
    """Where ``"commands"`` come from when not the sticks: ``"rate setpoints"`` or
    ``"attitude targets"`` (:data:`SETPOINT_KINDS`); empty for sticks and motors."""

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.t.size

    @property
    def airborne_s(self) -> float:
        """Airborne time used as evidence, s."""
        return float(np.sum(self.airborne)) / self.fs


@lru_cache(maxsize=64)
def _lowpass_sos(wn: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(sos, its steady-state initial conditions, pad length) of the analysis low-pass at
    normalised cut-off ``wn`` (computed once: a fit filters thousands of predictions)."""
    sos = butter(2, wn, output="sos")
    zeros = min(int(np.sum(sos[:, 2] == 0)), int(np.sum(sos[:, 5] == 0)))
    return sos, sosfilt_zi(sos), 3 * (2 * len(sos) + 1 - zeros)


def lowpass(x: np.ndarray, fs: float, cutoff: float = ANALYSIS_CUTOFF_HZ) -> np.ndarray:
    """Zero-phase 4th-order Butterworth low-pass along axis 0 (cut-off in Hz).

    The steps of :func:`scipy.signal.sosfiltfilt` (odd extension, forward and backward
    passes from steady state) with the filter's initial conditions computed once, every
    column through the same arithmetic as scipy's section kernel, the columns advanced
    together (:mod:`etsid.gap.zero_phase`; bit-identical to ``sosfilt``)."""
    sos, zi, edge = _lowpass_sos(min(cutoff / (0.5 * fs), 0.95))
    x = np.asarray(x, dtype=float)
    if x.shape[0] <= edge:
        return sosfiltfilt(sos, x, axis=0)
    return filtfilt_columns(x.reshape(x.shape[0], -1), sos, zi, edge).reshape(x.shape)


def lowpass_series(series: list[np.ndarray], fs: float, cutoff: float = ANALYSIS_CUTOFF_HZ
                   ) -> list[np.ndarray]:
    """Each 1-D series of one length low-passed as by :func:`lowpass`, bit for bit, in one
    call (no stacking into columns first)."""
    sos, zi, edge = _lowpass_sos(min(cutoff / (0.5 * fs), 0.95))
    if series[0].shape[0] <= edge:
        return list(lowpass(np.column_stack(series), fs, cutoff).T)
    return list(filtfilt_columns(series, sos, zi, edge).T)


def _lowpass_public(x: np.ndarray, sos: np.ndarray, zi: np.ndarray, edge: int) -> np.ndarray:
    """:func:`lowpass` through ``scipy.signal.sosfilt`` (the reference its kernel is tested
    against)."""
    ext = np.concatenate([2 * x[:1] - x[edge:0:-1], x, 2 * x[-1:] - x[-2:-edge - 2:-1]])
    z = zi.reshape(zi.shape + (1,) * (x.ndim - 1))
    y, _ = sosfilt(sos, ext, axis=0, zi=z * ext[:1])
    y, _ = sosfilt(sos, y[::-1], axis=0, zi=z * y[-1:])
    return y[::-1][edge:-edge]


def derivative(x: np.ndarray, fs: float) -> np.ndarray:
    """Central-difference time derivative along axis 0, per s."""
    return np.gradient(x, 1.0 / fs, axis=0)


def _motor_columns(table: pd.DataFrame) -> list[str]:
    cols = [c for c in table.columns if c.startswith("m") and c[1:].isdigit()]
    return sorted(cols, key=lambda c: int(c[1:]))


def down_in_body(att: np.ndarray) -> np.ndarray:
    """(n, 3) the earth's down direction in body axes for Euler angles ``att`` (roll,
    pitch, yaw; rad): the third column of Rᵀ, ``(−sin θ, sin φ cos θ, cos φ cos θ)``."""
    roll, pitch = att[:, 0], att[:, 1]
    return np.column_stack([-np.sin(pitch), np.sin(roll) * np.cos(pitch),
                            np.cos(roll) * np.cos(pitch)])


def _body_velocity(vned: np.ndarray, att: np.ndarray) -> np.ndarray:
    roll, pitch, yaw = att[:, 0], att[:, 1], att[:, 2]
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    # rows of R (body -> NED) are used transposed: v_b = R^T v_ned
    r00, r01, r02 = cp * cy, cp * sy, -sp
    r10, r11, r12 = sr * sp * cy - cr * sy, sr * sp * sy + cr * cy, sr * cp
    r20, r21, r22 = cr * sp * cy + sr * sy, cr * sp * sy - sr * cy, cr * cp
    vx, vy, vz = vned[:, 0], vned[:, 1], vned[:, 2]
    return np.column_stack([r00 * vx + r01 * vy + r02 * vz, r10 * vx + r11 * vy + r12 * vz,
                            r20 * vx + r21 * vy + r22 * vz])


def _airborne(table: pd.DataFrame, t: np.ndarray, thrust: np.ndarray, alt: np.ndarray,
              fs: float) -> np.ndarray:
    ok = np.isfinite(thrust)
    level = np.nanmedian(thrust) if np.any(ok) else 0.0
    mask = ok & (thrust > 0.5 * level) & (level > 0.05)
    for column in ("landed", "ground_contact"):  # the detector and its touch-down stages
        if column in table.columns:
            ground = np.interp(t, table.index.to_numpy(float),
                               table[column].astype(float).to_numpy()) > 0.5
            mask &= ~ground
    if np.any(np.isfinite(alt)):
        low = ~mask & np.isfinite(alt)  # height while motors are low: the ground
        ground = np.nanpercentile(alt[low], 50) if np.sum(low) > fs else np.nanmin(alt) - 1.0
        mask &= np.isfinite(alt) & (alt > ground + 0.03)
    # keep stretches longer than two edges, minus an edge at both ends
    edge = round(EDGE_S * fs)
    out = np.zeros_like(mask)
    for i, j in true_runs(mask):
        if j - i > 2 * edge + int(fs):
            out[i + edge:j - edge] = True
    return out


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index pairs of every run of True in a boolean array (stop exclusive).

    >>> true_runs(np.array([False, True, True, False, True]))
    [(1, 3), (4, 5)]
    """
    padded = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


COMMANDS = ("u_thrust", "u_roll", "u_pitch", "u_yaw")


RATE_SETPOINTS = ("u_thrust", "sp_p", "sp_q", "sp_r")
ATTITUDE_TARGETS = ("u_thrust", "sp_roll", "sp_pitch", "sp_yaw")
SETPOINT_KINDS = {"rate setpoints": RATE_SETPOINTS, "attitude targets": ATTITUDE_TARGETS}
"""Commands read from the autopilot's own setpoints when a log has neither motor outputs nor
sticks: the collective and the rate setpoints (the rate loop's demand), else the collective
and the attitude errors to the attitude targets (the attitude loop's demand)."""


def _has(table: pd.DataFrame, cols: tuple[str, ...]) -> bool:
    return all(c in table.columns and table[c].notna().sum() >= 10 for c in cols)


def input_kinds(table: pd.DataFrame) -> tuple[str, ...]:
    """The kinds of inputs a table offers, best first: ``"motors"`` (m1..mN, N ≥ 3),
    ``"commands"`` (the four loop commands), then, only when it has neither, ``"rate
    setpoints"`` or ``"attitude targets"`` (:data:`SETPOINT_KINDS`)."""
    kinds = []
    if len(_motor_columns(table)) >= 3:
        kinds.append("motors")
    if _has(table, COMMANDS):
        kinds.append("commands")
    if not kinds:
        kinds += [k for k, cols in SETPOINT_KINDS.items() if _has(table, cols)
                  and (k != "attitude targets" or _has(table, ("roll", "pitch", "yaw")))]
    return tuple(kinds)


def prepare(table: pd.DataFrame, name: str, inputs: str | None = None) -> Flight:
    """Resample a FlightTable to the analysis grid and derive what the gap analysis uses.

    Parameters
    ----------
    table : pandas.DataFrame
        FlightTable (index ``t`` in s).
    name : str
        File name used in error messages.
    inputs : str, optional
        ``"motors"`` or ``"commands"`` (default: motors where the log has them): two logs
        are compared on the same kind of input.

    Raises
    ------
    GapError
        The log lacks body rates, vertical specific force or motor/command inputs.
    """
    missing = [c for c in REQUIRED if c not in table.columns or table[c].notna().sum() < 10]
    kinds = input_kinds(table)
    inputs = inputs if inputs in kinds else (kinds[0] if kinds else None)
    motors = _motor_columns(table) if inputs == "motors" else list(
        SETPOINT_KINDS.get(inputs or "", COMMANDS))
    if inputs is None:
        missing.append("m1..mN motor outputs (or u_thrust/u_roll/u_pitch/u_yaw, or u_thrust "
                       "with rate setpoints sp_p/sp_q/sp_r or attitude targets)")
    if missing:
        raise GapError(f"{name}: lacks {', '.join(missing)}; the gap analysis needs body "
                       "rates, vertical specific force and motor outputs or commands")
    t_src = table.index.to_numpy(dtype=float)
    if t_src.size < 10 or not np.all(np.diff(t_src) > 0):
        raise GapError(f"{name}: time index is too short or not increasing")
    native = (t_src.size - 1) / (t_src[-1] - t_src[0])
    fs = float(min(MODEL_HZ, native))
    t = np.arange(t_src[0], t_src[-1], 1.0 / fs)
    dt = np.diff(t_src)
    # a faster log is low-passed before it is resampled: motor outputs carry the rate
    # loop's high-frequency content, which would otherwise alias into the model's band
    antialias = native > 1.25 * fs and float(np.std(dt)) < 0.1 * float(np.median(dt))

    def col(c: str) -> np.ndarray:
        if c not in table.columns:
            return np.full(t.size, np.nan)
        v = table[c].to_numpy(dtype=float)
        good = np.isfinite(v)
        if good.sum() < 2:
            return np.full(t.size, np.nan)
        if antialias and good.all():
            v = lowpass(v, native, ANTIALIAS_SHARE * fs)
        return np.interp(t, t_src[good], v[good])

    have = {c for c in ("alt", "vbat", "ax", "ay", "roll", "vx") if c in table.columns
            and table[c].notna().sum() > 10}
    rates = np.column_stack([col(c) for c in ("p", "q", "r")])
    acc = np.column_stack([col(c) for c in ("ax", "ay", "az")])
    att = np.column_stack([col(c) for c in ("roll", "pitch", "yaw")])
    if "roll" in have:
        att[:, 2] = np.unwrap(att[:, 2]) if np.all(np.isfinite(att[:, 2])) else 0.0
    m = np.column_stack([col(c) for c in motors])
    if inputs == "attitude targets":  # the attitude loop's demand: the error to the target
        m[:, 1:] = m[:, 1:] - att
        m[:, 3] = np.angle(np.exp(1j * m[:, 3]))
    thrust = m[:, 0] if inputs != "motors" else np.mean(m, axis=1)
    alt = col("alt")
    v_body = np.zeros((t.size, 3))
    if "vx" in have and "roll" in have:
        vned = np.column_stack([col(c) for c in ("vx", "vy", "vz")])
        if np.all(np.isfinite(vned)) and np.all(np.isfinite(att)):
            v_body = _body_velocity(vned, att)
            have.add("vel")
    air = _airborne(table, t, thrust, alt, fs)
    for arr in (rates, acc[:, 2:], m):
        air &= np.all(np.isfinite(arr), axis=1)
    source = inputs if inputs in SETPOINT_KINDS else ""
    return Flight(name=name, t=t - t[0], fs=fs, motors=m,
                  inputs="commands" if source else inputs, rates=rates, acc=acc, att=att,
                  v_body=v_body, alt=alt, vbat=col("vbat"), airborne=air, have=have,
                  command_source=source)


def describe(flight: Flight) -> dict[str, Any]:
    """Short provenance of a prepared flight for gap.json."""
    return {"file": flight.name, "rate_hz": flight.fs, "inputs": flight.inputs,
            "n_inputs": int(flight.motors.shape[1]), "airborne_s": round(flight.airborne_s, 2),
            **({"command_source": flight.command_source} if flight.command_source else {}),
            "duration_s": round(float(flight.t[-1]), 2),
            "signals": sorted(flight.have)}


MAX_EVIDENCE_S = 600.0
"""Longest airborne time the likelihood criterion reads from one flight, s: ten minutes of
blocks give each effect's held-out gain a standard error far below any calibrated
threshold, and bound the cost and memory of a long log (an hour is read as twenty evenly
spread 30 s windows)."""
WINDOW_S = 30.0
LEAD_S = 1.0
"""Each window starts this long before its evidence: the filters and the motor-response
model settle there (their memory is ≪ 1 s)."""


def excerpt(flight: Flight, max_s: float = MAX_EVIDENCE_S) -> tuple[Flight, str | None]:
    """The flight, or, when it has more than ``max_s`` of airborne time, evenly spread
    windows of :data:`WINDOW_S` of it (times kept; the note says what was read)."""
    if flight.airborne_s <= max_s:
        return flight, None
    n_win, n_lead = round(WINDOW_S * flight.fs), round(LEAD_S * flight.fs)
    pieces = [(s, min(s + n_win, b)) for a, b in true_runs(flight.airborne)
              for s in range(a, b, n_win) if min(s + n_win, b) - s >= n_win // 2]
    keep = max(int(max_s // WINDOW_S), 1)
    chosen = [pieces[i] for i in np.unique(np.linspace(0, len(pieces) - 1, keep).round()
                                           .astype(int))]
    idx, air = [], []
    for a, b in chosen:
        lo = max(a - n_lead, 0)
        idx.append(np.arange(lo, b))
        air.append(np.r_[np.zeros(a - lo, dtype=bool), flight.airborne[a:b]])
    sel = np.concatenate(idx)
    air_mask = np.concatenate(air)
    part = Flight(name=flight.name, t=flight.t[sel], fs=flight.fs, motors=flight.motors[sel],
                  inputs=flight.inputs, rates=flight.rates[sel], acc=flight.acc[sel],
                  att=flight.att[sel], v_body=flight.v_body[sel], alt=flight.alt[sel],
                  vbat=flight.vbat[sel], airborne=air_mask, have=set(flight.have))
    note = (f"{flight.name}: {flight.airborne_s:.0f} s airborne; {len(chosen)} evenly spread "
            f"{WINDOW_S:.0f} s windows ({part.airborne_s:.0f} s) read as evidence")
    return part, note
