"""Physical plausibility of ingested samples: the limits, and the check that applies them.

A decoder that reads damaged bytes can hand back numbers no vehicle produces (a body rate
of 1e131 rad/s, a battery at 0.006 V). Such samples are dropped on ingest, counted in
``attrs["dropped"]`` and summed up in one note, so that a table that was written never
holds them. The limits are deliberately wide — they catch garbage, not aggressive flying
(docs/ingest.md, "Physical plausibility"):

=================  ==============================  =========================================
columns            kept when                       why
=================  ==============================  =========================================
p q r, sp_p …      |value| ≤ 35 rad/s              2000 °/s, the largest common gyro range
roll, yaw          |value| ≤ π rad                 Euler angle range
pitch              |value| ≤ π/2 rad               ZYX Euler pitch range
ax ay az           |value| ≤ 16 g = 156.9 m/s²     the largest common accelerometer range;
                   and |(ax, ay, az)| ≤ 16 g        the vector, when one message holds all three
vx vy vz           |value| ≤ 340 m/s               speed of sound
alt                −1000 m ≤ value ≤ 20 000 m      below sea level … above any drone ceiling
vbat               0.5 V ≤ value ≤ 100 V           a 24-cell pack; below 0.5 V: a placeholder
u_roll … u_yaw     |value| ≤ 1.5                   normalised command (−1…1), with margin
u_thrust, m1…m8    −0.5 ≤ value ≤ 1.5              normalised output (0…1), with margin
=================  ==============================  =========================================

Timestamps: a sample whose time lies far outside the span of the log (more than
:data:`SPAN_MARGIN` × that span, and at least :data:`SPAN_MARGIN_MIN_S`, before the
0.1 % or after the 99.9 % quantile of all chosen samples' times) is a damaged timestamp
and is dropped too.
"""

from __future__ import annotations

import math

import numpy as np

from etsid.ingest.base import Issue, Signal
from etsid.table import COLUMNS

STANDARD_GRAVITY = 9.80665
"""m/s²."""

MAX_BODY_RATE = 35.0
"""rad/s: the full scale of a ±2000 °/s gyro."""

MAX_SPECIFIC_FORCE = 16.0 * STANDARD_GRAVITY
"""m/s²: the full scale of a ±16 g accelerometer."""

LIMITS: dict[str, tuple[float, float]] = {
    **{c: (-MAX_BODY_RATE, MAX_BODY_RATE) for c in ("p", "q", "r", "sp_p", "sp_q", "sp_r")},
    "roll": (-math.pi, math.pi),
    "pitch": (-math.pi / 2, math.pi / 2),
    "yaw": (-math.pi, math.pi),
    "sp_roll": (-math.pi, math.pi),
    "sp_pitch": (-math.pi / 2, math.pi / 2),
    "sp_yaw": (-math.pi, math.pi),
    **{c: (-MAX_SPECIFIC_FORCE, MAX_SPECIFIC_FORCE) for c in ("ax", "ay", "az")},
    **{c: (-340.0, 340.0) for c in ("vx", "vy", "vz")},
    "alt": (-1000.0, 20_000.0),
    "vbat": (0.5, 100.0),
    **{c: (-1.5, 1.5) for c in ("u_roll", "u_pitch", "u_yaw")},
    **{c: (-0.5, 1.5) for c in ("u_thrust", *(f"m{i}" for i in range(1, 9)))},
}
"""FlightTable column → (lowest, highest) plausible value in the column's SI unit."""

ANGLE_SLACK = 1e-6
"""rad: Euler angles exactly at ±π or ±π/2 (plus rounding) are in range."""

SPAN_MARGIN = 1.0
"""Timestamps further than this many log spans outside the log's span are damaged."""

SPAN_MARGIN_MIN_S = 60.0
"""… and further than this many seconds."""

SPAN_QUANTILE = 0.001
"""The log's span runs from this quantile to 1 − this quantile of all sample times."""


def limits_text(column: str) -> str:
    """The limit of ``column`` as people read it, e.g. ``|p| ≤ 35 rad/s``."""
    lo, hi = LIMITS[column]
    unit = COLUMNS[column].unit if column in COLUMNS else ""
    unit = "" if unit in ("", "1") else f" {unit}"
    if lo == -hi:
        return f"|{column}| ≤ {hi:.4g}{unit}"
    return f"{lo:.4g} ≤ {column} ≤ {hi:.4g}{unit}"


def implausible_mask(column: str, values: np.ndarray) -> np.ndarray:
    """True where ``values`` of ``column`` are finite but beyond :data:`LIMITS`."""
    values = np.asarray(values, dtype=float)
    if column not in LIMITS:
        return np.zeros(values.shape, dtype=bool)
    lo, hi = LIMITS[column]
    slack = ANGLE_SLACK if column in ("roll", "pitch", "yaw") else 0.0
    with np.errstate(invalid="ignore"):
        return np.isfinite(values) & ((values < lo - slack) | (values > hi + slack))


def log_span(signals: list[Signal]) -> tuple[float, float] | None:
    """(start, end) of the bulk of the log's samples, s on the native clock; None if empty."""
    times = [np.asarray(s.t, dtype=float) for s in signals]
    times = [t if np.isfinite(t).all() else t[np.isfinite(t)] for t in times]  # (no copy)
    if not times or not sum(t.size for t in times):
        return None
    lo, hi = pooled_quantiles(times, (SPAN_QUANTILE, 1.0 - SPAN_QUANTILE))
    return float(lo), float(hi)


def pooled_quantiles(arrays: list[np.ndarray], qs: tuple[float, ...]) -> list[float]:
    """``np.quantile(np.concatenate(arrays), qs)`` (linear method) of finite arrays.

    When every array is in order, the order statistics are found by bisection on the
    arrays themselves, counting with ``searchsorted`` (an array shared by several signals
    counts once per signal), and interpolated with numpy's own arithmetic: the same
    numbers without pooling and partitioning millions of samples. Otherwise numpy's."""
    weight: dict[int, int] = {}
    unique: list[np.ndarray] = []
    for a in arrays:
        if a.size == 0:
            continue
        if id(a) not in weight:
            weight[id(a)] = 0
            unique.append(a)
        weight[id(a)] += 1
    n = sum(a.size for a in arrays)
    if len(unique) > 64 or not all(a.size < 2 or bool(np.all(a[1:] >= a[:-1]))
                                   for a in unique):
        return [float(v) for v in np.quantile(np.concatenate(arrays), list(qs))]
    w = np.array([weight[id(a)] for a in unique], dtype=np.int64)
    out = []
    for q in qs:
        virtual = (n - 1) * np.float64(q)  # numpy's linear method (_quantile, _lerp)
        if virtual >= n - 1:
            out.append(_order_statistic(unique, w, n - 1))
            continue
        prev = np.floor(virtual)
        a = _order_statistic(unique, w, int(prev))
        b = _order_statistic(unique, w, int(prev) + 1)
        gamma = virtual - prev
        diff = b - a
        out.append(float(b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma))
    return out


def _order_statistic(arrays: list[np.ndarray], weight: np.ndarray, k: int) -> float:
    """The ``k``-th smallest (from 0) of the ordered ``arrays`` pooled, each counted
    ``weight`` times: in each array, bisection for the first value with more than ``k``
    pooled values at or below it; the least of those."""
    sizes = np.array([a.size for a in arrays], dtype=np.int64)
    lo = np.zeros(len(arrays), dtype=np.int64)
    hi = sizes.copy()
    while np.any(lo < hi):
        mid = (lo + hi) // 2
        x = np.array([a[min(i, a.size - 1)] for a, i in zip(arrays, mid, strict=True)])
        below = np.zeros(len(arrays), dtype=np.int64)
        for a, w in zip(arrays, weight, strict=True):
            below += w * np.searchsorted(a, x, side="right")
        more = below > k
        active = lo < hi
        hi = np.where(active & more, mid, hi)
        lo = np.where(active & ~more, mid + 1, lo)
    return float(min(a[i] for a, i in zip(arrays, lo, strict=True) if i < a.size))


def stray_times(t: np.ndarray, span: tuple[float, float] | None) -> np.ndarray:
    """True where a finite time ``t`` lies outside ``span`` (:func:`log_span`) by more than
    the margin."""
    t = np.asarray(t, dtype=float)
    if span is None:
        return np.zeros(t.shape, dtype=bool)
    lo, hi = span
    margin = max(SPAN_MARGIN * (hi - lo), SPAN_MARGIN_MIN_S)
    with np.errstate(invalid="ignore"):
        return np.isfinite(t) & ((t < lo - margin) | (t > hi + margin))


def check_signal(sig: Signal, span: tuple[float, float] | None,
                 dropped: list[Issue], stray: np.ndarray | None = None) -> Signal:
    """``sig`` without implausible values and stray timestamps; counts go to ``dropped``.
    ``stray`` is :func:`stray_times` of ``sig.t`` when the caller has it (it is not
    changed)."""
    t = np.asarray(sig.t, dtype=float)
    v = np.asarray(sig.values, dtype=float)
    bad_value = implausible_mask(sig.column, v)
    bad_time = stray_times(t, span) if stray is None else stray.copy()
    if bad_value.any():
        dropped.append(Issue(f"implausible value ({limits_text(sig.column)})",
                             int(bad_value.sum()), sig.source))
    bad_time &= ~bad_value
    if bad_time.any():
        dropped.append(Issue("timestamp outside the log's span", int(bad_time.sum()),
                             sig.source))
    bad = bad_value | bad_time
    if not bad.any():
        return sig
    return Signal(sig.column, t[~bad], v[~bad], sig.source, sig.priority)


def check_signals(chosen: dict[str, Signal], dropped: list[Issue]) -> tuple[dict[str, Signal],
                                                                             str | None]:
    """Apply :func:`check_signal` to every chosen signal.

    Returns
    -------
    signals
        The checked signals, same keys.
    note
        One line summing up what was dropped, or None when everything was plausible.
    """
    span = log_span(list(chosen.values()))
    before = len(dropped)
    chosen = _check_specific_force_norm(chosen, dropped)
    strays: dict[int, np.ndarray] = {}  # once per time array (a message's fields share it)
    for s in chosen.values():
        if id(s.t) not in strays:
            strays[id(s.t)] = stray_times(s.t, span)
    out = {c: check_signal(s, span, dropped, strays[id(s.t)]) for c, s in chosen.items()}
    issues = dropped[before:]
    if not issues:
        return out, None
    total = sum(i.count for i in issues)
    parts = ", ".join(f"{i.count} {i.signal}" for i in issues[:6])
    more = f" and {len(issues) - 6} more signals" if len(issues) > 6 else ""
    return out, (f"dropped {total} physically implausible sample(s) (limits in "
                 f"docs/ingest.md): {parts}{more}")


def _check_specific_force_norm(chosen: dict[str, Signal],
                               dropped: list[Issue]) -> dict[str, Signal]:
    """Drop samples whose specific-force vector is longer than 16 g, when ax, ay, az come
    from one message (same timestamps); each component alone may still be in range."""
    axes = [chosen.get(c) for c in ("ax", "ay", "az")]
    if any(a is None for a in axes):
        return chosen
    t = np.asarray(axes[0].t)  # type: ignore[union-attr]
    if not all(np.array_equal(a.t, t) for a in axes[1:]):  # type: ignore[union-attr]
        return chosen
    with np.errstate(invalid="ignore", over="ignore"):
        norm = np.sqrt(sum(np.asarray(a.values, dtype=float) ** 2 for a in axes))  # type: ignore[union-attr]
        bad = np.isfinite(norm) & (norm > MAX_SPECIFIC_FORCE)
    if not bad.any():
        return chosen
    out = dict(chosen)
    for column, sig in zip(("ax", "ay", "az"), axes, strict=True):
        assert sig is not None
        dropped.append(Issue(f"implausible value (|specific force| ≤ 16 g = "
                             f"{MAX_SPECIFIC_FORCE:.4g} m/s²)", int(bad.sum()), sig.source))
        out[column] = Signal(column, sig.t[~bad], sig.values[~bad], sig.source, sig.priority)
    return out


def table_violations(table: object) -> dict[str, int]:
    """Column → count of values beyond :data:`LIMITS` in a FlightTable (for checks and tests)."""
    out = {}
    for column in getattr(table, "columns", []):
        if column in LIMITS:
            count = int(implausible_mask(column, table[column].to_numpy(dtype=float)).sum())  # type: ignore[index]
            if count:
                out[column] = count
    return out
