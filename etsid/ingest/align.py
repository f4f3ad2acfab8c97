"""Put chosen source signals on one uniform time grid: the FlightTable.

Rules (docs/ingest.md):

* The grid runs at ``rate_hz`` (default: the native rate of the body-rate source ``p``,
  else the fastest chosen signal: its mean rate over gap-free stretches) over the span of
  that reference signal.
* Continuous signals are interpolated linearly (angles on their unwrapped value, then
  wrapped to (−π, π]); commands, setpoints and motor outputs are held (zero-order hold).
* A signal whose samples are more than :data:`~etsid.table.GAP_PERIODS` native periods
  apart has a gap there. Inside a gap of the reference signal the grid has no points and
  the ``segment`` column counts up after it; inside a gap of another signal its column
  is NaN. Outside a signal's span its column is NaN.
* Non-finite samples are dropped, out-of-order samples sorted and duplicate timestamps
  merged (first kept); physically implausible samples and stray timestamps are dropped
  (:mod:`etsid.ingest.plausibility`); every count lands in ``attrs["dropped"]`` /
  ``attrs["repaired"]``.
"""

from __future__ import annotations

import sys
from dataclasses import asdict
from typing import TYPE_CHECKING

import numpy as np

from etsid.errors import IngestError
from etsid.ingest.base import Issue, RawLog, Signal
from etsid.ingest.outputs import drop_unused_outputs
from etsid.ingest.plausibility import check_signals
from etsid.ingest.vehicle import FACTS
from etsid.table import COLUMNS, GAP_PERIODS, SEGMENT, ordered_columns, validate

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

HOLD_MERGE_MIN = 1000
"""Fewest grid points for which :func:`hold_index` and :func:`interp_linear` try the merge walk
(and fewest angles that :func:`unwrap` unwraps compiled)."""
MAX_GRID_POINTS = 50_000_000
"""Refuse grids larger than this (a typo in ``--rate`` would otherwise exhaust memory)."""


def clean_signal(sig: Signal, dropped: list[Issue], repaired: list[Issue],
                 clean_times: set[int] | None = None) -> Signal:
    """Drop non-finite samples, sort by time, merge duplicate timestamps; record counts.

    ``clean_times`` holds the ids of time arrays already found finite, in order and without
    repeats (the fields of one message share theirs): for such a time array only the values
    are checked. Arrays found clean here are added; the caller keeps them alive meanwhile.
    """
    t = np.asarray(sig.t, dtype=float)
    v = np.asarray(sig.values, dtype=float)
    if clean_times is not None and id(t) in clean_times and np.isfinite(v).all():
        return Signal(sig.column, t, v, sig.source, sig.priority)
    ok = np.isfinite(t) & np.isfinite(v)
    clean = bool(ok.all())
    if not clean:
        dropped.append(Issue("NaN or inf sample", int((~ok).sum()), sig.source))
        t, v = t[ok], v[ok]
    if t.size > 1 and np.any(np.diff(t) < 0):
        clean = False
        order = np.argsort(t, kind="stable")
        moved = int(np.count_nonzero(order != np.arange(t.size)))
        repaired.append(Issue("out-of-order timestamp, re-sorted", moved, sig.source))
        t, v = t[order], v[order]
    if t.size > 1:
        dup = np.concatenate(([False], np.diff(t) == 0))
        if dup.any():
            clean = False
            dropped.append(Issue("duplicate timestamp", int(dup.sum()), sig.source))
            t, v = t[~dup], v[~dup]
    if clean and clean_times is not None:
        clean_times.add(id(t))
    return Signal(sig.column, t, v, sig.source, sig.priority)


def native_period(t: np.ndarray) -> float:
    """Typical sample spacing, s: the mean spacing once outliers (> 20 × median) are left out.

    The median alone would understate the period of bursty streams (samples in pairs,
    1 ms and 6 ms apart, as real PX4 logs have) and then call every long spacing a gap.
    """
    if t.size < 2:
        return float("nan")
    dt = np.diff(t)
    regular = dt[dt <= 20.0 * np.median(dt)]
    return float(regular.mean())


def native_rate(t: np.ndarray) -> float:
    """Mean sample rate, Hz, over the stretches without gaps (see :func:`native_period`)."""
    return 1.0 / native_period(t) if t.size > 1 else float("nan")


def find_gaps(t: np.ndarray, period: float | None = None) -> list[tuple[float, float]]:
    """Intervals (start, end) where consecutive samples are > GAP_PERIODS periods apart;
    ``period`` (s) is :func:`native_period` of ``t`` when the caller has it already."""
    if t.size < 3:
        return []
    dt = np.diff(t)
    limit = GAP_PERIODS * (native_period(t) if period is None else period)
    idx = np.flatnonzero(dt > limit)
    return [(float(t[i]), float(t[i + 1])) for i in idx]


def interpolation(column: str) -> str:
    """How ``column`` is resampled: "linear", "angle" or "hold" (zero-order hold)."""
    return COLUMNS[column].interp if column in COLUMNS else "linear"


HOLD_TOLERANCE_S = 1e-6
"""A sample stamped less than this after a grid point is held from that point on: one
microsecond, the finest clock of the log formats read (MAVLink ``time_usec``, DataFlash
``TimeUS``), so two stamps closer than it are one instant as far as a log can say. The
grid's own floating-point error lies far below it (the grid is built from an estimated
period: about 1e-14 s at boot-clock times, 1e-7 s at Unix times), and without it a motor
output stamped at the same instant as a grid point was held one sample late wherever
rounding put the point a hair early: on a 50 Hz log, at 15 % of its points or at none,
depending on the log's length, a 3 ms difference in apparent motor timing between two
logs of one simulator (docs/gap_results.md, session 12)."""


def hold_index(t: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Index of the last sample of ``t`` at or before each grid point (−1 before the first),
    a sample within :data:`HOLD_TOLERANCE_S` after the point counting as at it.

    Once numba is loaded, ordered float arrays take one merge walk
    (:mod:`etsid.ingest.align_kernels`) instead of a bisection per grid point."""
    grid = np.asarray(grid, dtype=float) + HOLD_TOLERANCE_S
    if ("numba" in sys.modules and grid.size > HOLD_MERGE_MIN and t.dtype == np.float64
            and grid.dtype == np.float64 and t.ndim == grid.ndim == 1):
        from etsid.ingest.align_kernels import hold_merge

        out = np.empty(grid.size, dtype=np.intp)
        if hold_merge(t, grid, out):
            return out
    return np.searchsorted(t, grid, side="right") - 1


def unwrap(v: np.ndarray) -> np.ndarray:
    """``np.unwrap(v)``; once numba is loaded, a finite 1-D float64 array takes one compiled
    pass with the same arithmetic (:func:`etsid.ingest.align_kernels.unwrap_pi`: 1.3 ms
    instead of 6.6 ms for 150,000 angles)."""
    if ("numba" in sys.modules and v.size > HOLD_MERGE_MIN and v.dtype == np.float64
            and v.ndim == 1 and v.flags.c_contiguous):
        from etsid.ingest.align_kernels import unwrap_pi

        out = np.empty(v.size)
        if unwrap_pi(v, out):
            return out
    return np.unwrap(v)


def interp_linear(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp(x, xp, fp)``; once numba is loaded, ordered float64 arrays without NaN
    take one compiled merge walk with numpy's arithmetic
    (:func:`etsid.ingest.align_kernels.interp_merge`: about a third of the time)."""
    if ("numba" in sys.modules and x.size > HOLD_MERGE_MIN
            and all(a.dtype == np.float64 and a.ndim == 1 and a.flags.c_contiguous
                    for a in (x, xp, fp)) and xp.size == fp.size):
        from etsid.ingest.align_kernels import interp_merge

        out = np.empty(x.size)
        if interp_merge(x, xp, fp, out):
            return out
    return np.interp(x, xp, fp)


def resample(sig: Signal, grid: np.ndarray, period: float | None = None,
             held: np.ndarray | None = None,
             gaps: list[tuple[float, float]] | None = None) -> np.ndarray:
    """Values of ``sig`` on ``grid`` following its column's interpolation rule.

    ``period`` (s, :func:`native_period` of ``sig.t``), ``held`` (:func:`hold_index` of
    ``sig.t`` on ``grid``, held columns only) and ``gaps`` (:func:`find_gaps` of ``sig.t``
    with that period) may be passed when the caller has them already (the fields of one
    message share their time array).
    """
    t, v = sig.t, sig.values
    if t.size == 0:
        return np.full(grid.size, np.nan)
    interp = interpolation(sig.column)
    if period is None:
        period = native_period(t) if t.size > 1 else 0.0
    if interp == "hold":
        idx = hold_index(t, grid) if held is None else held
        after = t[-1] + GAP_PERIODS * period
        if ("numba" in sys.modules and grid.size > HOLD_MERGE_MIN
                and all(a.dtype == d and a.ndim == 1 and a.flags.c_contiguous
                        for a, d in ((v, np.float64), (grid, np.float64), (idx, np.intp)))):
            from etsid.ingest.align_kernels import hold_values

            out = np.empty(grid.size)
            hold_values(v, idx, grid, float(after), out)
        else:
            out = v[np.clip(idx, 0, None)].astype(float)
            out[idx < 0] = np.nan
            out[grid > after] = np.nan
    else:
        base = unwrap(v) if interp == "angle" else v
        out = interp_linear(grid, t, base)
        half = 0.5 * period
        out[(grid < t[0] - half) | (grid > t[-1] + half)] = np.nan
        if interp == "angle":
            out = np.angle(np.exp(1j * out))
            out[out == -np.pi] = np.pi
    for start, end in find_gaps(t, period) if gaps is None else gaps:
        inside = (grid > start) & (grid < end)
        out[inside] = np.nan
    return out


def reference_signal(chosen: dict[str, Signal]) -> Signal:
    """The signal whose native rate and span define the grid: ``p``, ``q``, ``r``, else fastest."""
    for column in ("p", "q", "r"):
        if column in chosen:
            return chosen[column]
    return max(chosen.values(), key=lambda s: (s.rate_hz, s.t.size))


def build_table(
    raw: RawLog,
    chosen: dict[str, Signal],
    rate_hz: float | None = None,
    start: float | None = None,
    end: float | None = None,
) -> pd.DataFrame:
    """Align ``chosen`` signals of ``raw`` into a validated FlightTable.

    Parameters
    ----------
    rate_hz
        Grid rate, Hz; default the native rate of the reference signal.
    start, end
        Keep only this window, s from the reference signal's first sample.
    """
    dropped, repaired = list(raw.dropped), list(raw.repaired)
    clean_times: set[int] = set()  # (the arrays stay alive in ``cleaned``)
    cleaned = {c: clean_signal(s, dropped, repaired, clean_times) for c, s in chosen.items()}
    cleaned, note = check_signals(cleaned, dropped)
    if note:
        raw.warnings.append(f"{raw.path}: {note}")
    for column, sig in cleaned.items():
        if sig.t.size < 2:
            raw.warnings.append(f"{column}: left out, {sig.source} has {sig.t.size} usable "
                                "sample(s) (need 2)")
    cleaned = {c: s for c, s in cleaned.items() if s.t.size >= 2}
    if not cleaned:
        raise IngestError(f"{raw.path}: no usable samples in any mapped signal")
    ref = reference_signal(cleaned)
    # native period of every signal, once per time array (a message's fields share theirs)
    by_array: dict[int, float] = {}
    period: dict[str, float] = {}
    for column, sig in cleaned.items():
        if id(sig.t) not in by_array:
            by_array[id(sig.t)] = native_period(sig.t)
        period[column] = by_array[id(sig.t)]
    gaps_of: dict[int, list[tuple[float, float]]] = {}  # find_gaps, once per time array
    for column, sig in cleaned.items():
        if id(sig.t) not in gaps_of:
            gaps_of[id(sig.t)] = find_gaps(sig.t, period[column])
    ref_column = next(c for c, s in cleaned.items() if s is ref)
    rate = float(rate_hz) if rate_hz else 1.0 / period[ref_column]
    if not np.isfinite(rate) or rate <= 0:
        raise IngestError(f"{raw.path}: cannot infer a sample rate from {ref.source}")
    for name, value in (("--start", start), ("--end", end)):
        if value is not None and not (np.isfinite(value) and value >= 0):
            raise IngestError(f"{raw.path}: {name} must be a time ≥ 0 s from the first "
                              f"sample, got {value:g}")
    t0 = float(ref.t[0])
    lo = t0 + (start or 0.0)
    hi = float(ref.t[-1]) if end is None else min(float(ref.t[-1]), t0 + end)
    if hi <= lo:
        raise IngestError(f"{raw.path}: the window --start/--end selects no data")
    n_grid = int(np.floor((hi - lo) * rate + 1e-9)) + 1
    if n_grid > MAX_GRID_POINTS:
        if rate_hz:
            raise IngestError(f"{raw.path}: --rate {rate:g} Hz over {hi - lo:.1f} s gives "
                              f"{n_grid:.3g} grid points (limit {MAX_GRID_POINTS:.0e}); "
                              "use a lower rate")
        raise IngestError(f"{raw.path}: {ref.source} spans {hi - lo:.3g} s at {rate:.4g} Hz, "
                          f"{n_grid:.3g} grid points (limit {MAX_GRID_POINTS:.0e}): its "
                          "timestamps look damaged; cut a window with --start/--end")
    grid = lo + np.arange(n_grid) / rate
    keep = np.ones(grid.size, dtype=bool)
    gaps = []
    for gap_start, gap_end in gaps_of[id(ref.t)]:
        keep &= ~((grid > gap_start) & (grid < gap_end))
    for column, sig in cleaned.items():
        for gap_start, gap_end in gaps_of[id(sig.t)]:
            gaps.append({"start": gap_start - t0, "end": gap_end - t0, "signal": sig.source,
                         "column": column})
    grid = grid[keep]
    if grid.size < 2:
        raise IngestError(f"{raw.path}: fewer than two samples on the time grid")
    data = {}
    held: dict[int, np.ndarray] = {}  # hold_index per time array
    for column in ordered_columns(list(cleaned)):
        sig = cleaned[column]
        if interpolation(column) == "hold" and id(sig.t) not in held:
            held[id(sig.t)] = hold_index(sig.t, grid)
        data[column] = resample(sig, grid, period[column], held.get(id(sig.t)),
                                gaps_of[id(sig.t)])
    # segment counts up after every dropped stretch of the grid
    jumps = np.diff(grid) > 1.5 / rate
    data[SEGMENT] = np.concatenate(([0], np.cumsum(jumps))).astype(np.int64)
    import pandas as pd

    table = pd.DataFrame(data, index=pd.Index(grid - grid[0], name="t"))
    for column in table.columns:
        if column != SEGMENT:
            values = data[column]  # (the column's values; pandas' isna per column: 3x)
            missing = (int(np.count_nonzero(np.isnan(values))) if values.dtype == np.float64
                       else int(table[column].isna().sum()))
            if missing:
                raw.warnings.append(
                    f"{column}: {missing} of {len(table)} grid points have no data "
                    f"(outside the span of {cleaned[column].source} or inside its gaps)"
                )
    table.attrs = {
        "source": str(raw.path),
        "format": raw.format,
        "start_time": None if raw.start_time is None else raw.start_time + grid[0],
        "rate_hz": rate,
        "reference": ref.source,
        "mapping": {c: s.source for c, s in cleaned.items()},
        "signals": {
            c: {"source": s.source, "count": int(s.t.size), "rate_hz": round(s.rate_hz, 3)}
            for c, s in cleaned.items()
        },
        "dropped": [asdict(i) for i in dropped],
        "repaired": [asdict(i) for i in repaired],
        "gaps": gaps,
        "warnings": list(raw.warnings),
        "log": {k: v for k, v in raw.extra.items() if isinstance(v, (str, int, float, list))},
        **{k: raw.extra[k] for k in FACTS if isinstance(raw.extra.get(k), str)},
    }
    layout = raw.extra.get("motor_layout")
    if isinstance(layout, dict) and "m1" in cleaned and cleaned["m1"].topic == layout.get("topic"):
        # the layout's motor order holds for the motor topic it names only
        table.attrs["motor_layout"] = {k: v for k, v in layout.items() if k != "topic"}
    return validate(drop_unused_outputs(table))
