"""The twin report of ``etsid fit --report``: the fitted vehicle replayed against its log.

For each flight: the loop replay (:func:`etsid.sim.replay.replay`, recorded sticks, the
simulator's altitude hold on the recorded altitude) with the fitted vehicle; per channel
(roll, pitch, p, q, r, alt) the twin's RMSE over the log's standard deviation, the log's
own noise on the same scale (second differences: no model can be closer than that), and
a linear ARX model of the same flight run free from the same commands (output lags 2,
command lags 0–3 at 50 Hz, least squares on the whole flight): the data-driven model with
as much freedom as a twin has no right to. A figure shows the three over the flight.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.ident.arx import ARX
from etsid.sim.replay import NOISE_COLUMNS, log_noise_std, replay
from etsid.sim.vehicle import Vehicle

CHANNELS = ("roll", "pitch", "p", "q", "r", "alt")
COMMANDS = ("u_roll", "u_pitch", "u_yaw", "u_thrust")
ARX_HZ = 50.0
NA, NB = 2, 4


def _arx_free_run(table: pd.DataFrame, channel: str) -> np.ndarray | None:
    """ARX of ``channel`` on the commands, simulated free from the first samples."""
    cmds = [c for c in COMMANDS if c in table]
    if channel not in table or len(cmds) < 2:
        return None
    t = table.index.to_numpy(dtype=float)
    grid = np.arange(t[0], t[-1], 1.0 / ARX_HZ)
    y = np.interp(grid, t, table[channel].interpolate(limit_direction="both").to_numpy())
    u = np.column_stack([np.interp(grid, t, table[c].interpolate(
        limit_direction="both").to_numpy()) for c in cmds])
    k0 = max(NA, NB)
    rows = [np.r_[y[k - NA:k][::-1], u[k - NB + 1:k + 1][::-1].ravel()]
            for k in range(k0, len(y))]
    model = ARX.fit(np.asarray(rows), y[k0:, None])
    sim = y.copy()
    for k in range(k0, len(y)):
        x = np.r_[sim[k - NA:k][::-1], u[k - NB + 1:k + 1][::-1].ravel()]
        sim[k] = float(model.predict_one(x)[0])
        if not math.isfinite(sim[k]) or abs(sim[k]) > 1e6:
            sim[k:] = np.nan
            break
    return np.interp(t, grid, sim)


def twin_report(table: pd.DataFrame, vehicle: Vehicle, out_png: Path | None = None
                ) -> dict[str, Any]:
    """Per-channel errors of the twin and the ARX model, and the figure (when asked)."""
    twin = replay(table, vehicle, mode="loop", thrust="alt_hold", noise="log")
    noise = log_noise_std(table, np.full(len(NOISE_COLUMNS) + 20, np.nan))
    out: dict[str, Any] = {"source": table.attrs.get("source"), "divergence": twin.divergence,
                           "channels": {}}
    arx_runs = {}
    for ch in CHANNELS:
        if ch not in table or ch not in twin.table:
            continue
        log = table[ch].to_numpy(dtype=float)
        std = float(np.nanstd(log))
        e_twin = twin.table[ch].to_numpy(dtype=float) - log
        arx = _arx_free_run(table, ch)
        arx_runs[ch] = arx
        e_arx = arx - log if arx is not None else None
        out["channels"][ch] = {
            "twin": float(np.sqrt(np.nanmean(e_twin ** 2)) / std) if std else math.nan,
            "noise": float(noise[NOISE_COLUMNS[ch]] / std) if std else math.nan,
            "arx": (float(np.sqrt(np.nanmean(e_arx ** 2)) / std) if e_arx is not None
                    and np.isfinite(e_arx).any() else math.nan)}
    if out_png is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        chans = list(out["channels"])
        fig, axes = plt.subplots(len(chans), 1, sharex=True, figsize=(9, 1.6 * len(chans)))
        t = table.index.to_numpy(dtype=float)
        for ax, ch in zip(np.atleast_1d(axes), chans, strict=True):
            m = out["channels"][ch]
            ax.plot(t, table[ch], color="k", lw=0.8, label="log")
            ax.plot(t, twin.table[ch], color="tab:red", lw=0.8,
                    label=f"twin (RMSE {m['twin']:.2f} std)")
            if arx_runs.get(ch) is not None:
                ax.plot(t, arx_runs[ch], color="tab:blue", lw=0.6, alpha=0.7,
                        label=f"ARX free run ({m['arx']:.2f})")
            ax.set_ylabel(ch, fontsize=8)
            ax.legend(fontsize=6, loc="upper right",
                      title=f"log noise {m['noise']:.2f} std", title_fontsize=6)
            ax.tick_params(labelsize=7)
        np.atleast_1d(axes)[-1].set_xlabel("t (s)")
        fig.suptitle(f"fitted twin vs log: {Path(str(out['source'])).name}", fontsize=9)
        fig.tight_layout()
        fig.savefig(out_png, dpi=100)
        plt.close(fig)
    return out
