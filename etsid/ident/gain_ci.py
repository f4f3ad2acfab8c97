"""Uncertainty of the rules' consequents: standard errors of one coefficient per rule, and
the confidence interval of a ratio of two rules' coefficients (the learnt sentence of
:mod:`etsid.ident.regimes`).

Each rule's consequent is a fuzzily weighted recursive least-squares estimate; its RLS
matrix C_i = (Σ_k λ_ik x_k x_kᵀ + I/ω)⁻¹ (normalised regressors, λ the rule's firing) times
the residual variance σ_i² of the rule's local model is its covariance (Ljung, *System
Identification*, 2nd ed., §11.2: for weighted LS with weights ≤ 1, σ² C bounds the true
covariance C (Σ λ² x xᵀ) C σ² from above, so the interval is conservative). σ_i² is the
mean squared residual of the rule's own consequent over the learning rows it leads, with
the degrees of freedom of its n + 1 parameters removed.

The ratio g_lo / g_hi of two independent estimates: by the delta method on the logarithm,
sd(ln r) = √((se_lo/g_lo)² + (se_hi/g_hi)²) and the 95 % interval r·exp(±1.96 sd).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

Z95 = 1.959964
"""Two-sided 95 % quantile of the standard normal distribution."""


def coefficient_se(rules: dict[str, Any], X: np.ndarray, Y: np.ndarray, lead: np.ndarray
                   ) -> np.ndarray | None:
    """Standard errors (R, n + 1, m) of every rule's consequent coefficients in original
    units (row 0 the intercept), from its RLS matrix and the residual variance over the
    rows ``lead`` says it leads (``lead``: index of the leading rule of each row of ``X``,
    ``Y``); None with global RLS (no per-rule matrix). Rules leading fewer rows than their
    parameters get NaN."""
    from etsid.ets import ETS

    model = ETS.from_dict(rules, trusted=True)
    state = model.export_state()
    if state.covariances is None:
        return None
    n, m, R = state.n_inputs, state.n_outputs, state.n_rules
    xo = model.x_offset_
    s = model.scales()[xo:xo + n]
    cons = model.consequents_raw()  # (R, n + 1, m)
    diag = np.array([np.diag(c) for c in state.covariances])  # (R, n + 1), normalised
    scale = np.r_[1.0, 1.0 / s]  # raw coefficient = normalised / s (intercept: see note)
    out = np.full((R, n + 1, m), np.nan)
    for i in range(R):
        rows = lead == i
        k = int(np.count_nonzero(rows))
        if k <= n + 1:
            continue
        resid = Y[rows] - (cons[i, 0] + X[rows] @ cons[i, 1:])
        var = np.sum(resid * resid, axis=0) / (k - (n + 1))  # (m,)
        se = np.sqrt(np.clip(diag[i], 0.0, None))[:, None] * np.sqrt(var)[None, :]
        out[i] = se * scale[:, None]
    out[:, 0, :] = np.nan  # the raw intercept mixes every coefficient: not used
    return out


def ratio_interval(g_lo: float, se_lo: float, g_hi: float, se_hi: float
                   ) -> tuple[float, float] | None:
    """95 % interval of g_lo / g_hi (same signs), or None when it cannot be given."""
    if not all(math.isfinite(v) for v in (g_lo, se_lo, g_hi, se_hi)) or g_lo * g_hi <= 0:
        return None
    sd = math.hypot(se_lo / g_lo, se_hi / g_hi)
    r = g_lo / g_hi
    return r * math.exp(-Z95 * sd), r * math.exp(Z95 * sd)


def sign_interval(g: float, se: float) -> bool:
    """Whether the 95 % interval of ``g`` excludes zero."""
    return math.isfinite(se) and abs(g) > Z95 * se
