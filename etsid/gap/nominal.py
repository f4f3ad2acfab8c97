"""The nominal model: physics-structured regressions fitted on the simulation log.

Per rotor, speed follows the command through a short delay (0–10 ms, the log's own) and a
first-order lag (time constant ``tau``, s) and ``Omega_i ∝ m_i + k`` (``k`` = idle speed
over speed range); thrust and reaction torque go as ``P_i = (m_i + k)²``. The channels:

* ``az`` (m/s²): ``c1 ΣP_i + c2 v_bz + c3 |v_bz| v_bz + c4 ΣP_i (v_bx² + v_by²)`` — thrust
  over mass with climb-inflow, vertical drag and translational-lift corrections (no
  intercept: zero thrust is zero specific force);
* ``ax``, ``ay`` (m/s²): rotor and body drag ``c1 Ω̄ v + c2 |v| v + c0`` (Ω̄ = mean (m_i + k));
* ``p``, ``q`` (rad/s²): moments from thrust differences, ``Σ g_i (P_i − P̄)`` plus the
  gyroscopic product (``q r`` or ``p r``), rotor damping (∝ ``p`` or ``q``) and a constant;
* ``r`` (rad/s²): reaction torques ``Σ h_i (P_i − P̄)`` plus rotor spin-up ``Σ j_i dΩ_i/dt``,
  ``p q``, damping (∝ ``r``) and a constant;
* ``gyro_p``, ``gyro_q``, ``gyro_r`` (rad/s): the gyro against the body rate implied by the
  logged attitude (Euler kinematics); no coefficient to fit;
* ``kin_x``, ``kin_y``, ``kin_z`` (m/s²): the accelerometer against the specific force
  implied by the logged velocity and attitude, ``v̇_b + ω × v_b − Rᵀ g`` (kinematics, no
  coefficient to fit): zero on average for a sound accelerometer, whatever the thrust.

Measured outputs and predictions are low-passed by the same zero-phase filter
(:data:`CUTOFF_HZ`), so a linear regression on filtered features is the filtered
prediction. ``k`` and ``tau`` are found by a bounded search on the simulation; the other
coefficients by least squares. Candidates change the model through :class:`Mods`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cache
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from etsid.gap.signals import Flight, derivative, down_in_body, lowpass, lowpass_series

FORCE_CHANNELS = ("az", "ax", "ay")
RATE_CHANNELS = ("p", "q", "r")
GYRO_CHANNELS = ("gyro_p", "gyro_q", "gyro_r")
KIN_CHANNELS = ("kin_x", "kin_y", "kin_z")
SENSOR_CHANNELS = (*GYRO_CHANNELS, *KIN_CHANNELS)
"""Channels that compare a sensor with kinematics: nothing is fitted on them."""
CHANNELS = (*RATE_CHANNELS, *FORCE_CHANNELS, *GYRO_CHANNELS, *KIN_CHANNELS)
UNITS = {"p": "rad/s²", "q": "rad/s²", "r": "rad/s²", "az": "m/s²", "ax": "m/s²",
         "ay": "m/s²", "gyro_p": "rad/s", "gyro_q": "rad/s", "gyro_r": "rad/s",
         "kin_x": "m/s²", "kin_y": "m/s²", "kin_z": "m/s²"}
LABELS = {"p": "roll angular acceleration", "q": "pitch angular acceleration",
          "r": "yaw angular acceleration", "az": "vertical specific force",
          "ax": "longitudinal specific force", "ay": "lateral specific force",
          "gyro_p": "roll gyro vs attitude", "gyro_q": "pitch gyro vs attitude",
          "gyro_r": "yaw gyro vs attitude", "kin_x": "x accelerometer vs velocity",
          "kin_y": "y accelerometer vs velocity", "kin_z": "z accelerometer vs velocity"}
CUTOFF_HZ = {c: 8.0 for c in CHANNELS} | {c: 0.5 for c in SENSOR_CHANNELS}
GRAVITY = 9.80665
"""m/s²."""
K_DEFAULT = 0.1
"""Idle offset k of Ω ∝ m + k when no vehicle file gives it (idle ≈ 10 % of range)."""
TAU_BOUNDS = (0.005, 0.25)
NOMINAL_DELAYS_S = (0.0, 0.005, 0.01)
"""Command-to-motor delays tried for the simulation's own log, s (a log records the
command a step before the motors act on it)."""


@dataclass
class Mods:
    """Changes a candidate makes to the nominal model (defaults change nothing).

    Attributes
    ----------
    tau : float or None
        Motor time constant, s (None: the nominal one).
    delay : float
        Transport delay from command to motor, s.
    thrust_gain : float or ndarray
        Multiplier on rotor thrust (az, p, q), scalar or per sample.
    torque_gain : float or ndarray
        Multiplier on rotor reaction torque (r).
    inertia : float
        Inertia ratio real/nominal: divides the predicted angular accelerations.
    mass : float
        Mass ratio real/nominal: divides the predicted specific forces (az, ax, ay).
    offset : dict
        Constant added to a channel's prediction (channel → value in its unit).
    drag : float
        Extra linear drag on ax and ay, 1/s (specific force −drag · v_body).
    drag_moment : float
        Angular acceleration per body speed of that drag acting at the rotor plane, above
        or below the CG, rad/s² per m/s (q̇ += k v_x, ṗ −= k v_y).
    spin_torque : float
        Yaw angular acceleration added per unit of the rotors' signed spin-up rate,
        rad/s² per (1/s): ``ṙ += c Σ_i sgn(h_i) dΩ_i/dt`` with ``h_i`` the rotor's yaw-torque
        coefficient (a spin-up reaction a simulation without rotor inertia lacks).
    spinup : float
        Multiplier on the rotors' spin-up reaction torque (∝ rotor inertia) in r.
    spin_gain : float or ndarray
        Factor on the rotor speed, so on its spin-up rate, per sample (n,) or per sample and
        rotor (n, n_rotors): a sagging pack slows the rotors and their spin-up with them.
    yaw_per_thrust : float
        Yaw angular acceleration per unit of the rotors' thrust specific force, rad/s² per
        (m/s²): ``ṙ += κ |a_T|``. Rotors twisted about their arms in one sense tilt every
        thrust vector sideways by δ, a yaw moment ``L sin δ Σ T_i`` (``κ = m L tan δ / I_z``).
    damping : float
        Extra rate damping of roll and pitch, 1/s (ṗ −= d p, q̇ −= d q).
    yaw_damping : float
        Extra rate damping of yaw, 1/s (ṙ −= d_r r).
    wind : tuple of float
        Steady wind (north, east), m/s: the drag terms see the air-relative velocity.
    drag_shape : str
        ``"quadratic"``: ``ax`` and ``ay`` under SIM's other drag shape
        (:attr:`NominalModel.drag_quadratic`); ``""``: the one chosen.
    rate_bias : tuple of float
        Constant the gyro adds to the body rates (roll, pitch, yaw), rad/s: the rate terms
        of the angular-acceleration laws (rotor damping, gyroscopic products, the damping
        above) see the logged rates less it.
    """

    tau: float | None = None
    delay: float = 0.0
    thrust_gain: float | np.ndarray = 1.0
    torque_gain: float | np.ndarray = 1.0
    inertia: float = 1.0
    mass: float = 1.0
    offset: dict[str, float] = field(default_factory=dict)
    drag: float = 0.0
    drag_moment: float = 0.0
    spinup: float = 1.0
    spin_gain: float | np.ndarray = 1.0
    spin_torque: float = 0.0
    yaw_per_thrust: float = 0.0
    damping: float = 0.0
    yaw_damping: float = 0.0
    wind: tuple[float, float] = (0.0, 0.0)
    drag_shape: str = ""
    rate_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)


def motor_response(m: np.ndarray, fs: float, tau: float, delay: float = 0.0) -> np.ndarray:
    """Motor outputs delayed by ``delay`` s and lagged by a first-order ``tau`` s, per column."""
    if delay > 0:
        t = np.arange(m.shape[0]) / fs
        m = np.column_stack([np.interp(t - delay, t, m[:, j]) for j in range(m.shape[1])])
    a = float(np.exp(-1.0 / (fs * max(tau, 1e-6))))
    zi = (a * m[0])[None, :]
    out, _ = lfilter([1.0 - a], [1.0, -a], m, axis=0, zi=zi)
    return out


def _wind_axes(flight: Flight) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) body-axis components of a unit wind towards north and towards east
    (``Rᵀ`` of NED → body, ZYX); kept on the flight for as long as its attitude array is the
    same object (a wind fit evaluates them hundreds of times)."""
    cached = flight.__dict__.get("_wind_axes")
    if cached is not None and cached[0] is flight.att:
        return cached[1], cached[2]
    phi, th, psi = flight.att[:, 0], flight.att[:, 1], flight.att[:, 2]
    sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th)
    sp, cp = np.sin(psi), np.cos(psi)
    north = np.column_stack([ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp])
    east = np.column_stack([ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp])
    flight.__dict__["_wind_axes"] = (flight.att, north, east)
    return north, east


def air_velocity(flight: Flight, wind: tuple[float, float]) -> np.ndarray:
    """(n, 3) body-axis velocity relative to a steady horizontal wind (north, east), m/s."""
    if not any(wind):
        return flight.v_body
    north, east = _wind_axes(flight)
    return flight.v_body - (wind[0] * north + wind[1] * east)


def euler_body_rates(att: np.ndarray, fs: float) -> np.ndarray:
    """Body rates p q r (rad/s) implied by ZYX Euler angles ``att`` (n, 3) in rad."""
    d = derivative(att, fs)
    phi, th = att[:, 0], att[:, 1]
    p = d[:, 0] - d[:, 2] * np.sin(th)
    q = d[:, 1] * np.cos(phi) + d[:, 2] * np.sin(phi) * np.cos(th)
    r = -d[:, 1] * np.sin(phi) + d[:, 2] * np.cos(phi) * np.cos(th)
    return np.column_stack([p, q, r])


def kinematic_rates(flight: Flight) -> np.ndarray:
    """(n, 3) filtered body rates implied by the attitude (rad/s), the gyro channels'
    prediction; kept on the flight for as long as its attitude array is the same object."""
    cached = flight.__dict__.get("_kinematic_rates")
    if cached is not None and cached[0] is flight.att:
        return cached[1]
    kin = lowpass(euler_body_rates(flight.att, flight.fs), flight.fs, CUTOFF_HZ["gyro_p"])
    flight.__dict__["_kinematic_rates"] = (flight.att, kin)
    return kin


def kinematic_specific_force(flight: Flight) -> np.ndarray:
    """(n, 3) specific force in body axes (m/s²) implied by the body velocity, the body
    rates and the attitude: ``v̇_b + ω × v_b − Rᵀ (0, 0, g)``."""
    vb = flight.v_body
    acc = derivative(vb, flight.fs) + np.cross(flight.rates, vb)
    return acc - GRAVITY * down_in_body(flight.att)


def measured(flight: Flight) -> dict[str, np.ndarray]:
    """Filtered measured outputs of every channel the flight supports (read-only arrays,
    kept on the flight for as long as its signal arrays are the same objects: the nominal
    fit reads them a hundred times)."""
    signals = (flight.rates, flight.acc, flight.att, flight.v_body)
    key = (frozenset(flight.have), flight.fs)
    cached = flight.__dict__.get("_measured")
    if cached is not None and cached[1] == key and all(
            a is b for a, b in zip(cached[0], signals, strict=True)):
        return dict(cached[2])
    out = _measured(flight)
    for v in out.values():
        v.flags.writeable = False
    flight.__dict__["_measured"] = (signals, key, out)
    return dict(out)


def _measured(flight: Flight) -> dict[str, np.ndarray]:
    fs = flight.fs
    out: dict[str, np.ndarray] = {}
    acc_rates = derivative(lowpass(flight.rates, fs, CUTOFF_HZ["p"]), fs)
    for j, c in enumerate(RATE_CHANNELS):
        out[c] = acc_rates[:, j]
    for j, c in zip((2, 0, 1), FORCE_CHANNELS, strict=True):
        if np.all(np.isfinite(flight.acc[:, j])) and (c == "az" or "vel" in flight.have):
            out[c] = lowpass(flight.acc[:, j], fs, CUTOFF_HZ[c])
    if "roll" in flight.have and np.all(np.isfinite(flight.att)):
        gyro = lowpass(flight.rates, fs, CUTOFF_HZ["gyro_p"])
        for j, c in enumerate(GYRO_CHANNELS):
            out[c] = gyro[:, j]
        if "vel" in flight.have and np.all(np.isfinite(flight.acc)):
            kin = lowpass(flight.acc - kinematic_specific_force(flight), fs,
                          CUTOFF_HZ["kin_x"])
            for j, c in enumerate(KIN_CHANNELS):
                out[c] = kin[:, j]
    return out


MOTOR_TERMS_CACHED = 8
"""Motor-law terms kept per flight (a fit that varies only gains reuses one entry; a delay
or lag fit evaluates a few dozen values)."""


VOLTAGE_CUTOFF_HZ = 2.0
"""Low-pass of the pack voltage in the rotor-speed law, Hz (its sensor noise out; an ESC
follows the voltage at once, the vehicle's response is slower than this anyway)."""


def voltage_ratio(flight: Flight, v_ref: float | None) -> np.ndarray | None:
    """Pack voltage over ``v_ref`` per sample (low-passed at :data:`VOLTAGE_CUTOFF_HZ`), or
    None without a reference or a usable voltage log."""
    if v_ref is None or "vbat" not in flight.have or not np.all(np.isfinite(flight.vbat)):
        return None
    return np.maximum(lowpass(flight.vbat, flight.fs, VOLTAGE_CUTOFF_HZ), 0.1 * v_ref) / v_ref


def _motor_terms(flight: Flight, k: float, tau: float, delay: float,
                 v_ref: float | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(motor response, rotor speed Ω ∝ (m + k) [V/V_ref], Ω², dΩ/dt per s) of ``flight``
    under lag ``tau`` s and delay ``delay`` s, with the pack voltage's factor when ``v_ref``
    (V) is given; for stick commands Ω and its powers are of the collective (column 0) and
    dΩ/dt is the yaw demand's rate. Kept on the flight for as long as its motor array is
    the same object: a fit evaluates them thousands of times."""
    cache = flight.__dict__.setdefault("_motor_terms", {})
    key = (id(flight.motors), float(k), float(tau), float(delay), v_ref)
    hit = cache.get(key)
    if hit is not None and hit[0] is flight.motors:
        return hit[1]
    m_eff = motor_response(flight.motors, flight.fs, tau, delay)
    volts = voltage_ratio(flight, v_ref)
    gain = 1.0 if volts is None else volts[:, None]
    if flight.inputs == "motors":
        om = (np.clip(m_eff, 0.0, 1.0) + k) * gain
        spin = derivative(om, flight.fs)
    else:
        om = (np.clip(m_eff[:, :1], 0.0, 1.0) + k) * gain
        spin = derivative(m_eff[:, 3:4], flight.fs)
    terms = (m_eff, om, om**2, spin)
    if len(cache) >= MOTOR_TERMS_CACHED:
        cache.pop(next(iter(cache)))
    cache[key] = (flight.motors, terms)
    return terms


def _column_gain(gain: float | np.ndarray, n: int) -> np.ndarray:
    g = np.asarray(gain, dtype=float)
    if g.ndim == 0:
        return np.full((n, 1), float(g))
    return g[:, None] if g.ndim == 1 else g


def features(flight: Flight, k: float, tau: float, mods: Mods,
             channels: tuple[str, ...] = CHANNELS, delay: float = 0.0,
             v_ref: float | None = None) -> dict[str, np.ndarray]:
    """Unfiltered regressors of the channels (n, n_features) under ``mods`` (``delay``, s:
    the nominal command-to-motor delay, to which ``mods.delay`` adds; ``v_ref``, V: rotor
    speed scales with the pack voltage over it, None: it does not)."""
    if not any(c in channels for c in (*RATE_CHANNELS, *FORCE_CHANNELS)):
        return {}
    if np.ndim(mods.thrust_gain) or np.ndim(mods.torque_gain) or np.ndim(mods.spin_gain):
        return _features(flight, k, tau, mods, channels, delay, v_ref)
    # a fit that varies what acts after the regressors (inertia, mass, offsets, damping,
    # drag) builds them once: kept on the flight per channel and regressor inputs
    signals = (flight.motors, flight.rates, flight.v_body, flight.att)
    key = (float(k), float(tau if mods.tau is None else mods.tau), float(delay + mods.delay),
           v_ref, tuple(mods.wind), float(mods.thrust_gain), float(mods.torque_gain),
           float(mods.spinup), float(mods.spin_gain), flight.inputs)
    cache = flight.__dict__.setdefault("_features", {})
    out: dict[str, np.ndarray] = {}
    for c in (*channels, "spin"):
        hit = cache.get((key, c))
        if hit is None or not all(a is b for a, b in zip(hit[0], signals, strict=True)):
            break
        out[c] = hit[1]
    else:
        return out
    out = _features(flight, k, tau, mods, channels, delay, v_ref)
    keys = list(dict.fromkeys(kc[0] for kc in cache))  # oldest first
    recent = {*keys[max(len(keys) - FEATURES_KEYS + 1, 0):], key}
    for kc in [kc for kc in cache if kc[0] not in recent]:
        del cache[kc]
    for c, v in out.items():
        v.flags.writeable = False
        cache[(key, c)] = (signals, v)
    return out


FEATURES_KEYS = 2
"""Sets of regressor inputs whose matrices are kept per flight, the latest (a fit of what
acts after the regressors uses one; the nominal fit, one per lag it tries): ≈ 2 MB each
for 90 s at 100 Hz, 15 MB for the 620 s of a long log's windows."""


def _features(flight: Flight, k: float, tau: float, mods: Mods, channels: tuple[str, ...],
              delay: float, v_ref: float | None) -> dict[str, np.ndarray]:
    """:func:`features`, computed."""
    tau_eff = tau if mods.tau is None else mods.tau
    m_eff, om, pw, spin = _motor_terms(flight, k, tau_eff, delay + mods.delay, v_ref)
    p, q, r = flight.rates.T
    vb = flight.v_body
    # horizontal drag sees the air, not the ground
    va = air_velocity(flight, mods.wind) if "ax" in channels or "ay" in channels else vb
    vh2 = vb[:, 0] ** 2 + vb[:, 1] ** 2
    tg = _column_gain(mods.thrust_gain, p.size)
    qg = _column_gain(mods.torque_gain, p.size)
    sg = _column_gain(mods.spin_gain, p.size)
    one = np.ones_like(p)
    if flight.inputs == "motors":
        thrust = pw * tg
        s = _row_sum(thrust)
        # collective thrust makes no moment: only differences between rotors enter
        mom = thrust - _row_mean(thrust) if "p" in channels or "q" in channels else thrust

        def yaw() -> list[np.ndarray]:
            tq = pw * qg
            dom = spin * sg * mods.spinup
            return [tq - _row_mean(tq), dom - _row_mean(dom)]

        def om_mean() -> np.ndarray:
            return _row_mean(om)[:, 0]
    else:  # stick commands: collective and three moment demands
        omt = om[:, 0]
        s = pw[:, 0] * tg.mean(axis=1)
        mom = m_eff[:, 1:] * (omt * tg.mean(axis=1))[:, None]

        def yaw() -> list[np.ndarray]:
            return [m_eff[:, 1:] * (omt * qg.mean(axis=1))[:, None],
                    spin * sg.mean(axis=1)[:, None] * mods.spinup]

        def om_mean() -> np.ndarray:
            return omt
    om_mean = cache(om_mean)  # the drag and drag-moment columns of four channels share it
    build = {
        "az": lambda: _stack([s, vb[:, 2], np.abs(vb[:, 2]) * vb[:, 2], s * vh2]),
        "ax": lambda: _drag_columns(om_mean(), va, 0),
        "ay": lambda: _drag_columns(om_mean(), va, 1),
        # rotor damping: a rolling rotor plane meets the air at a changed angle (∝ rate)
        # rotor drag's moment: the H-force (∝ Ω̄ v) acts at the rotor plane, off the CG
        "p": lambda: _stack([mom, om_mean() * vb[:, 1], q * r, p, one]),
        "q": lambda: _stack([mom, om_mean() * vb[:, 0], p * r, q, one]),
        "r": lambda: _stack([*yaw(), p * q, r, one]),
    }
    out = {c: make() for c, make in build.items() if c in channels}
    out["spin"] = spin
    return out


def _drag_columns(om_mean: np.ndarray, va: np.ndarray, j: int) -> np.ndarray:
    """Regressors of the horizontal specific force along body axis ``j``: rotor drag
    ``Ω̄ v``, per-axis and whole-speed quadratic drag ``|v_j| v_j`` and ``|v| v_j``, offset."""
    v = va[:, j]
    return _stack([om_mean * v, np.abs(v) * v, np.ones_like(v),
                   np.sqrt(_row_sum(va * va)) * v])


def _stack(parts: list[np.ndarray]) -> np.ndarray:
    """The (n, k) regressor matrix of 1-D columns and (n, m) blocks, in column-major order:
    each column is written contiguously (≈ 4× faster than ``np.column_stack``'s strided
    writes for the 9000 samples of a 90 s flight) and its product with the coefficients is
    a sum of whole columns."""
    width = sum(1 if a.ndim == 1 else a.shape[1] for a in parts)
    x = np.empty((parts[0].shape[0], width), order="F")
    j = 0
    for a in parts:
        if a.ndim == 1:
            x[:, j] = a
            j += 1
        else:
            x[:, j:j + a.shape[1]] = a
            j += a.shape[1]
    return x


def _row_sum(a: np.ndarray) -> np.ndarray:
    """``a.sum(axis=1)`` of a 2-D array, bit for bit, as column additions in numpy's own
    order (sequential below eight columns, its eight-way pairwise sum at eight): numpy
    reduces a short row element by element, which costs ≈ 10× more."""
    k = a.shape[1]
    if k < 8:
        out = a[:, 0].copy()
        for j in range(1, k):
            out += a[:, j]
        return out
    if k == 8 and a.flags.c_contiguous:
        c = [a[:, j] for j in range(8)]
        return ((c[0] + c[1]) + (c[2] + c[3])) + ((c[4] + c[5]) + (c[6] + c[7]))
    return a.sum(axis=1)


def _row_mean(a: np.ndarray) -> np.ndarray:
    """``a.mean(axis=1, keepdims=True)`` of a 2-D array, bit for bit (:func:`_row_sum`)."""
    return (_row_sum(a) / a.shape[1])[:, None]


@dataclass
class NominalModel:
    """Coefficients fitted on the simulation log.

    Attributes
    ----------
    k : float
        Idle offset of the rotor-speed law Ω ∝ m + k (dimensionless).
    tau : float
        Motor time constant, s.
    coef : dict
        Channel → least-squares coefficients of its regressors.
    channels : tuple of str
        Channels the simulation log supports.
    delay : float
        Command-to-motor delay of the simulation's own log, s (a logging or mixing step).
    speed : float
        Highest horizontal speed the simulation flew (99th percentile of the fit samples),
        m/s: its drag terms are extrapolated beyond it.
    reference : dict
        Angular-acceleration channel → (slope, standard error) of the simulation's own
        broadband response (:func:`etsid.gap.floors.broadband_slopes`); empty until set.
    drag_law : str
        The horizontal drag law's structure chosen on SIM (:func:`_drag_law`), in words.
    v_ref : float or None
        Pack voltage at which the rotor-speed law holds as fitted, V: rotor speed scales
        with voltage over it (:func:`speed_law`); None: with the command alone.
    drag_quadratic : dict
        ``ax``/``ay`` coefficients of one law for both axes with the speed-squared terms,
        when the law chosen is linear (SIM's speeds could not reject either shape); what
        :attr:`Mods.drag_shape` ``"quadratic"`` predicts with. Empty otherwise.
    """

    k: float
    tau: float
    coef: dict[str, np.ndarray]
    channels: tuple[str, ...]
    delay: float = 0.0
    speed: float = np.inf
    drag_law: str = ""
    v_ref: float | None = None
    drag_quadratic: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def speed_law(self) -> str:
        """The rotor-speed law in words (gap.json's ``nominal.speed_law``)."""
        if self.v_ref is None:
            return f"rotor speed ∝ command + {self.k:.3g} (the pack voltage not in the law)"
        return (f"rotor speed ∝ (command + {self.k:.3g}) × V / {self.v_ref:.3g} V (the pack "
                "voltage scales it, as SIM's own data show)")

    @property
    def speed_limit(self) -> float:
        """Horizontal speed beyond which the model extrapolates, m/s: :attr:`speed` ×
        :data:`ENVELOPE_FACTOR` + :data:`SPEED_MARGIN`."""
        return self.speed * ENVELOPE_FACTOR + SPEED_MARGIN

    def predict(self, flight: Flight, mods: Mods | None = None,
                channels: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Filtered prediction of the channels (default all) for ``flight`` under ``mods``."""
        mods = mods or Mods()
        chans = self.channels if channels is None else tuple(c for c in channels
                                                             if c in self.channels)
        raw = self._unfiltered(flight, mods, chans, self.tau, self.delay)
        out: dict[str, np.ndarray] = {}
        # one filter call per cut-off: filtering is column-wise, the columns share it
        for cutoff in {CUTOFF_HZ[c] for c in raw}:
            group = [c for c in raw if CUTOFF_HZ[c] == cutoff]
            filtered = lowpass_series([raw[c] for c in group], flight.fs, cutoff)
            for j, c in enumerate(group):
                out[c] = filtered[j] + mods.offset[c] if c in mods.offset else filtered[j]
        if any(c in chans for c in GYRO_CHANNELS):
            kin = kinematic_rates(flight)
            for j, c in enumerate(GYRO_CHANNELS):
                if c in chans:
                    out[c] = kin[:, j] + mods.offset.get(c, 0.0)
        for c in KIN_CHANNELS:
            if c in chans:
                out[c] = np.full(flight.n, mods.offset.get(c, 0.0))
        return out

    def predict_unfiltered(self, flight: Flight, mods: Mods | None = None,
                           channels: tuple[str, ...] = RATE_CHANNELS) -> dict[str, np.ndarray]:
        """The model's angular accelerations (rad/s²) before the analysis low-pass, with its
        own lag and delay (those of ``mods`` added), for a fit in another band."""
        chans = tuple(c for c in channels if c in self.channels and c in RATE_CHANNELS)
        return self._unfiltered(flight, mods or Mods(), chans, self.tau, self.delay)

    def thrust_acceleration(self, flight: Flight, mods: Mods, tau: float, delay: float
                            ) -> np.ndarray:
        """|Specific force| of the rotors' thrust (n,), m/s², as SIM's vertical-force law
        predicts it under ``mods`` (its thrust column alone: no drag terms)."""
        if flight.inputs == "motors":
            _, _, pw, _ = self._motor_terms_under(flight, mods, tau, delay)
            s = _row_sum(pw * _column_gain(mods.thrust_gain, pw.shape[0]))
        else:
            s = features(flight, self.k, tau, mods, ("az",), delay, self.v_ref)["az"][:, 0]
        return np.abs(self.coef["az"][0]) * s

    def _unfiltered(self, flight: Flight, mods: Mods, chans: tuple[str, ...], tau: float,
                    delay: float) -> dict[str, np.ndarray]:
        """The model channels of ``chans`` before the analysis low-pass (no offsets)."""
        # with motor outputs the thrust, torque and spin-up gains act on the per-rotor
        # columns alone: the other columns are built once at unit gains and the rotors'
        # part is summed from Ω², dΩ/dt and the gains (no matrix built per gain value)
        by_rotor = flight.inputs == "motors"
        feats = features(flight, self.k, tau, _unit_gains(mods) if by_rotor else mods, chans,
                         delay, self.v_ref)
        coefs = {c: self.drag_quadratic[c] if mods.drag_shape == "quadratic"
                 and c in self.drag_quadratic else self.coef[c]
                 for c in chans if c not in SENSOR_CHANNELS}
        rotors = self._rotor_part(flight, mods, chans, tau, delay, coefs) if by_rotor else {}
        raw: dict[str, np.ndarray] = {}
        for c in chans:
            if c in SENSOR_CHANNELS:
                continue
            coef = coefs[c]
            if c in rotors:  # filtering is linear: filter the sum once
                y = _regression(self, c, feats[c], self._other_terms(c, coef)) + rotors[c]
            else:
                y = _regression(self, c, feats[c], coef)
            if c == "r" and mods.spin_torque:
                n_spin = feats["spin"].shape[1]
                signs = (np.sign(self.coef["r"][:n_spin]) if flight.inputs == "motors"
                         else np.ones(1))
                y = y + mods.spin_torque * (feats["spin"] @ signs)
            if c == "r" and mods.yaw_per_thrust:
                y = y + mods.yaw_per_thrust * self.thrust_acceleration(flight, mods, tau, delay)
            if c in RATE_CHANNELS and any(mods.rate_bias):  # SIM's own rate terms: torques
                y = y + _rate_bias_change(flight.rates, mods.rate_bias, c, coef)
            if c in RATE_CHANNELS:
                if mods.inertia != 1.0:  # y / 1.0 is y: no copy
                    y = y / mods.inertia
            elif mods.mass != 1.0:
                y = y / mods.mass
            if c in ("ax", "ay") and mods.drag:
                y = y - mods.drag * air_velocity(flight, mods.wind)[:, 0 if c == "ax" else 1]
            if mods.damping and c in ("p", "q"):
                j = 0 if c == "p" else 1
                y = y - mods.damping * (flight.rates[:, j] - mods.rate_bias[j])
            if mods.yaw_damping and c == "r":
                y = y - mods.yaw_damping * (flight.rates[:, 2] - mods.rate_bias[2])
            if mods.drag_moment and c in ("p", "q"):
                sign, j = (-1.0, 1) if c == "p" else (1.0, 0)
                y = y + sign * mods.drag_moment * flight.v_body[:, j]
            raw[c] = y
        return raw

    def _motor_terms_under(self, flight: Flight, mods: Mods, tau: float, delay: float
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:func:`_motor_terms` with the lag and delay of ``mods`` (its lag replaces
        ``tau`` s, its delay adds to ``delay`` s)."""
        return _motor_terms(flight, self.k, tau if mods.tau is None else mods.tau,
                            delay + mods.delay, self.v_ref)

    def _rotor_part(self, flight: Flight, mods: Mods, chans: tuple[str, ...], tau: float,
                    delay: float, coefs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The per-rotor columns' share of ``az``, ``p``, ``q`` and ``r`` under ``mods``
        (motor outputs): ``Σ T_i (c_0 + c_3 v_h²)`` with ``T_i = Ω_i² g_i``, the moment
        columns' ``Σ T_i (c_i − c̄)``, and in yaw the reaction and spin-up torques', as
        :func:`_features` builds them. The unit-gain sums are kept; a constant or per-sample
        gain scales them, a per-rotor gain scales the weights, and only a gain per rotor and
        sample needs its own products."""
        _, _, pw, spin = self._motor_terms_under(flight, mods, tau, delay)
        unit = self._rotor_sums(flight, pw, spin, coefs)
        weights, sums = unit["weights"], unit["sums"]
        thrust = _gained(sums[0], pw, weights[0], mods.thrust_gain)
        out: dict[str, np.ndarray] = {}
        if "az" in chans and "az" in coefs:
            w = coefs["az"]
            out["az"] = thrust[:, 0] * (w[0] + w[3] * unit["vh2"])
        for j, c in ((1, "p"), (2, "q")):
            if c in chans and c in coefs:
                out[c] = thrust[:, j]
        if "r" in chans and "r" in coefs:
            torque = _gained(sums[1], pw, weights[1], mods.torque_gain)
            spun = _gained(sums[2], spin, weights[2], mods.spin_gain)
            out["r"] = torque[:, 0] + spun[:, 0] * mods.spinup
        return out

    def _rotor_sums(self, flight: Flight, pw: np.ndarray, spin: np.ndarray,
                    coefs: dict[str, np.ndarray]) -> dict[str, Any]:
        """Per-rotor weights (thrust: ``1``, ``c_p − c̄_p``, ``c_q − c̄_q``; reaction torque;
        spin-up torque) and their sums over the rotors at unit gains, kept for as long as
        ``Ω²``, ``dΩ/dt``, the velocity and the coefficients are the same objects."""
        inputs = (pw, spin, flight.v_body, *(coefs.get(c) for c in ROTOR_CHANNELS))
        kept = self.__dict__.get("_rotor_sums_kept")
        if kept is not None and all(a is b for a, b in zip(kept[0], inputs, strict=True)):
            return kept[1]
        m = pw.shape[1]

        def centred(c: str, part: slice) -> np.ndarray:
            w = coefs[c][part] if c in coefs else np.zeros(m)
            return w - np.mean(w)

        weights = (np.column_stack([np.ones(m), centred("p", slice(0, m)),
                                    centred("q", slice(0, m))]),
                   centred("r", slice(0, m))[:, None], centred("r", slice(m, 2 * m))[:, None])
        sums = (pw @ weights[0], pw @ weights[1], spin @ weights[2])
        vb = flight.v_body
        unit = {"weights": weights, "sums": sums, "vh2": vb[:, 0] ** 2 + vb[:, 1] ** 2}
        self.__dict__["_rotor_sums_kept"] = (inputs, unit)
        return unit

    def _other_terms(self, c: str, coef: np.ndarray) -> np.ndarray:
        """``coef`` with the per-rotor columns' entries of channel ``c`` at 0 (the same array
        for the same ``coef``, so the product with kept regressors is kept too)."""
        cache = self.__dict__.setdefault("_other_coefs", {})
        hit = cache.get(c)
        if hit is not None and hit[0] is coef:
            return hit[1]
        out = coef.copy()
        if c == "az":
            out[[0, 3]] = 0.0
        else:  # the leading per-rotor columns (in yaw: reaction and spin-up, 2 × rotors)
            out[:len(coef) - (4 if c in ("p", "q") else 3)] = 0.0
        cache[c] = (coef, out)
        return out


def _gained(unit_sums: np.ndarray, per_rotor: np.ndarray, weights: np.ndarray,
            gain: float | np.ndarray) -> np.ndarray:
    """``(per_rotor ⊙ g) @ weights`` from its unit-gain value ``unit_sums``: a constant or
    per-sample gain (n,) scales the sums, a per-rotor gain (1, m) the weights; a gain per
    rotor and sample (n, m) is multiplied out."""
    g = np.asarray(gain, dtype=float)
    if g.ndim == 0:
        return unit_sums if float(g) == 1.0 else unit_sums * float(g)
    if g.ndim == 1:
        return unit_sums * g[:, None]
    if g.shape[0] == 1:
        return per_rotor @ (weights * g[0][:, None])
    return (per_rotor * g) @ weights


ROTOR_CHANNELS = ("az", "p", "q", "r")
"""Channels with per-rotor regressor columns (:meth:`NominalModel._rotor_part`)."""


def _unit_gains(mods: Mods) -> Mods:
    """``mods`` with its thrust, torque and spin-up gains at 1 (what the regressors other
    than the per-rotor columns are built under)."""
    if (not (np.ndim(mods.thrust_gain) or np.ndim(mods.torque_gain)
             or np.ndim(mods.spin_gain))
            and mods.thrust_gain == 1.0 and mods.torque_gain == 1.0
            and mods.spin_gain == 1.0 and mods.spinup == 1.0):
        return mods
    return replace(mods, thrust_gain=1.0, torque_gain=1.0, spin_gain=1.0, spinup=1.0)


RATE_TERMS = {"p": (1, 2, 0), "q": (0, 2, 1), "r": (0, 1, 2)}
"""Angular-acceleration channel → (the two rates of its gyroscopic product, its own rate):
the regressors ``[…, product, rate, 1]`` end every rate channel's law."""


def _rate_bias_change(rates: np.ndarray, bias: tuple[float, float, float], c: str,
                      coef: np.ndarray) -> np.ndarray:
    """Change of channel ``c``'s prediction, rad/s², when its rate terms see the rates less
    a gyro bias ``bias`` (rad/s): ``c_prod (a−b_a)(b−b_b) − c_prod a b − c_rate b_own``."""
    i, j, own = RATE_TERMS[c]
    bi, bj = bias[i], bias[j]
    product = -bi * rates[:, j] - bj * rates[:, i] + bi * bj
    return coef[-3] * product - coef[-2] * bias[own]


def _regression(model: NominalModel, c: str, x: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """``x @ coef``; while ``x`` is a kept (read-only) regressor matrix, the product of
    channel ``c`` is kept on the model too (a fit of what acts after the regression, such as
    an inertia or a damping, reuses it at every evaluation)."""
    if x.flags.writeable:
        return x @ coef
    cache = model.__dict__.setdefault("_products", {})
    hit = cache.get(c)
    if hit is not None and hit[0] is x and hit[1] is coef:
        return hit[2]
    y = x @ coef
    y.flags.writeable = False
    cache[c] = (x, coef, y)
    return y


ENVELOPE_FACTOR = 1.2
SPEED_MARGIN = 0.5
"""m/s: the nominal model is trusted up to ENVELOPE_FACTOR × the fastest (99th percentile)
horizontal speed the simulation flew, plus this margin; beyond it, it extrapolates."""

QUADRATIC_SPEED = 2.0
"""m/s: a simulation flown slower than this leaves its translational-lift term unfitted
(coefficient 0): the drag law's shape is poorly determined."""

RIDGE = 1e-3
"""Ridge weight on the normalised regressors (× sample count). A mixer drives the motors
only along its roll, pitch, yaw and collective patterns, so per-motor moment coefficients
are barely determined across the other directions; a near-zero ridge let noise set them
(an octocopter's eight roll coefficients came out lopsided and a weak motor, which moves
the trims along a new direction, was mispredicted 30-fold). This ridge keeps each
coefficient vector in the span the simulation excites, at a cost of ≈ 1 % of SIM's own
error."""


def _solve(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    scale = np.sqrt(np.mean(x**2, axis=0)) + 1e-12
    xs = x / scale
    a = xs.T @ xs + RIDGE * len(y) * np.eye(x.shape[1])
    return np.linalg.solve(a, xs.T @ y) / scale


def _unexcited(flight: Flight, mask: np.ndarray) -> dict[str, list[int]]:
    """Regressors the simulation does not excite enough to extrapolate from (their
    coefficient is fixed at 0): vertical-speed terms below 0.3 m/s of climb-rate spread,
    the translational-lift term below :data:`QUADRATIC_SPEED` of horizontal speed (the
    horizontal drag law's shape is chosen on SIM's own data, :func:`_drag_law`). The last
    answer is kept on the flight (the nominal fit asks a hundred times with one mask)."""
    cached = flight.__dict__.get("_unexcited")
    if cached is not None and cached[0] is flight.v_body and np.array_equal(cached[1], mask):
        return {c: list(v) for c, v in cached[2].items()}
    vb = flight.v_body[mask]
    speed = float(np.max(np.hypot(vb[:, 0], vb[:, 1]))) if vb.size else 0.0
    climb = float(np.std(vb[:, 2])) * 4.0 if vb.size else 0.0
    out: dict[str, list[int]] = {"az": [], "ax": [], "ay": []}
    if climb < 0.3:
        out["az"].append(1)
    if speed < QUADRATIC_SPEED:
        out["az"].append(3)
    flight.__dict__["_unexcited"] = (flight.v_body, np.array(mask, dtype=bool), out)
    return {c: list(v) for c, v in out.items()}


DRAG_TERMS = (0, 1, 3)
"""Columns of :func:`_drag_columns` that are drag (rotor drag ``Ω̄ v``, ``|v_j| v_j``,
``|v| v_j``): each must oppose the velocity (coefficient ≤ 0). A simulation flown mostly
along one body axis leaves the other axis's terms barely determined, and an unconstrained
fit can trade a dissipative term against an anti-dissipative one at SIM's speeds that
extrapolates absurdly under a wind (third-party pair 331-21: ``+0.031 |v_y| v_y`` beside
``−0.107 Ω̄ v_y``; the true 3.7 m/s wind predicted the lateral force 4× worse than no wind)."""
OFFSET_TERM = 2
QUADRATIC_TERMS = (1, 3)
STRUCTURE_Z = 2.0
"""The horizontal drag law starts as the simplest structure: one law for both body axes
(each with its own offset), linear in the air velocity (rotor drag ``Ω̄ v``). The
speed-squared terms, then separate laws per axis, are taken only where they predict the
last 40 % of SIM's samples better, fitted on the first 60 %, by more than this many
standard errors of the difference. A multirotor's drag is close to symmetric in x and y,
and at the ≤ 1 m/s a simulation usually flies sideways a quadratic drag is below the
noise: per-axis laws left the lateral one at zero and a wind SIM lacks was not found
(third-party pairs 332-17 and 334-16: the wind law took 0.20 and −0.05 of the held-out
excess with per-axis linear laws, 0.97 and 0.93 with one quadratic law, winds within
10 % of the truth instead of 2× too strong)."""


def _dissipative_fit(x: np.ndarray, y: np.ndarray, keep: np.ndarray,
                     signed: tuple[int, ...]) -> np.ndarray:
    """Ridge least squares (:func:`_solve`) over the columns in ``keep`` with every
    ``signed`` coefficient ≤ 0: the term pushing hardest the wrong way (in units of its RMS
    force) is dropped and the rest refitted until none is left."""
    keep = keep.copy()
    while True:
        full = np.zeros(x.shape[1])
        full[keep] = _solve(x[:, keep], y)
        wrong = [j for j in signed if keep[j] and full[j] > 0.0]
        if not wrong:
            return full
        keep[max(wrong, key=lambda j: full[j] * np.sqrt(np.mean(x[:, j] ** 2)))] = False


Pair = tuple[np.ndarray, np.ndarray]


def _per_axis(xs: Pair, ys: Pair, keep: np.ndarray) -> Pair:
    """Separate dissipative drag laws for x and y."""
    return (_dissipative_fit(xs[0], ys[0], keep, DRAG_TERMS),
            _dissipative_fit(xs[1], ys[1], keep, DRAG_TERMS))


def _shared(xs: Pair, ys: Pair, keep: np.ndarray) -> Pair:
    """One dissipative drag law for x and y, each axis with its own offset."""
    n_x, width = xs[0].shape
    stacked = np.zeros((n_x + len(xs[1]), width + 1))
    stacked[:n_x, :width] = xs[0]
    stacked[n_x:, :width] = xs[1]
    stacked[n_x:, OFFSET_TERM] = 0.0
    stacked[n_x:, width] = xs[1][:, OFFSET_TERM]
    both = _dissipative_fit(stacked, np.concatenate(ys), np.append(keep, keep[OFFSET_TERM]),
                            DRAG_TERMS)
    lateral = both[:width].copy()
    lateral[OFFSET_TERM] = both[width]
    return both[:width], lateral


def _drag_law(xs: Pair, ys: Pair, n_per_sample: float) -> tuple[Pair, str, Pair | None]:
    """Coefficients of ``ax`` and ``ay``, the structure chosen (:data:`STRUCTURE_Z`;
    ``n_per_sample``: independent samples per sample of the low-passed signals) and, when
    that structure is linear, the coefficients of one law for both axes with the
    speed-squared terms: the shape SIM's data could not reject either."""
    cut = int(0.6 * len(ys[0]))
    early = tuple(x[:cut] for x in xs), tuple(y[:cut] for y in ys)
    late = tuple(x[cut:] for x in xs), tuple(y[cut:] for y in ys)
    linear = np.ones(xs[0].shape[1], dtype=bool)
    linear[list(QUADRATIC_TERMS)] = False
    full = np.ones_like(linear)

    def late_error(law, keep: np.ndarray) -> np.ndarray:
        coefs = law(*early, keep)
        return sum((y - x @ c) ** 2 for x, y, c in zip(*late, coefs, strict=True))

    def better(a: np.ndarray, b: np.ndarray) -> bool:
        gain = b - a
        n_eff = max(gain.size * n_per_sample, 2.0)
        return float(np.mean(gain)) > STRUCTURE_Z * float(np.std(gain)) / np.sqrt(n_eff)

    law, keep = _shared, linear
    if len(late[1][0]) >= 10:
        err = late_error(law, keep)
        quad = late_error(_shared, full)
        if better(quad, err):
            keep, err = full, quad
        if better(late_error(_per_axis, keep), err):
            law = _per_axis
    shape = "linear + quadratic" if keep.all() else "linear"
    name = (f"one {shape} law for x and y" if law is _shared
            else f"separate {shape} laws per axis")
    return law(xs, ys, keep), name, None if keep.all() else _shared(xs, ys, full)


def fit_coefficients(flight: Flight, mask: np.ndarray, k: float, tau: float,
                     channels: tuple[str, ...], delay: float = 0.0,
                     v_ref: float | None = None
                     ) -> tuple[dict[str, np.ndarray], str, dict[str, np.ndarray]]:
    """Least-squares coefficients per channel on the samples in ``mask``, the horizontal
    drag law's structure: dissipative (:data:`DRAG_TERMS`), chosen on SIM's own data
    (:func:`_drag_law`), and ``ax``/``ay`` under the speed-squared law SIM could not reject
    (empty when that is the law chosen)."""
    meas = measured(flight)
    feats = features(flight, k, tau, Mods(), delay=delay, v_ref=v_ref)
    drop = _unexcited(flight, mask)
    coef = {}
    for c in channels:
        if c in SENSOR_CHANNELS or (c in ("ax", "ay") and "ax" in channels
                                    and "ay" in channels):
            continue
        x = lowpass(feats[c], flight.fs, CUTOFF_HZ[c])[mask]
        keep = np.array([j not in drop.get(c, []) for j in range(x.shape[1])])
        coef[c] = _dissipative_fit(x, meas[c][mask], keep,
                                   DRAG_TERMS if c in ("ax", "ay") else ())
    if "ax" in channels and "ay" in channels:
        xs = tuple(lowpass(feats[c], flight.fs, CUTOFF_HZ[c])[mask] for c in ("ax", "ay"))
        ys = (meas["ax"][mask], meas["ay"][mask])
        (coef["ax"], coef["ay"]), law, alt = _drag_law(xs, ys,
                                                        2.0 * CUTOFF_HZ["ax"] / flight.fs)
        return coef, law, {} if alt is None else {"ax": alt[0], "ay": alt[1]}
    return coef, "", {}


def _weighted_sse(flight: Flight, mask: np.ndarray, k: float, tau: float,
                  channels: tuple[str, ...], delay: float = 0.0,
                  v_ref: float | None = None) -> float:
    meas = measured(flight)
    coef, _, _ = fit_coefficients(flight, mask, k, tau, channels, delay, v_ref)
    model = NominalModel(k, tau, coef, channels, delay, v_ref=v_ref)
    pred = model.predict(flight)
    total = 0.0
    for c in channels:
        if c in SENSOR_CHANNELS:
            continue
        e = (meas[c] - pred[c])[mask]
        total += float(np.mean(e**2) / np.var(meas[c][mask]))
    return total


K_SEARCH = (0.0, 0.3)
"""Bounds of the idle offset ``k`` when a voltage-scaled speed law is fitted on SIM: the
voltage's drift over a flight moves the hover command along the law, which fixes ``k``."""

MIN_VOLTAGE_COVER = 0.5
"""Least share of REAL's airborne samples whose pack voltage lies within SIM's (1st to 99th
percentile) for the voltage-scaled law to be used: its idle offset is fixed only over SIM's
own span (the flights' own voltage drift), and a 0.05 error in ``k`` is a 2-3 % thrust error
at a 10 % lower voltage. Beyond it, the command-only law is kept and a voltage effect is a
candidate (``battery_sag``). On the seen third-party pairs a sagging REAL has 0 % of its
samples there, every other pair 20-100 %."""


def voltage_covered(sim: Flight, real: Flight) -> float | None:
    """Share of REAL's airborne pack voltage within SIM's 1st-99th percentile, or None when
    either log lacks a usable voltage."""
    if "vbat" not in sim.have or "vbat" not in real.have:
        return None
    vs, vr = sim.vbat[sim.airborne], real.vbat[real.airborne]
    vs, vr = vs[np.isfinite(vs)], vr[np.isfinite(vr)]
    if vs.size < 2 or vr.size < 2:
        return None
    lo, hi = np.quantile(vs, (0.01, 0.99))
    return float(np.mean((vr >= lo) & (vr <= hi)))


def _late_error(flight: Flight, mask: np.ndarray, k: float, tau: float, delay: float,
                v_ref: float | None) -> np.ndarray:
    """Squared ``az`` errors on the last 40 % of ``mask`` of coefficients fitted on its
    first 60 %."""
    idx = np.flatnonzero(mask)
    cut = idx[int(0.6 * idx.size)]
    early, late = mask & (np.arange(mask.size) < cut), mask & (np.arange(mask.size) >= cut)
    coef, _, _ = fit_coefficients(flight, early, k, tau, ("az",), delay, v_ref)
    x = lowpass(features(flight, k, tau, Mods(), ("az",), delay, v_ref)["az"], flight.fs,
                CUTOFF_HZ["az"])
    return (measured(flight)["az"] - x @ coef["az"])[late] ** 2


def speed_law(flight: Flight, mask: np.ndarray, k: float | None, tau: float, delay: float
              ) -> tuple[float, float | None]:
    """(k, v_ref): whether rotor speed scales with the pack voltage, chosen on SIM's own
    ``az``.

    Most ESCs set a duty cycle, so a rotor's speed goes as the pack voltage times the
    command and its thrust as the voltage squared: a simulation with a battery model drifts
    in thrust per command as its pack drains. The voltage-scaled law is kept when, fitted on
    SIM's first 60 %, it predicts ``az`` on the last 40 % better than the command-only law
    by :data:`STRUCTURE_Z` standard errors of the difference, each law with the same ``k``
    when given, else each with its own ``k`` fitted in :data:`K_SEARCH` (so the voltage law
    can win only by the voltage: on a pack that does not drain the two laws are one, and a
    refitted idle offset alone is not a voltage law); otherwise the command alone sets the
    speed (``k`` given, or :data:`K_DEFAULT`) and a voltage effect is a candidate
    (``battery_sag``).
    """
    k_plain = K_DEFAULT if k is None else float(k)
    if "vbat" not in flight.have or "az" not in measured(flight) or mask.sum() < 20:
        return k_plain, None
    if not np.all(np.isfinite(flight.vbat)) or np.median(flight.vbat[mask]) <= 0:
        return k_plain, None
    volts = lowpass(flight.vbat, flight.fs, VOLTAGE_CUTOFF_HZ)[mask]  # the drift, not noise
    v_ref = float(np.median(volts))
    k_cmd = k_volt = k_plain
    if k is None:  # each law with its own idle offset: the voltage law wins by the voltage
        idx = np.flatnonzero(mask)
        early = mask & (np.arange(mask.size) < idx[int(0.6 * idx.size)])

        def own_k(ref: float | None) -> float:
            r = minimize_scalar(lambda v: float(np.mean(_late_error(flight, early, v, tau,
                                                                    delay, ref))),
                                bounds=K_SEARCH, method="bounded", options={"xatol": 5e-3})
            return float(r.x)
        k_cmd, k_volt = own_k(None), own_k(v_ref)
    gain = _late_error(flight, mask, k_cmd, tau, delay, None) - _late_error(
        flight, mask, k_volt, tau, delay, v_ref)
    n_eff = max(gain.size * 2.0 * CUTOFF_HZ["az"] / flight.fs, 2.0)
    if float(np.mean(gain)) > STRUCTURE_Z * float(np.std(gain)) / np.sqrt(n_eff):
        return k_volt, v_ref
    return k_plain, None


def fit_nominal(flight: Flight, mask: np.ndarray | None = None, k: float | None = None,
                law: tuple[float, float | None] | None = None, voltage: bool = True
                ) -> NominalModel:
    """Fit the nominal model on the airborne part of the simulation (or on ``mask``).

    Parameters
    ----------
    flight : Flight
        The simulation, prepared.
    mask : ndarray, optional
        Samples to fit on (default: airborne).
    k : float, optional
        Idle offset of Ω ∝ m + k (from a vehicle file); default :data:`K_DEFAULT` — it is
        weakly identifiable from hover data, whose command range is narrow.
    law : (float, float or None), optional
        The rotor-speed law ``(k, v_ref)`` to use as it is (a refit of a fitted model's
        structure); default: chosen on ``flight`` by :func:`speed_law`.
    voltage : bool
        Whether a voltage-scaled rotor-speed law may be chosen (see :func:`voltage_covered`).

    The motor time constant ``tau`` is found by a bounded scalar search on the rate
    channels; every other coefficient by least squares.
    """
    mask = flight.airborne if mask is None else mask
    channels = tuple(c for c in CHANNELS if c in measured(flight))
    rates = tuple(c for c in channels if c in RATE_CHANNELS)
    k_given = k if law is None else law[0]
    k = K_DEFAULT if k_given is None else float(k_given)
    best = (np.inf, 0.0, 0.0)
    for delay in NOMINAL_DELAYS_S:
        r = minimize_scalar(lambda v, d=delay: _weighted_sse(flight, mask, k, v, rates, d),
                            bounds=TAU_BOUNDS, method="bounded", options={"xatol": 2e-3})
        if r.fun < best[0]:
            best = (float(r.fun), float(r.x), delay)
    _, tau, delay = best
    if law is None:
        law = speed_law(flight, mask, k_given, tau, delay) if voltage else (k, None)
    k, v_ref = law
    coef, drag_law, quadratic = fit_coefficients(flight, mask, k, tau, channels, delay, v_ref)
    vb = flight.v_body[mask]
    speed = float(np.quantile(np.hypot(vb[:, 0], vb[:, 1]), 0.99)) if vb.size else 0.0
    return NominalModel(k, tau, coef, channels, delay, speed, drag_law=drag_law, v_ref=v_ref,
                        drag_quadratic=quadratic)
