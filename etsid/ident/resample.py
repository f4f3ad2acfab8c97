"""The identification sample rate: block-mean decimation of a table by an integer factor.

A rate model needs its lags to span the rate dynamics (0.1–0.5 s for a multirotor). At
250–400 Hz four output lags span 10–16 ms and free-run simulation drifts; at ~50 Hz (the
MAVROS-era rate of the chapter) the same lags span 80 ms. :func:`decimate` brings a faster
table down to the rate nearest ``rate_hz`` that is an integer fraction of the native rate.

Anti-aliasing: each output sample is the **mean of a block of k consecutive samples**
(a boxcar FIR filter followed by keeping one sample in k). Blocks never straddle a segment
boundary (a gap); a block touching a NaN is NaN; angle columns use the circular mean.
The boxcar's first null is at the new sample rate and it attenuates by 3.9 dB at the new
Nyquist frequency; rate dynamics below ~10 Hz pass with < 1 dB loss at 50 Hz.

Noise floor: white sensor noise of standard deviation σ at the native rate has standard
deviation σ/√k after averaging k samples, so the floor of the one-step error (the σ the
metrics report) becomes σ/√k. :func:`decimate` records both in ``attrs["noise"]``
(``gyro_std`` = σ/√k, ``gyro_std_native`` = σ) and ``attrs["decimation"]``.

>>> import numpy as np, pandas as pd
>>> t = pd.DataFrame({"p": np.arange(10.0)}, index=pd.Index(np.arange(10) / 250, name="t"))
>>> t.attrs = {"rate_hz": 250.0, "noise": {"gyro_std": 0.02}}
>>> d = decimate(t, 50.0)
>>> d["p"].tolist(), d.attrs["decimation"]["factor"], round(d.attrs["noise"]["gyro_std"], 5)
([2.0, 7.0], 5, 0.00894)
"""

from __future__ import annotations

import copy
import itertools
import math
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError
from etsid.ident.bare import bare
from etsid.ident.choices import DEFAULT_RATE_HZ as DEFAULT_RATE_HZ
from etsid.table import COLUMNS, SEGMENT

METHOD = "block mean"


def native_rate(table: pd.DataFrame) -> float:
    """Sample rate of ``table``, Hz: ``attrs["rate_hz"]``, else from the median time step.

    Raises
    ------
    IdentError
        Fewer than two rows and no ``rate_hz`` attribute, or a non-increasing index.
    """
    rate = table.attrs.get("rate_hz")
    if isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0:
        return float(rate)
    t = np.asarray(table.index, dtype=float)
    steps = np.diff(t)
    steps = steps[steps > 0]
    if steps.size == 0:
        raise IdentError("cannot tell the table's sample rate (fewer than two distinct times)")
    return float(1.0 / np.median(steps))


def factor_for(native_hz: float, rate_hz: float | None) -> int:
    """Integer decimation factor whose rate ``native_hz / k`` is nearest ``rate_hz``
    (1 when ``rate_hz`` is None or not below the native rate)."""
    if rate_hz is None or rate_hz <= 0 or rate_hz >= native_hz:
        return 1
    k = native_hz / rate_hz
    lo, hi = max(1, math.floor(k)), max(1, math.ceil(k))
    return lo if abs(native_hz / lo - rate_hz) <= abs(native_hz / hi - rate_hz) else hi


def _scale_noise(value: Any, scale: float) -> Any:
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return float(value) * scale
    if isinstance(value, (list, tuple)):
        return [_scale_noise(v, scale) for v in value]
    if isinstance(value, dict):
        return {k: _scale_noise(v, scale) for k, v in value.items()}
    return value


def _noise_after(noise: Any, k: int) -> Any:
    """``attrs["noise"]`` with the white-noise σ of the rate (and ``*_std``) entries of
    the outputs scaled by 1/√k; the native values are kept as ``*_native``."""
    if not isinstance(noise, dict):
        return noise
    out = copy.deepcopy(noise)
    scale = 1.0 / math.sqrt(k)
    for key in [k_ for k_ in noise if k_.endswith("_std")]:
        if key in ("gyro_bias_std",):  # a constant bias does not average out
            continue
        out[f"{key}_native"] = copy.deepcopy(noise[key])
        out[key] = _scale_noise(noise[key], scale)
    return out


def block_starts(segments: np.ndarray, k: int) -> np.ndarray:
    """First row of every complete block of ``k`` rows inside one segment."""
    n = len(segments)
    bounds = np.flatnonzero(np.r_[True, segments[1:] != segments[:-1], True])
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    starts = [np.arange(a, a + ((b - a) // k) * k, k, dtype=np.int64)
              for a, b in itertools.pairwise(bounds.tolist())]
    return np.concatenate(starts)


SEQUENTIAL_MAX = 7
"""Longest block whose mean :func:`block_mean` sums column by column: numpy's
``mean(axis=1)`` adds fewer than 8 values one after the other (pairwise from 8 on), so the
column sums give the same bits (tests/ident/test_ident_resample.py checks it)."""


def block_mean(values: np.ndarray, starts: np.ndarray, k: int,
               fn: Any = None) -> np.ndarray:
    """Mean of ``fn(values)`` (``values`` when None) over the ``k`` rows from each start:
    ``fn(values)[starts[:, None] + arange(k)].mean(axis=1)`` with the same bits, summed as
    k column vectors for short blocks (an (N, k) row reduction is one short numpy loop per
    row: 1 ms per column of 30,000 blocks)."""
    if k > SEQUENTIAL_MAX:
        block = values[starts[:, None] + np.arange(k)[None, :]]
        return (block if fn is None else fn(block)).mean(axis=1)
    first = int(starts[0]) if starts.size else 0
    if starts.size > 1 and values.ndim == 1 and bool(np.all(np.diff(starts) == k)):
        # one run of adjacent blocks: row j of every block is a strided slice, not a gather
        def rows(j: int) -> np.ndarray:
            return values[first + j:first + j + k * (starts.size - 1) + 1:k]
    else:
        def rows(j: int) -> np.ndarray:
            return values[starts + j]
    total = rows(0) if fn is None else fn(rows(0))
    for j in range(1, k):
        part = rows(j)
        total = total + (part if fn is None else fn(part))
    return total / k


def decimate(table: pd.DataFrame, rate_hz: float | None) -> pd.DataFrame:
    """Block-mean decimation of ``table`` to the integer fraction of its rate nearest
    ``rate_hz`` (Hz); the table itself when no decimation is needed.

    Parameters
    ----------
    table
        Indexed by ``t`` (s); optional ``segment`` column (blocks stay inside a segment).
    rate_hz
        Wanted identification rate, Hz; None keeps the native rate.

    Returns
    -------
    DataFrame
        Index: the mean time of each block, s. ``attrs`` as the input's plus
        ``decimation`` = ``{"factor", "native_rate_hz", "rate_hz", "method"}``, ``rate_hz``
        updated and the noise σ scaled by 1/√k (module docstring).
    """
    native = native_rate(table)
    k = factor_for(native, rate_hz)
    info = {"factor": k, "native_rate_hz": native, "rate_hz": native / k,
            "method": METHOD if k > 1 else "none", "requested_hz": rate_hz}
    if k == 1:
        out = table.copy(deep=False)
        out.attrs = {**table.attrs, "decimation": info}
        return out
    seg = (table[SEGMENT].to_numpy(dtype=np.int64) if SEGMENT in table.columns
           else np.zeros(len(table), dtype=np.int64))
    starts = block_starts(seg, k)
    if starts.size == 0:
        raise IdentError(f"the table is too short to decimate by {k} "
                         f"({native:.1f} Hz → {native / k:.1f} Hz)")
    t = block_mean(np.asarray(table.index, dtype=float), starts, k)
    data: dict[str, np.ndarray] = {}
    cols = bare(table)
    for column in table.columns:
        values = cols[column].to_numpy()
        if column == SEGMENT:
            data[column] = values[starts]
            continue
        if not np.issubdtype(values.dtype, np.number):
            data[column] = values[starts]
            continue
        values = np.asarray(values, dtype=float)  # (no copy of a float column)
        spec = COLUMNS.get(column)
        if spec is not None and spec.interp == "angle":
            data[column] = np.arctan2(block_mean(values, starts, k, np.sin),
                                      block_mean(values, starts, k, np.cos))
        else:
            data[column] = block_mean(values, starts, k)
    out = pd.DataFrame(data, index=pd.Index(t, name=table.index.name or "t"))
    attrs = copy.deepcopy(dict(table.attrs))
    attrs["rate_hz"] = native / k
    attrs["decimation"] = info
    if "noise" in attrs:
        attrs["noise"] = _noise_after(table.attrs["noise"], k)
    out.attrs = attrs
    return out
