"""Scores of a closed-loop flight (all on the noise-free height, never the measured one).

* ``tracking_rmse``: RMS of r − h after the first :data:`SCORE_AFTER` seconds, m.
* ``max_error``: largest |r − h| after the first :data:`SCORE_AFTER` seconds, m;
  ``max_error_all`` over the whole flight (learning transient included).
* ``settling_time``: per reference step, time until |r − h| enters and stays within
  :func:`settle_band` of the new height before the next step, s (None when it never does);
  with ``settling_time_mean`` / ``settling_time_max``.
* ``control_effort``: RMS rate of change of the collective after :data:`SCORE_AFTER` s,
  1/s — actuator activity (noise fed to the motors), lower is calmer.
* ``u_mean``: mean collective after :data:`SCORE_AFTER` s.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

SCORE_AFTER = 10.0
"""Seconds at the start of a flight left out of the tracking scores (learning from zero)."""


def settle_band(step: float) -> float:
    """Settling band of a reference step of size ``step`` m: 5 % of it, at least 2 cm."""
    return max(0.05 * abs(step), 0.02)


def settling_times(t: np.ndarray, r: np.ndarray, h: np.ndarray,
                   step_times: list[float]) -> list[float | None]:
    """Settling time of every reference step within the flight (module docstring), s."""
    out: list[float | None] = []
    step_times = [w for w in step_times if t.size and w < t[-1]]
    ends = [*step_times[1:], np.inf]
    for when, end in zip(step_times, ends, strict=True):
        sel = (t >= when) & (t < end)
        if sel.sum() < 2:
            out.append(None)
            continue
        i0 = int(np.argmax(sel))
        before = r[i0 - 1] if i0 > 0 else r[i0]
        band = settle_band(r[i0] - before)
        outside = np.abs(r[sel] - h[sel]) > band
        if outside[-1]:
            out.append(None)
            continue
        idx = np.flatnonzero(outside)
        k = 0 if idx.size == 0 else idx[-1] + 1
        out.append(float(t[sel][k] - when))
    return out


def flight_metrics(table: pd.DataFrame, step_times: list[float] | None = None,
                   score_after: float = SCORE_AFTER) -> dict[str, Any]:
    """Scores of a control flight table (:class:`~etsid.control.loop.ControlFlight`)."""
    t = table.index.to_numpy(dtype=float)
    r = table["alt_ref"].to_numpy()
    h = table["true_alt"].to_numpy()
    u = table["u_thrust"].to_numpy()
    err = r - h
    sel = t >= score_after
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    out: dict[str, Any] = {
        "score_after_s": score_after,
        "tracking_rmse": float(np.sqrt(np.mean(err[sel] ** 2))) if sel.any() else None,
        "max_error": float(np.max(np.abs(err[sel]))) if sel.any() else None,
        "max_error_all": float(np.max(np.abs(err))),
        "control_effort": (float(np.sqrt(np.mean((np.diff(u[sel]) / dt) ** 2)))
                           if sel.sum() > 1 else None),
        "u_mean": float(np.mean(u[sel])) if sel.any() else None,
        "settling_time": None,
    }
    if step_times:
        st = settling_times(t, r, h, step_times)
        done = [s for s in st if s is not None]
        out["settling_time"] = st
        out["settling_time_mean"] = float(np.mean(done)) if done else None
        out["settling_time_max"] = (float(np.max(done)) if len(done) == len(st) else None)
    return out
