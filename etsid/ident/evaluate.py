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
from etsid.ident.simulate import free_run
from etsid.table import COLUMNS


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


def prediction_columns(reg: Regression, spec: RegressorSpec, split: int, n_table: int,
             yhat: np.ndarray, frozen: ETS | None) -> dict[str, np.ndarray]:
    """All prediction columns: online, frozen one-step and free-run, ARX online/val/sim."""
    n, m = reg.Y.shape
    cols = {k: np.full((n, m), np.nan) for k in ("y_val", "y_sim", "y_arx_val", "y_arx_sim")}
    cols["y_hat"] = yhat
    cols["y_arx"] = rls_online(reg.X, reg.Y)
    if frozen is not None and split < n:
        cols["y_val"][split:] = np.asarray(frozen.predict(reg.X[split:])).reshape(n - split, m)
        cols["y_sim"][split:] = free_run(frozen.predict_one, reg, spec, split, n_table)
    if split >= reg.X.shape[1] + 1 and split < n:
        arx = ARX.fit(reg.X[:split], reg.Y[:split])
        cols["y_arx_val"][split:] = arx.predict(reg.X[split:])
        cols["y_arx_sim"][split:] = free_run(arx.predict_one, reg, spec, split, n_table)
    return cols


def output_metrics(reg: Regression, spec: RegressorSpec, split: int,
                   cols: dict[str, np.ndarray], sigma: dict[str, float],
                   sigma_native: dict[str, float] | None = None) -> dict[str, Any]:
    """metrics.json ``outputs``: online, validation and ARX scores per output."""
    n = len(reg.Y)
    out: dict[str, Any] = {}
    val = slice(split, n)
    for o, y in enumerate(spec.outputs):
        meas = reg.Y[:, o]
        entry: dict[str, Any] = {"unit": _unit(y), "noise_std": sigma.get(y),
                                 "noise_std_native": (sigma_native or {}).get(y)}
        entry["online"] = scores(meas, cols["y_hat"][:, o])
        if split < n:
            entry["validation"] = {"one_step": scores(meas[val], cols["y_val"][val, o]),
                                   "free_run": scores(meas[val], cols["y_sim"][val, o])}
        else:
            entry["validation"] = None
        arx: dict[str, Any] = {"online": scores(meas, cols["y_arx"][:, o])}
        if split < n and np.isfinite(cols["y_arx_val"][val, o]).any():
            arx["validation"] = {"one_step": scores(meas[val], cols["y_arx_val"][val, o]),
                                 "free_run": scores(meas[val], cols["y_arx_sim"][val, o])}
        else:
            arx["validation"] = None
        entry["arx"] = arx
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
        for key in ("y_hat", "y_val", "y_sim", "y_arx", "y_arx_val", "y_arx_sim"):
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
            "t_start": float(reg.t[split]) if split < n else None}
