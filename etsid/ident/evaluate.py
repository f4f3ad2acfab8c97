"""Evaluation of a run: prediction columns (online, frozen one-step and free-run, ARX),
metrics per output, and the predictions.parquet frame."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from etsid.ets import ETS
from etsid.ident.arx import ARX, rls_online
from etsid.ident.metrics import scores
from etsid.ident.regressors import Regression, RegressorSpec
from etsid.ident.simulate import envelope, free_run, linear_stability
from etsid.table import COLUMNS, RATE_COLUMNS


def noise_std(table: pd.DataFrame, outputs: tuple[str, ...]) -> dict[str, float]:
    """Known sensor-noise σ per output from ``table.attrs["noise"]`` (gyro σ for p, q, r)."""
    noise = table.attrs.get("noise") or {}
    out: dict[str, float] = {}
    gyro = noise.get("gyro_std") if isinstance(noise, dict) else None
    for y in outputs:
        value: Any = noise.get(f"{y}_std") if isinstance(noise, dict) else None
        if value is None and y in ("p", "q", "r") and gyro is not None:
            value = gyro
            if isinstance(gyro, dict):
                value = gyro.get(y)
            elif isinstance(gyro, (list, tuple)) and len(gyro) == 3:
                value = gyro["pqr".index(y)]
        if isinstance(value, (int, float)) and np.isfinite(value):
            out[y] = float(value)
    return out


def _unit(name: str) -> str:
    spec = COLUMNS.get(name)
    return spec.unit if spec else ""


def persistence(reg: Regression, spec: RegressorSpec, table: pd.DataFrame | None = None
                ) -> np.ndarray:
    """The "no change" prediction ŷ_k = y_{k−1} (N, m): from the regressor ``y[k-1]`` when
    the model has it, else from the table row before (NaN across a segment start)."""
    n, m = reg.Y.shape
    out = np.full((n, m), np.nan)
    names = [str(t) for t in spec.terms]
    for o, y in enumerate(spec.outputs):
        if f"{y}[k-1]" in names:
            out[:, o] = reg.X[:, names.index(f"{y}[k-1]")]
        elif table is not None and y in table.columns:
            values = table[y].to_numpy(dtype=float)
            seg = (table["segment"].to_numpy() if "segment" in table.columns
                   else np.zeros(len(table)))
            prev = reg.rows - 1
            ok = (prev >= 0) & (seg[np.maximum(prev, 0)] == seg[reg.rows])
            out[ok, o] = values[prev[ok]]
    return out


def prediction_columns(reg: Regression, spec: RegressorSpec, split: int, n_table: int,
                       yhat: np.ndarray, frozen: ETS | None,
                       table: pd.DataFrame | None = None
                       ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """All prediction columns: online, frozen one-step and free-run, ARX online/val/sim,
    persistence; and the times at which each free run diverged
    (:mod:`etsid.ident.simulate`), keyed ``ets`` and ``arx``."""
    n, m = reg.Y.shape
    cols = {k: np.full((n, m), np.nan) for k in ("y_val", "y_sim", "y_arx_val", "y_arx_sim")}
    cols["y_hat"] = yhat
    cols["y_arx"] = rls_online(reg.X, reg.Y)
    cols["y_persist"] = persistence(reg, spec, table)
    diverged: dict[str, Any] = {"ets": [], "arx": []}
    bounds = envelope(reg.Y)
    if frozen is not None and split < n:
        S = None if reg.S is None else reg.S[split:]
        cols["y_val"][split:] = np.asarray(frozen.predict(reg.X[split:], S)).reshape(n - split,
                                                                                     m)
        cols["y_sim"][split:] = free_run(frozen, reg, spec, split, n_table, bounds,
                                         diverged["ets"])
    rate = _rate_hz(reg)
    x0 = np.nanmean(reg.X[:max(split, 1)], axis=0) if n else np.zeros(reg.X.shape[1])
    stability: dict[str, Any] = {}
    if frozen is not None and split < n:
        if reg.S is None:
            stability["ets"] = linear_stability(frozen.predict_one, spec, x0, rate)
        else:  # scheduled: linearised at the learning part's mean scheduling vector too
            s0 = np.nanmean(reg.S[:max(split, 1)], axis=0)
            stability["ets"] = linear_stability(lambda x: frozen.predict_one(x, s0), spec, x0,
                                                rate)
    if split >= reg.X.shape[1] + 1 and split < n:
        arx = ARX.fit(reg.X[:split], reg.Y[:split])
        cols["y_arx_val"][split:] = arx.predict(reg.X[split:])
        cols["y_arx_sim"][split:] = free_run(arx, reg, spec, split, n_table,
                                             bounds, diverged["arx"])
        stability["arx"] = linear_stability(arx.predict_one, spec, x0, rate)
    diverged["stability"] = stability
    return cols, diverged


def _rate_hz(reg: Regression) -> float:
    """Sample rate of the regression rows, Hz (median spacing inside segments)."""
    if len(reg.t) < 2:
        return 1.0
    dt = np.diff(reg.t)
    if reg.segment is not None:
        dt = dt[np.diff(reg.segment) == 0]
    dt = dt[dt > 0]
    return float(1.0 / np.median(dt)) if dt.size else 1.0


def _free_run_scores(meas: np.ndarray, sim: np.ndarray, reg: Regression, split: int,
                     diverged: list[float], stability: dict[str, Any] | None = None
                     ) -> dict[str, Any]:
    """Free-run scores on the rows simulated before any divergence, the divergence flag
    and times, the frozen model's stability and the fit of every segment of the
    validation part."""
    block: dict[str, Any] = scores(meas, sim)
    stability = stability or {}
    block["unstable_model"] = bool(stability.get("unstable", False))
    block["spectral_radius"] = stability.get("spectral_radius")
    block["doubling_time_s"] = stability.get("doubling_time_s")
    block["diverged"] = bool(diverged)
    block["diverged_at"] = diverged[0] if diverged else None
    block["diverged_times"] = list(diverged)
    seg = reg.segment if reg.segment is not None else np.zeros(len(reg.Y), dtype=np.int64)
    per = []
    t = reg.t[split:]
    for value in np.unique(seg[split:]):
        rows = seg[split:] == value
        stop = [d for d in diverged if t[rows][0] <= d <= t[rows][-1]]
        per.append({"segment": int(value), "t_start": float(t[rows][0]),
                    "t_end": float(t[rows][-1]), "fit": scores(meas[rows], sim[rows])["fit"],
                    "n": int(np.count_nonzero(np.isfinite(sim[rows]))),
                    "diverged_at": stop[0] if stop else None})
    block["segments"] = per
    return block


def output_metrics(reg: Regression, spec: RegressorSpec, split: int,
                   cols: dict[str, np.ndarray], sigma: dict[str, float],
                   sigma_native: dict[str, float] | None = None,
                   diverged: dict[str, Any] | None = None,
                   motion_min: float | None = None) -> dict[str, Any]:
    """metrics.json ``outputs``: online, validation, ARX and persistence scores per
    output; free-run blocks carry ``diverged``, ``diverged_at`` (s) and ``segments``.

    With ``motion_min`` (rad/s; identify and predict pass
    :data:`etsid.ident.flight.EXCITE_STD`) every validation block (eTS and ARX, one-step
    and free-run) of a body-rate output (p, q, r) also holds ``signal_std`` (the measured
    output's standard deviation over the validation part) and ``informative``
    (``signal_std`` ≥ ``motion_min``): an output that barely moves there is scored on
    noise, and its fit % means nothing."""
    n = len(reg.Y)
    diverged = diverged or {"ets": [], "arx": []}
    stab: dict[str, Any] = diverged.get("stability") or {}
    out: dict[str, Any] = {}
    val = slice(split, n)
    for o, y in enumerate(spec.outputs):
        meas = reg.Y[:, o]
        entry: dict[str, Any] = {"unit": _unit(y), "noise_std": sigma.get(y),
                                 "noise_std_native": (sigma_native or {}).get(y)}
        entry["online"] = scores(meas, cols["y_hat"][:, o])
        if split < n:
            entry["validation"] = {
                "one_step": scores(meas[val], cols["y_val"][val, o]),
                "free_run": _free_run_scores(meas[val], cols["y_sim"][val, o], reg, split,
                                             diverged["ets"], stab.get("ets"))}
        else:
            entry["validation"] = None
        arx: dict[str, Any] = {"online": scores(meas, cols["y_arx"][:, o])}
        if split < n and np.isfinite(cols["y_arx_val"][val, o]).any():
            arx["validation"] = {
                "one_step": scores(meas[val], cols["y_arx_val"][val, o]),
                "free_run": _free_run_scores(meas[val], cols["y_arx_sim"][val, o], reg, split,
                                             diverged["arx"], stab.get("arx"))}
        else:
            arx["validation"] = None
        entry["arx"] = arx
        if motion_min is not None and split < n and y in RATE_COLUMNS:
            std = float(np.nanstd(meas[val]))
            for block in (*(entry["validation"] or {}).values(),
                          *((arx["validation"] or {}).values())):
                block["signal_std"] = std
                block["informative"] = bool(std >= motion_min)
        entry["persistence"] = {"online": scores(meas, cols["y_persist"][:, o]),
                                "validation": scores(meas[val], cols["y_persist"][val, o])
                                if split < n else None}
        if y in sigma and sigma[y] > 0:
            for block in (entry["online"], *((entry["validation"] or {}).values()),
                          arx["online"], *((arx["validation"] or {}).values())):
                if block.get("rmse") is not None:
                    block["rmse_over_noise"] = block["rmse"] / sigma[y]
        out[y] = entry
    return out


def predictions_frame(reg: Regression, spec: RegressorSpec, table: pd.DataFrame, split: int,
                      cols: dict[str, np.ndarray]) -> pd.DataFrame:
    """predictions.parquet: t, segment, part and per output the measured and predicted
    columns."""
    frame: dict[str, Any] = {"t": reg.t}
    if "segment" in table.columns:
        frame["segment"] = table["segment"].to_numpy()[reg.rows]
    part = np.full(len(reg.t), "learn", dtype=object)
    part[split:] = "validation"
    frame["part"] = part
    for o, y in enumerate(spec.outputs):
        frame[y] = reg.Y[:, o]
        for key in ("y_hat", "y_val", "y_sim", "y_arx", "y_arx_val", "y_arx_sim",
                    "y_persist"):
            frame[y + key[1:]] = cols[key][:, o]
    return pd.DataFrame(frame)


def rate_info(table: pd.DataFrame) -> dict[str, Any]:
    """Identification rate facts of a (decimated) table for metrics/config/rules."""
    d = dict(table.attrs.get("decimation") or {})
    return {"rate_hz": d.get("rate_hz"), "native_rate_hz": d.get("native_rate_hz"),
            "factor": d.get("factor", 1), "method": d.get("method", "none"),
            "requested_hz": d.get("requested_hz")}


def validation_info(reg: Regression, split: int, fraction: float) -> dict[str, Any]:
    """metrics.json ``validation``: the split between learning and validation rows."""
    n = len(reg.t)
    return {"fraction": fraction, "n_learn": split, "n_validation": n - split,
            "t_start": float(reg.t[split]) if split < n else None,
            "t_end": float(reg.t[-1]) if split < n else None}
