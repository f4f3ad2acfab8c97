"""Judge a candidate signal by its content, not its name (rule 5 of
:mod:`etsid.ingest.mapping`).

A measured column (body rates, angles, specific force, height, velocity, battery) can have
several candidate sources; the reader's priority says which is *usually* best (a
rangefinder's height over the estimator's −z). A log can still carry the preferred source
empty or stuck: PX4's ``vehicle_local_position.dist_bottom`` without a range finder sits at
its 0.1 m floor, valid on a fifth of the flight. A candidate is *flawed* when, over the
reference span (:func:`reference_span`: the airborne part by the log's land detector, else
the span of the body-rate source, else the whole log),

- it has a value on less than :data:`MIN_COVERAGE` of the span (after the reader blanked
  the samples its validity flags reject: ``dist_bottom_valid``, ``z_valid``,
  ``signal_quality`` …), or
- it is constant there: one value in at least :data:`STUCK_SHARE` of its samples (a sensor
  at a limit, an unset field).

A candidate is also faulty when it is implausible against the other channels (a gyro in
deg/s against the attitude's derivative, a height that does not follow the vertical
velocity, a specific force in g: :mod:`etsid.ingest.source_consistency`). A faulty
candidate gives way to the best-ranked sound one; when every candidate is faulty the order
stays and the note says so; a lone implausible candidate stays, with a warning note.
Inputs and setpoints are not judged here (a still stick is a fact of the flight; identify
chooses its inputs by excitation, :mod:`etsid.ident.inputs`); motor outputs neither
(unused outputs are marked elsewhere).
"""

from __future__ import annotations

import numpy as np

from etsid.ingest.base import Signal
from etsid.ingest.source_consistency import Judge

CHECKED_COLUMNS = ("p", "q", "r", "roll", "pitch", "yaw", "ax", "ay", "az", "alt",
                   "vx", "vy", "vz", "vbat")
"""Measured columns whose candidates are judged by content."""

MIN_COVERAGE = 0.5
"""Least share of the reference span a candidate must cover with values: a source empty over
more than half of the flight describes the flight less well than a complete one."""

STUCK_SHARE = 0.95
"""Share of samples at one value from which a measured signal counts as constant (a real
sensor's noise moves at least its last digit). Above 0.5, which :func:`stuck_value` uses."""

MAX_GAP_S = 0.5
"""A gap between two valid samples longer than this, s (and than five of the signal's own
sample periods), is not covered."""


def reference_span(signals: list[Signal]) -> tuple[float, float, str]:
    """``(t0, t1, what)``: the span the candidates are judged on, native clock s.

    The airborne part by the best-ranked ``landed`` candidate (first to last row with
    ``landed`` < 0.5), else the span of the best-ranked ``p`` candidate, else of every
    signal.
    """
    def best(column: str) -> Signal | None:
        cands = [s for s in signals if s.column == column and s.t.size]
        return min(cands, key=lambda s: (s.priority, -s.rate_hz, s.source), default=None)

    landed = best("landed")
    if landed is not None:
        with np.errstate(invalid="ignore"):
            air = landed.t[np.nan_to_num(landed.values, nan=1.0) < 0.5]
        if air.size >= 2 and air[-1] > air[0]:
            return float(air[0]), float(air[-1]), "the airborne part"
    rate = best("p")
    if rate is not None and rate.t.size >= 2:
        return float(np.nanmin(rate.t)), float(np.nanmax(rate.t)), "the span of the body rates"
    times = [s.t for s in signals if s.t.size]
    if not times:
        return 0.0, 0.0, "the log"
    return (float(min(np.nanmin(t) for t in times)), float(max(np.nanmax(t) for t in times)),
            "the log")


def coverage(sig: Signal, t0: float, t1: float) -> float:
    """Share (0…1) of ``[t0, t1]`` covered by ``sig``'s finite samples: each covers the time
    to the next one when that gap is at most :data:`MAX_GAP_S` or five sample periods."""
    if not t1 > t0:
        return 1.0
    every = np.asarray(sig.t, dtype=float)
    ok = np.isfinite(every) & np.isfinite(np.asarray(sig.values, dtype=float))
    whole = bool(ok.all())  # (then the valid times are all times: one sort, one diff)
    t = _sorted(every if whole else every[ok])
    if t.size < 2:
        return 0.0
    step = np.diff(t)
    period = float(np.median(step if whole else np.diff(_sorted(every))))
    limit = max(MAX_GAP_S, 5.0 * period)
    a, b = np.clip(t[:-1], t0, t1), np.clip(t[1:], t0, t1)
    span = b - a
    return float(np.sum(span[step <= limit]) / (t1 - t0))


def stuck_value(sig: Signal, t0: float, t1: float) -> float | None:
    """The value ``sig`` holds in at least :data:`STUCK_SHARE` of its finite samples inside
    ``[t0, t1]``; None when it moves."""
    inside = (sig.t >= t0) & (sig.t <= t1)
    v = np.asarray(sig.values, dtype=float)[inside]
    v = v[np.isfinite(v)]
    if v.size < 3:
        return None
    # a value held by more than half of the samples is the middle one in sorted order, so
    # only that one is counted (STUCK_SHARE > 0.5; the same as counting every value)
    middle = np.partition(v, v.size // 2)[v.size // 2]
    held = int(np.count_nonzero(v == middle))
    return float(middle) if held >= STUCK_SHARE * v.size else None


def _sorted(t: np.ndarray) -> np.ndarray:
    """``np.sort(t)``, without the sort when ``t`` is already in order (the usual case)."""
    return t if t.size < 2 or bool(np.all(t[1:] >= t[:-1])) else np.sort(t)


def flaw(sig: Signal, t0: float, t1: float, what: str) -> str | None:
    """Why ``sig`` is not fit to fill its column over ``[t0, t1]`` (``what`` names the
    span), or None."""
    share = coverage(sig, t0, t1)
    if share < MIN_COVERAGE:
        return f"has a value on only {100 * share:.0f} % of {what}"
    value = stuck_value(sig, t0, t1)
    if value is not None:
        return f"is constant at {value:.4g} over {what}"
    return None


def order_by_content(column: str, cands: list[Signal], span: tuple[float, float, str],
                     judge: Judge | None = None) -> tuple[list[Signal], str | None]:
    """``cands`` (best-ranked first) with faulty candidates after the first sound one, and a
    note naming each faulty candidate that was passed over and why (None when the first
    candidate is sound or the column is not judged).

    A candidate is faulty when :func:`flaw` finds a flaw or ``judge(column, candidate)``
    (:meth:`etsid.ingest.source_consistency.Referee.judge`) finds it implausible against the
    other channels. A lone candidate is never dropped; when it is implausible the note
    warns that it was used anyway."""
    if column not in CHECKED_COLUMNS or not cands:
        return cands, None
    t0, t1, what = span

    def fault(sig: Signal) -> str | None:
        found = flaw(sig, t0, t1, what)
        if found is None and judge is not None:
            found = judge(column, sig)
        return found

    if len(cands) < 2:
        why = judge(column, cands[0]) if judge is not None else None
        return cands, (None if why is None else
                       f"{column}: {cands[0].source} {why}, and it is the only candidate; "
                       "used it anyway")
    first_fault = fault(cands[0])
    if first_fault is None:
        return cands, None
    faults = {id(s): fault(s) for s in cands[1:]}
    faults[id(cands[0])] = first_fault
    sound = next((s for s in cands if faults[id(s)] is None), None)
    if sound is None:
        return cands, (f"{column}: {cands[0].source} {first_fault}, and no other candidate is "
                       "better; used it anyway")
    at = next(i for i, s in enumerate(cands) if s is sound)
    passed = cands[:at]
    why = "; ".join(f"{s.source} {faults[id(s)]}" for s in passed)
    return [sound] + [s for s in cands if s is not sound], \
        f"{column}: used {sound.source} by content, not {passed[0].source}: {why}"
