"""The fleet figure of ``etsid batch fit``: each airframe's parameters over its flights,
with 95 % intervals, the reference flights shaded and every flag marked."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from etsid.fit.fleet import N_REFERENCE, tracked


def fleet_figure(rows: pd.DataFrame, flags: list[dict[str, Any]], out: Path) -> Path:
    """Draw ``out`` (PNG): one column per airframe, one row per trended parameter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    airframes = sorted(rows["airframe"].unique())
    params = tracked(rows)
    fig, axes = plt.subplots(len(params), len(airframes), squeeze=False, sharex=True,
                             figsize=(3.6 * len(airframes), 1.5 * len(params) + 0.8))
    for j, airframe in enumerate(airframes):
        group = rows[rows["airframe"] == airframe].sort_values("index")
        x = group["index"].to_numpy()
        for i, name in enumerate(params):
            ax = axes[i, j]
            if name not in group:
                continue
            v = group[name].to_numpy(dtype=float)
            se = group[f"{name}_se"].to_numpy(dtype=float)
            ax.axvspan(0.5, N_REFERENCE + 0.5, color="0.92", lw=0)
            ax.errorbar(x, v, yerr=1.96 * se, fmt="o", ms=3, lw=1, color="tab:blue")
            for flag in flags:
                if flag["airframe"] == airframe and flag["param"] == name:
                    ax.axvline(flag["flight"], color="tab:red", lw=2)
                    ax.set_facecolor("#fff0f0")
            if j == 0:
                ax.set_ylabel(name.replace("_", " "), fontsize=7)
            if i == 0:
                ax.set_title(airframe, fontsize=9)
            ax.tick_params(labelsize=6)
        axes[-1, j].set_xlabel("flight", fontsize=8)
    fig.suptitle("etsid batch fit: parameters per flight (95 % intervals; grey: reference "
                 "flights; red: change flagged where it starts)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
