"""One flight made ready for the regressions: uniform grid, airborne rows, motor outputs,
voltage ratio, body velocity, and the zero-phase filter applied to both sides of every
regression (a linear filter on target and regressors keeps a linear relation exact)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfiltfilt

from etsid.errors import FitError

IV_HISTORY = 0.3
"""s of command history in the instruments (covers the motor lag and the rate loop)."""
IV_STEP = 0.03
"""s between instrument lags."""

NEAR_HOVER_SPEED = 1.5
"""m/s: horizontal speed below which the rotors' static thrust law is used. Faster, a rotor
gives more thrust at the same speed (translational lift: its inflow is swept away), which
the thrust and moment regressions do not model; those rows feed the drag fit only."""

MIN_AIRBORNE_S = 5.0
"""s of airborne data below which a flight is refused (nothing can be estimated)."""

CONTACT_MARGIN_S = 1.0
"""s cut at each take-off and landing edge of an airborne stretch. Motors spin above the
airborne threshold (or a land detector says airborne) while the legs still carry part of
the weight: there the accelerometer reads 1 g whatever the rotors do, and a few such rows
of low thrust at −a_z = g bend the thrust curve (on the ``multirotor`` set: 12 rows of a
60 s hover put the idle ratio at 0.04 for a truth of 0 and thrust/weight 7.5 % low). One
second is the shorter of the land detectors' documented trigger times (ArduPilot
``LAND_DETECTOR_TRIGGER_SEC``; :data:`etsid.ident.flight.LAND_MARGIN_S` cuts the same)."""


@dataclass
class Flight:
    """Arrays of one airborne stretch of a log, on a uniform grid ``dt``."""

    source: str
    dt: float
    t: np.ndarray                 # (n,) s
    motors: np.ndarray            # (n, N) outputs 0..1
    vratio: np.ndarray            # (n,) V_bat / V0 (1 where the log has no voltage)
    gyro: np.ndarray              # (n, 3) p q r, rad/s
    accel: np.ndarray | None      # (n, 3) specific force, m/s², FRD
    vel_body: np.ndarray | None   # (n, 3) velocity in body axes, m/s
    airborne: np.ndarray          # (n,) bool
    hover: np.ndarray             # (n,) bool: airborne and near hover (the static rotor laws)
    motor_rate_hz: float          # native rate of the motor outputs
    gyro_rate_hz: float
    commands: np.ndarray | None = None   # (n, k) pilot/loop commands: the instruments
    command_names: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    cutoff_scale: float = 1.0     # × the default cut-off (the model-error check halves it)
    _sos: np.ndarray | None = field(default=None, repr=False)

    @property
    def cutoff_hz(self) -> float:
        """Low-pass cut-off for derivative regressions: below the slower of the motor
        outputs' and the gyro's Nyquist rates (0.4×) and at most 15 Hz."""
        return self.cutoff_scale * float(min(
            15.0, 0.4 * 0.5 * min(self.motor_rate_hz, self.gyro_rate_hz), 0.4 / self.dt))

    def lowpass(self, x: np.ndarray) -> np.ndarray:
        """Zero-phase 2nd-order Butterworth at :attr:`cutoff_hz` along axis 0."""
        if self._sos is None:
            self._sos = butter(2, self.cutoff_hz, fs=1.0 / self.dt, output="sos")
        return sosfiltfilt(self._sos, x, axis=0)

    def instruments(self, extra: np.ndarray | None = None) -> np.ndarray | None:
        """Instrument matrix: the commands, low-passed, at lags 0 … :data:`IV_HISTORY` s
        (every :data:`IV_STEP` s), plus ``extra`` columns. The commands come from the pilot
        (or the loop above), not from the motor outputs' sampling jitter or the sensors'
        noise, so they are uncorrelated with the errors in the regressors — the
        instrumental-variable cure for errors-in-variables attenuation."""
        if self.commands is None:
            return None
        c = self.lowpass(self.commands)
        step = max(1, round(IV_STEP / self.dt))
        lags = range(0, round(IV_HISTORY / self.dt) + 1, step)
        cols = [np.vstack([np.repeat(c[:1], k, axis=0), c[:len(c) - k]]) if k else c
                for k in lags]
        z = np.hstack(cols)
        return z if extra is None else np.hstack([z, extra])


def _rate(table: pd.DataFrame, column: str, fallback: float) -> float:
    info = table.attrs.get("signals", {}).get(column)
    if isinstance(info, dict) and info.get("rate_hz"):
        return float(info["rate_hz"])
    return fallback


def _rotate_to_body(table: pd.DataFrame) -> np.ndarray | None:
    if not all(c in table for c in ("vx", "vy", "vz", "roll", "pitch", "yaw")):
        return None
    phi, th, psi = (table[c].to_numpy(dtype=float) for c in ("roll", "pitch", "yaw"))
    v = table[["vx", "vy", "vz"]].to_numpy(dtype=float)
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th), np.cos(psi), \
        np.sin(psi)
    # rows of R^T (NED -> body, ZYX Euler)
    r1 = np.stack([ct * cp, ct * sp, -st], axis=1)
    r2 = np.stack([sf * st * cp - cf * sp, sf * st * sp + cf * cp, sf * ct], axis=1)
    r3 = np.stack([cf * st * cp + sf * sp, cf * st * sp - sf * cp, cf * ct], axis=1)
    return np.stack([np.sum(r1 * v, 1), np.sum(r2 * v, 1), np.sum(r3 * v, 1)], axis=1)


def prepare(table: pd.DataFrame, motors: list[str], v0: float | None,
            max_rate_hz: float | None = None) -> Flight:
    """A :class:`Flight` from a FlightTable and its active motor columns.

    Airborne: not ``landed`` where the log says, and the mean motor output above 40 % of
    its in-flight median (a vehicle on the ground idles), less :data:`CONTACT_MARGIN_S` at
    each take-off and landing edge (:func:`trim_contact`). NaN rows are held over (counted).

    Raises
    ------
    FitError
        No gyro, or under :data:`MIN_AIRBORNE_S` of airborne data.
    """
    src = str(table.attrs.get("source", "table"))
    if not all(c in table for c in "pqr"):
        raise FitError(f"{src}: no body rates p q r; a fit needs the gyro")
    t = table.index.to_numpy(dtype=float)
    dt = float(np.median(np.diff(t)))
    if max_rate_hz is not None and dt < 1.0 / max_rate_hz:
        dt = dt * np.ceil(1.0 / (max_rate_hz * dt))   # a whole multiple of the log period
    grid = t[0] + dt * np.arange(round((t[-1] - t[0]) / dt) + 1)
    tab = table.reindex(table.index.union(grid)).interpolate("index", limit_area="inside")
    tab = tab.loc[grid].ffill().bfill()
    counts = {"rows": len(table), "grid_rows": len(grid)}
    m = tab[motors].to_numpy(dtype=float).clip(0.0, 1.0)
    mean_m = m.mean(axis=1)
    airborne = np.ones(len(grid), dtype=bool)
    if "landed" in tab:
        airborne &= ~(tab["landed"].to_numpy(dtype=float) > 0.5)
    level = np.median(mean_m[airborne]) if airborne.any() else np.median(mean_m)
    airborne &= mean_m > 0.4 * level
    airborne = trim_contact(airborne, dt)
    counts["airborne_rows"] = int(airborne.sum())
    if airborne.sum() * dt < MIN_AIRBORNE_S:
        raise FitError(f"{src}: {airborne.sum() * dt:.1f} s airborne (motors spinning, not "
                       f"landed); a fit needs at least {MIN_AIRBORNE_S:g} s")
    if "vbat" in tab and np.isfinite(tab["vbat"]).any():
        vbat = tab["vbat"].to_numpy(dtype=float)
        ref = v0 if v0 is not None else float(np.median(vbat[airborne]))
        vratio = vbat / ref
    else:
        vratio = np.ones(len(grid))
    accel = tab[["ax", "ay", "az"]].to_numpy(dtype=float) if all(
        c in tab for c in ("ax", "ay", "az")) else None
    names = [c for c in ("u_roll", "u_pitch", "u_yaw", "u_thrust") if c in tab
             and np.nanstd(tab[c].to_numpy(dtype=float)) > 1e-6]
    if len(names) < 3:
        names = [c for c in ("sp_p", "sp_q", "sp_r", "u_thrust") if c in tab
                 and np.nanstd(tab[c].to_numpy(dtype=float)) > 1e-6]
    commands = tab[names].to_numpy(dtype=float) if len(names) >= 3 else None
    vel_body = _rotate_to_body(tab)
    hover = airborne.copy()
    if vel_body is not None:
        slow = airborne & (np.hypot(vel_body[:, 0], vel_body[:, 1]) < NEAR_HOVER_SPEED)
        counts["near_hover_rows"] = int(slow.sum())
        hover = slow
    return Flight(source=src, dt=dt, t=grid - grid[0], motors=m, vratio=vratio,
                  commands=commands, command_names=names, hover=hover,
                  gyro=tab[["p", "q", "r"]].to_numpy(dtype=float), accel=accel,
                  vel_body=vel_body, airborne=airborne,
                  motor_rate_hz=_rate(table, motors[0], 1.0 / dt),
                  gyro_rate_hz=_rate(table, "p", 1.0 / dt), counts=counts)


def trim_contact(mask: np.ndarray, dt: float, margin_s: float = CONTACT_MARGIN_S
                 ) -> np.ndarray:
    """``mask`` without ``margin_s`` seconds at each edge of a True run that borders a False
    row (ground contact at take-off and landing); the log's own start and end are kept."""
    out = np.asarray(mask, dtype=bool).copy()
    k = round(margin_s / dt)
    edges = np.flatnonzero(np.diff(np.r_[0, out.astype(np.int8), 0]))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        lo = a + k if a > 0 else a
        hi = b - k if b < out.size else b
        out[a:b] = False
        if hi > lo:
            out[lo:hi] = True
    return out


def motor_state(flight: Flight, idle: float, tau: float, delay: float) -> np.ndarray:
    """Rotor speed over the top speed at V0, x = Ω/Ω_top(V0), per motor (n, N).

    The simulator's motor law (docs/physics.md): steady state x_ss = ι(1 − m) + (V/V0) m
    after a delay (negative: the log stamps the command late against the rotors), then a
    first-order lag τ. The logged outputs are point samples of a command that moves between
    them, so the lag is discretised exactly for a command interpolated linearly between
    samples (first-order hold); holding each sample over the period (zero-order hold) adds
    half a period of delay (with the delay held at 0, the fitted τ absorbed it: −10 % on a
    250 Hz log of etsid's simulator).
    """
    from scipy.signal import lfilter

    m = flight.motors
    shift = delay / flight.dt
    if shift > 0:
        k = int(np.floor(shift))
        frac = shift - k
        pad = np.vstack([np.repeat(m[:1], k + 1, axis=0), m])
        m = (1 - frac) * pad[1:len(m) + 1] + frac * pad[:len(m)]
    elif shift < 0:   # the command stamped late against the rotors: advance it
        k = int(np.floor(-shift))
        frac = -shift - k
        pad = np.vstack([m, np.repeat(m[-1:], k + 1, axis=0)])
        m = (1 - frac) * pad[k:k + len(m)] + frac * pad[k + 1:k + 1 + len(m)]
    xss = idle * (1.0 - m) + flight.vratio[:, None] * m
    if tau <= 0:
        return xss
    a = float(np.exp(-flight.dt / tau))
    # x[k+1] = a x[k] + b0 u[k] + b1 u[k+1] (first-order hold; b0 + b1 = 1 − a)
    c = (1.0 - a) * tau / flight.dt
    b1, b0 = 1.0 - c, c - a
    out, _ = lfilter([b1, b0], [1.0, -a], xss, axis=0, zi=xss[:1] * (1.0 - b1))
    return out
