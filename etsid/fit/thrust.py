"""Thrust per weight from the vertical specific force: the thrust curve and hover command.

Per rotor, thrust over mass is f_j = K x_j² with x_j = Ω_j/Ω_top(V0) from the motor law of
:func:`etsid.fit.signals.motor_state` (idle ratio ι = Ω_idle/Ω_top). Along the body z axis
the accelerometer reads the sum: −a_z = K Σ_j x_j² + c_w v_z,body (the v_z term: climb
inflow and vertical drag), + c_h Σ_j x_j² (u² + v²) (translational lift: at the same rotor
speed a rotor moving edgewise makes more thrust, its inflow swept away). K (m/s² per rotor
at full command and V0) and ι are fitted, ι by profile likelihood (K linear for each ι).
Mass and the thrust coefficient only ever appear as their ratio: a log of accelerations
cannot separate them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from etsid.fit.regress import LinearFit, effective_n, robust_lstsq
from etsid.fit.signals import Flight, motor_state

CHI2_95 = 3.841
"""χ²₁ 95 % quantile: the profile-likelihood interval threshold."""

IDLE_GRID = np.round(np.arange(0.0, 0.6001, 0.005), 4)
"""Idle ratios tried, Ω_idle/Ω_top."""

IDLE_MODEL_SE = 0.0093
"""Standard error of the idle ratio that the thrust law's own misfit adds (absolute, in
units of Ω_top), measured on the development seeds of ``benchmarks/fit.py`` (docs/fit.md):
ι only bends the thrust curve over the narrow command range of a flight, so a small misfit
of the law moves it further than the profile likelihood's sampling interval says."""


@dataclass
class ThrustFit:
    """Result of :func:`fit_thrust`."""

    k: float                     # m/s² per rotor at full command, V0
    k_se: float
    idle: float                  # ι = Ω_idle/Ω_top(V0)
    idle_interval: tuple[float, float]
    k_range: tuple[float, float]  # 95 % range of K over the ι interval (with K's own se)
    ends: tuple[tuple[float, float], ...]  # (K, ι) at the ends of ι's interval
    c_w: float                   # 1/s, −a_z per m/s of body-z velocity
    fit: LinearFit
    n_rotors: int


def _design(flights: list[Flight], idle: float, tau: float, delay: float
            ) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = [], []
    for f in flights:
        if f.accel is None:
            continue
        x = motor_state(f, idle, tau, delay)
        cols = [np.sum(x * x, axis=1)]
        vb = f.vel_body if f.vel_body is not None else np.zeros((len(f.t), 3))
        cols.append(vb[:, 2])
        cols.append(cols[0] * (vb[:, 0] ** 2 + vb[:, 1] ** 2))
        reg = f.lowpass(np.column_stack(cols))
        y = f.lowpass(-f.accel[:, 2])
        xs.append(reg[f.hover])
        ys.append(y[f.hover])
    if not xs:
        return np.zeros((0, 3)), np.zeros(0)
    return np.vstack(xs), np.concatenate(ys)


def fit_thrust(flights: list[Flight], tau: float, delay: float) -> ThrustFit | None:
    """Fit K and ι (module docstring); None when no flight has an accelerometer."""
    ssr = []
    fits: list[tuple[float, np.ndarray, float]] = []
    for idle in IDLE_GRID:
        x, y = _design(flights, float(idle), tau, delay)
        if len(y) < 50:
            return None
        ok = np.isfinite(y) & np.all(np.isfinite(x), axis=1)
        coef = np.linalg.lstsq(x[ok], y[ok], rcond=None)[0]
        r = y[ok] - x[ok] @ coef
        ssr.append(float(r @ r))
        fits.append((float(idle), coef, float(r @ r)))
    ssr_a = np.array(ssr)
    best = int(np.argmin(ssr_a))
    idle = float(IDLE_GRID[best])
    if 0 < best < IDLE_GRID.size - 1:   # parabolic interpolation between grid points
        y0, y1, y2 = ssr_a[best - 1:best + 2]
        den = y0 - 2 * y1 + y2
        step = float(IDLE_GRID[1] - IDLE_GRID[0])
        if den > 0:
            idle += float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5)) * step
    x, y = _design(flights, idle, tau, delay)
    lin = robust_lstsq(x, y)
    n_eff = effective_n(lin.resid)
    accept = n_eff * np.log(ssr_a / ssr_a[best]) <= CHI2_95
    idx = np.flatnonzero(accept)
    # the sampling interval, widened by the law's measured misfit (half-widths in quadrature)
    half = [idle - float(IDLE_GRID[idx.min()]), float(IDLE_GRID[idx.max()]) - idle]
    lo, hi = (idle - float(np.hypot(half[0], 1.96 * IDLE_MODEL_SE)),
              idle + float(np.hypot(half[1], 1.96 * IDLE_MODEL_SE)))
    inside = np.flatnonzero(np.abs(IDLE_GRID - 0.5 * (lo + hi)) <= 0.5 * (hi - lo) + 1e-9)
    idx = inside if inside.size else idx
    lo = max(lo, 0.0)
    ks = np.array([fits[i][1][0] for i in idx])
    k_se = float(lin.se[0])
    n_rot = flights[0].motors.shape[1]
    return ThrustFit(k=float(lin.coef[0]), k_se=k_se, idle=idle,
                     idle_interval=(lo, hi),
                     k_range=(float(ks.min() - 1.96 * k_se), float(ks.max() + 1.96 * k_se)),
                     ends=tuple((float(np.interp(e, IDLE_GRID, [f[1][0] for f in fits])), e)
                                for e in (lo, hi)),
                     c_w=float(lin.coef[1]), fit=lin, n_rotors=n_rot)


def hover_command(flights: list[Flight], gravity: float
                  ) -> tuple[float, float, float, float] | None:
    """Mean motor output at −a_z = g (level, unaccelerated) at V0, and its change per volt.

    Regression of the mean output on [1, (−a_z − g)/g, V/V0 − 1] over airborne rows
    (filtered both sides). Returns (m_hover, se, dm/d(V/V0), se) or None without
    accelerometer.
    """
    xs, ys = [], []
    for f in flights:
        if f.accel is None:
            continue
        reg = np.column_stack([np.ones(len(f.t)), (-f.accel[:, 2] - gravity) / gravity,
                               f.vratio - 1.0])
        reg[:, 1:] = f.lowpass(reg[:, 1:])
        y = f.lowpass(f.motors.mean(axis=1))
        xs.append(reg[f.hover])
        ys.append(y[f.hover])
    if not xs:
        return None
    x, y = np.vstack(xs), np.concatenate(ys)
    if np.ptp(x[:, 2]) < 1e-6:
        x = x[:, :2]
    lin = robust_lstsq(x, y)
    dv = float(lin.coef[2]) if x.shape[1] == 3 else 0.0
    dv_se = float(lin.se[2]) if x.shape[1] == 3 else float("nan")
    return float(lin.coef[0]), float(lin.se[0]), dv, dv_se
