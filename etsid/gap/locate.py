"""Where the residual concentrates: channels, time segments and a regime of one
scheduling variable (height, speed, thrust, command rate, battery voltage, time)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from etsid.gap.nominal import LABELS, UNITS
from etsid.gap.signals import Flight, derivative, lowpass, true_runs

N_BINS = 8
LOWEST_FLOWN_QUANTILE = 0.01
"""The lowest flown height is this quantile of the airborne heights (one stray sample
does not set where the fitted law's excess is largest)."""
MIN_ETA2 = 0.15
"""Least share of the residual variance one variable's bins must explain to name it."""
SEGMENT_WINDOW_S = 1.0
MAX_SEGMENTS = 12
VARIABLE_TEXT = {"alt": "height above ground", "speed": "horizontal body speed",
                 "thrust": "mean motor output", "command_rate": "motor command rate",
                 "vbat": "battery voltage", "time": "time"}
VARIABLE_UNITS = {"alt": "m", "speed": "m/s", "thrust": "1", "command_rate": "1/s",
                  "vbat": "V", "time": "s"}


@dataclass
class Regime:
    """A range of one scheduling variable where a channel's residual lives."""

    channel: str
    variable: str
    lo: float
    hi: float
    eta2: float
    mean_inside: float
    description: str


def scheduling_variables(flight: Flight) -> dict[str, np.ndarray]:
    """Every scheduling variable the flight has, on its grid."""
    out: dict[str, np.ndarray] = {}
    if "alt" in flight.have and np.all(np.isfinite(flight.alt[flight.airborne])):
        out["alt"] = flight.alt
    if "vel" in flight.have:
        out["speed"] = np.hypot(flight.v_body[:, 0], flight.v_body[:, 1])
    out["thrust"] = flight.motors.mean(axis=1)
    rate = np.abs(derivative(lowpass(flight.motors, flight.fs, 5.0), flight.fs))
    out["command_rate"] = lowpass(rate.mean(axis=1), flight.fs, 1.0)
    if "vbat" in flight.have and np.all(np.isfinite(flight.vbat[flight.airborne])):
        out["vbat"] = flight.vbat
    out["time"] = flight.t
    return out


def _bins(x: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    edges = np.unique(np.quantile(x, np.linspace(0, 1, N_BINS + 1)))
    if edges.size < 3:
        return edges, np.zeros(0), 0.0
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
    means = np.array([e[idx == b].mean() if np.any(idx == b) else 0.0
                      for b in range(edges.size - 1)])
    counts = np.bincount(idx, minlength=edges.size - 1)
    total = float(np.var(e)) + 1e-300
    between = float(np.sum(counts * (means - e.mean()) ** 2) / counts.sum())
    return edges, means, between / total


def locate_channel(channel: str, resid: np.ndarray, sigma: float, flight: Flight,
                   radius: float | None = None, effective: bool = False) -> Regime:
    """The scheduling variable whose bins explain most of ``resid`` on the airborne part.

    Parameters
    ----------
    channel : str
        Channel name.
    resid : ndarray
        Residual (measured − nominal) over the whole flight.
    sigma : float
        The channel's noise level measured on SIM.
    flight : Flight
        REAL, for the scheduling variables.
    radius : float, optional
        Rotor radius (m) to express heights as z/R.
    effective : bool
        ``radius`` is the ground-effect law's fitted effective radius, not the rotor's
        (no vehicle file): the text says z/R_eff and names it.
    """
    air = flight.airborne
    e = resid[air]
    unit = UNITS[channel]
    best: tuple[str, np.ndarray, np.ndarray, float] | None = None
    rms_mode = False
    for name, x in scheduling_variables(flight).items():
        for sq in (False, True):  # the residual itself, or its power (zero-mean effects)
            edges, means, eta2 = _bins(x[air], e**2 if sq else e)
            if means.size and (best is None or eta2 > best[3]):
                best = (name, edges, np.sqrt(np.maximum(means, 0)) if sq else means, eta2)
                rms_mode = sq
    mean_all = float(e.mean())
    if best is None or best[3] < MIN_ETA2:
        rms = float(np.sqrt(np.mean(e**2)))
        size = (f"off by {mean_all:+.2f} {unit} on average" if mean_all**2 > 0.5 * rms**2
                else f"residual RMS {rms:.3g} {unit} ({rms / sigma:.1f}× its floor)")
        text = (f"{LABELS[channel]} {size} throughout the flight (no height, speed, thrust, "
                "command-rate, voltage or time band stands out)")
        return Regime(channel, "none", float("nan"), float("nan"),
                      0.0 if best is None else best[3], mean_all, text)
    name, edges, means, eta2 = best
    floor = sigma if rms_mode else 2.0 * sigma / np.sqrt(max(e.size / N_BINS / 50.0, 1.0))
    active = np.abs(means) > max(floor, 0.5 * np.max(np.abs(means)))
    if not np.any(active):
        active = np.abs(means) >= np.max(np.abs(means))
    js = np.flatnonzero(active)
    lo, hi = float(edges[js[0]]), float(edges[js[-1] + 1])
    x_air = scheduling_variables(flight)[name][air]
    inside = (x_air >= lo) & (x_air <= hi)
    mean_in = float(np.sqrt(np.mean(e[inside] ** 2)) if rms_mode else e[inside].mean())
    vunit = VARIABLE_UNITS[name]
    full_lo, full_hi = float(edges[0]), float(edges[-1])
    if js[0] == 0 and js[-1] < edges.size - 2:
        where = f"below {hi:.3g} {vunit}"
    elif js[-1] == edges.size - 2 and js[0] > 0:
        where = f"above {lo:.3g} {vunit}"
    elif js[0] == 0 and js[-1] == edges.size - 2:
        low_end = abs(means[0]) > abs(means[-1])
        where = (f"over the whole range {full_lo:.3g}–{full_hi:.3g} {vunit}, strongest at "
                 f"its {'low' if low_end else 'high'} end")
    else:
        where = f"between {lo:.3g} and {hi:.3g} {vunit}"
    if name == "alt":
        where += _zr_text(lo, hi, radius, effective)
    size = f"RMS {mean_in:.2f}" if rms_mode else f"{mean_in:+.2f}"
    text = (f"{LABELS[channel]} {size} {unit} with {VARIABLE_TEXT[name]} {where}; "
            "elsewhere within noise" if not (js[0] == 0 and js[-1] == edges.size - 2) else
            f"{LABELS[channel]} residual follows {VARIABLE_TEXT[name]} {where}")
    return Regime(channel, name, lo, hi, eta2, mean_in, text)


def _zr_text(lo: float, hi: float, radius: float | None, effective: bool) -> str:
    if not radius:
        return ""
    if effective:
        return (f" (z/R_eff {lo / radius:.2g}–{hi / radius:.2g}, effective R = "
                f"{radius:.3g} m fitted)")
    return f" (z/R {lo / radius:.2g}–{hi / radius:.2g})"


def ground_band(channel: str, resid: np.ndarray, flight: Flight,
                excess_of: Callable[[np.ndarray], np.ndarray], eta2: float,
                radius: float | None = None, effective: bool = False) -> Regime:
    """The ground-effect band from the FITTED law: the flown heights where its thrust
    excess is at least half its largest value over the flight.

    The law decreases with height, so its largest excess is at the lowest flown height
    (:data:`LOWEST_FLOWN_QUANTILE` of the airborne heights) and the band runs from there
    up to the height where the excess falls to half of that (or to the top of the flight).

    Parameters
    ----------
    channel : str
        Channel whose residual is quoted inside the band.
    resid : ndarray
        Residual (measured − nominal) over the whole flight, in the channel's unit.
    flight : Flight
        REAL, for its heights (m).
    excess_of : callable
        Height (m) → the fitted law's thrust excess (ratio − 1;
        :func:`etsid.gap.candidates.ground_excess`).
    eta2 : float
        Share of the residual variance the height bins explain (kept for gap.json).
    radius : float, optional
        Rotor radius (m) to express heights as z/R.
    effective : bool
        ``radius`` is the fitted effective radius, not the rotor's.
    """
    air = flight.airborne
    z = flight.alt[air]
    z_lo = float(np.quantile(z, LOWEST_FLOWN_QUANTILE))
    z_top = float(z.max())
    grid = np.linspace(z_lo, z_top, 2001)
    excess = excess_of(grid)
    peak = float(excess[0])
    inside_law = excess >= 0.5 * peak
    hi = float(grid[np.flatnonzero(inside_law)[-1]]) if peak > 0 else z_top
    lo = float(z.min())
    inside = (z >= lo) & (z <= hi)
    e = resid[air]
    mean_in = float(e[inside].mean())
    unit = UNITS[channel]
    law = (f"the fitted law's thrust excess there is at least half its peak of "
           f"{100 * peak:.0f} % at {z_lo:.3g} m")
    if hi >= z_top:
        text = (f"{LABELS[channel]} residual follows height above ground over the whole range "
                f"{lo:.3g}–{hi:.3g} m{_zr_text(lo, hi, radius, effective)}: {law}")
    else:
        text = (f"{LABELS[channel]} {mean_in:+.2f} {unit} with height above ground below "
                f"{hi:.3g} m{_zr_text(lo, hi, radius, effective)}: {law}")
    return Regime(channel, "alt", lo, hi, eta2, mean_in, text)


def segments(resid: np.ndarray, sigma: float, flight: Flight) -> list[tuple[float, float]]:
    """Time segments (s) where the 1 s mean of the residual exceeds twice its noise level."""
    w = max(int(SEGMENT_WINDOW_S * flight.fs), 1)
    e = np.where(flight.airborne, resid, 0.0)
    cnt = np.convolve(flight.airborne.astype(float), np.ones(w), "same")
    mean = np.convolve(e, np.ones(w), "same") / np.maximum(cnt, 1.0)
    hot = flight.airborne & (np.abs(mean) > 2.0 * sigma / np.sqrt(max(w / 10.0, 1.0)))
    out: list[tuple[float, float]] = []
    for i, j in true_runs(hot):
        t0, t1 = float(flight.t[i]), float(flight.t[j - 1])
        if out and t0 - out[-1][1] < SEGMENT_WINDOW_S:
            out[-1] = (out[-1][0], t1)
        elif t1 - t0 >= 0.5 * SEGMENT_WINDOW_S:
            out.append((t0, t1))
    out = [s for s in out if s[1] - s[0] >= SEGMENT_WINDOW_S]
    out.sort(key=lambda s: s[1] - s[0], reverse=True)
    return sorted(out[:MAX_SEGMENTS])
