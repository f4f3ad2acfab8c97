"""The ``unexplained`` entry's model: an eTS model of what no named effect explains.

When a channel stays mismatched (nothing named, or a leftover after the named effects),
its residual is learnt by an evolving Takagi–Sugeno model scheduled on the variable that
locates it (height, speed, thrust, command rate, pack voltage or time), fitted on one fold
of REAL's blocks and scored on the other. It describes the structure; it names no physics
and never changes the verdict (a mismatch stays a mismatch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from etsid.ets import ETS

MIN_GAIN = 0.30
"""Least relative drop of the channel's held-out mean square error the eTS model must give
to be reported: a flexible model picks up some of any residual, noise included, so a
smaller drop is not structure worth a model (reported only; the verdict is unaffected)."""
MAX_TRAINING = 4000
"""Samples the model learns from (the fitting fold thinned evenly): one pass of eTS over
them takes milliseconds, and a low-passed residual holds no more information."""


@dataclass
class ResidualModel:
    """An eTS model of one channel's residual and what it does on held-out blocks."""

    channel: str
    variables: list[str]
    n_rules: int
    rmse_before: float
    """Held-out RMSE of the residual, channel units."""
    rmse_after: float
    """Held-out RMSE after the model's prediction is taken off."""
    correction: np.ndarray
    """The model's prediction of the residual at every sample, channel units."""


def fit_residual_model(channel: str, residual: np.ndarray,
                       variables: dict[str, np.ndarray], fit: np.ndarray,
                       hold: np.ndarray) -> ResidualModel | None:
    """eTS model of ``residual`` on ``variables`` learnt on ``fit``, or None when it does not
    cut the mean square error on ``hold`` by :data:`MIN_GAIN`."""
    names = list(variables)
    x = np.column_stack([variables[v] for v in names])
    usable = fit & np.all(np.isfinite(x), axis=1) & np.isfinite(residual)
    scored = hold & np.all(np.isfinite(x), axis=1) & np.isfinite(residual)
    if np.sum(usable) < 10 * len(names) or not np.any(scored):
        return None
    lo, hi = x[usable].min(axis=0), x[usable].max(axis=0)
    hi = np.where(hi > lo, hi, lo + 1.0)
    y = residual[:, None]
    ylo, yhi = float(np.min(y[usable])), float(np.max(y[usable]))
    model = ETS(radius=0.3, x_range=np.column_stack([lo, hi]),
                y_range=np.array([[ylo, max(yhi, ylo + 1e-9)]]), input_names=names,
                output_names=[channel], max_rules=12, history_every=100000,
                utility_threshold=0.05, adaptive_spread=False, forgetting=1.0)
    idx = np.flatnonzero(usable)
    idx = idx[::max(idx.size // MAX_TRAINING, 1)]
    model.run(x[idx], y[idx])
    correction = np.nan_to_num(model.predict(np.nan_to_num(x))[:, 0])
    before = float(np.mean(residual[scored] ** 2))
    after = float(np.mean((residual - correction)[scored] ** 2))
    if after > (1.0 - MIN_GAIN) * before:
        return None
    return ResidualModel(channel, names, model.n_rules, float(np.sqrt(before)),
                         float(np.sqrt(after)), correction)
