"""Anderson–Rubin test of an instrumented equation: a confidence set for the parameters
that enter the regressors nonlinearly (the motor lag τ and delay d) that stays valid
however weakly the instruments pin those parameters down.

At a candidate (τ, d) the regressors X are fully specified, and the structural residual
u = y − X β must be uncorrelated with the instruments Z. The linear coefficients β are
profiled out by two-stage least squares (the minimum of |P_Z u|², as the point estimate):

    κ = |P_Z u|² / |M_Z u|²,   AR = (n − r) κ / c

with r instrument columns and c the HAC inflation of the projection: under the null each
unit instrument column q carries E (qᵀu)² = σ² Σ_k ρ_u(k) γ_q(k) (ρ_u the residual's
autocorrelation, γ_q the column's own autocovariance), so c = (1/r) Σ_k w_k ρ_u(k) Γ(k)
with Γ = Σ_q γ_q over the instrument columns and Bartlett weights w_k over 3 τ_int lags —
the same kernel and bandwidth as :func:`etsid.fit.regress.hac_cov` (white instruments
give c = 1; instruments slower than the residual give its correlation time: the
effective-sample correction). Under the null AR ≈ χ²(r − p), p profiled coefficients.
What is tested is (τ, d), not β: the null's distribution does not depend on how strongly
the instruments separate τ from d, so the non-rejected candidates are an honest 95 % set
even where the objective is flat (τ and d trading along a valley): it is then wide. It
asks β to be well determined at a given (τ, d) (the effectivenesses are, to 1–5 %).
Profiling by LIML instead (the least favourable β, Guggenberger et al. 2012) was tried:
on etsid's simulator (seed 100) its ratio was lowest at τ = 250 ms, where the free
coefficients inflate the residual's part outside the instruments.

Several equations tested jointly (roll and pitch): the sum of their statistics, referred
to a scaled χ² with the first two moments of a sum of two correlated χ²'s (Satterthwaite:
with residual correlation ρ, scale 1 + ρ², degrees of freedom 2(r − p)/(1 + ρ²)).

A model that is not exact is rejected at every candidate once the data are long and the
instruments strong (the test checks the over-identifying restrictions too): the set is
then empty, and says nothing about τ and d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from etsid.fit.regress import autocorrelation, integrated_time

LEVEL = 0.95
"""Coverage of the confidence set (the 95 % of every interval of the fit)."""


@dataclass(frozen=True)
class ArStat:
    """Anderson–Rubin statistic of one equation at one candidate."""

    stat: float          # (n − r) κ / c
    df: int              # r − p
    resid: np.ndarray    # (n,) structural residual at the profiled coefficients


MAX_LAG = 2000
"""Longest lag of the autocorrelations (samples; as :func:`etsid.fit.regress.correlation_time`)."""


def instrument_autocov(q: np.ndarray, max_lag: int = MAX_LAG) -> np.ndarray:
    """Γ(k) = Σ over the columns of q of Σ_t q_t q_{t+k}, k = 0 … max_lag."""
    n = q.shape[0]
    f = np.fft.rfft(q, 2 * n, axis=0)
    return np.fft.irfft(np.sum(np.abs(f) ** 2, axis=1), 2 * n)[:min(max_lag, n - 1) + 1]


def hac_inflation(resid: list[np.ndarray], gammas: list[np.ndarray], r: int) -> float:
    """c of the module docstring: E |P_Z u|² / (σ² r) under the null, per flight's
    residual ρ_u and instruments' Γ, Bartlett weights over 3 τ_int lags."""
    total = 0.0
    for u, gam in zip(resid, gammas, strict=True):
        n = u.size
        m = min(MAX_LAG, n // 4, len(gam) - 1)
        if n < 4 or float(np.var(u)) <= 0 or m < 1:
            total += float(gam[0])
            continue
        rho = autocorrelation(u, m)
        lag = min(m, max(1, int(np.ceil(3.0 * integrated_time(rho)))))
        w = 1.0 - np.arange(1, lag + 1) / (lag + 1)
        total += float(gam[0] + 2.0 * np.sum(w * rho[1:lag + 1] * gam[1:lag + 1]))
    return max(total / r, 1e-3)


def ar_statistic(parts: list[tuple[np.ndarray, np.ndarray]],
                 gammas: list[np.ndarray] | None = None) -> ArStat | None:
    """AR statistic of y = X β + u over pooled flights.

    Parameters
    ----------
    parts : list of (W, Q)
        Per flight: W (n, 1 + p) = [y, X] and Q (n, r) an orthonormal instrument basis
        (the coefficients β are shared by the flights, the instruments are per flight).
    gammas : list of ndarray, optional
        Per flight, :func:`instrument_autocov` of Q (computed here when not given).

    Returns None when there are no more instrument columns than coefficients.
    """
    p = parts[0][0].shape[1] - 1
    n = sum(w.shape[0] for w, _ in parts)
    r = sum(q.shape[1] for _, q in parts)
    if r <= p or n <= r + 1:
        return None
    g = sum(w.T @ w for w, _ in parts)
    pw = [q.T @ w for w, q in parts]
    h = sum(x.T @ x for x in pw)
    scale = np.sqrt(np.maximum(np.diag(g), 1e-300))
    hs, rs = h / np.outer(scale, scale), (g - h) / np.outer(scale, scale)
    # β by two-stage least squares (the minimum of |P_Z u|²), as the point estimate's
    beta = np.linalg.lstsq(hs[1:, 1:], hs[1:, 0], rcond=None)[0]
    vs = np.concatenate([[1.0], -beta])
    num, den = float(vs @ hs @ vs), float(vs @ rs @ vs)
    if den <= 0:
        return None
    kappa = max(num, 0.0) / den
    v = vs / scale                        # (1, −β) in the columns' own units
    res = [w @ v for w, _ in parts]
    gammas = gammas if gammas is not None else [instrument_autocov(q) for _, q in parts]
    c = hac_inflation(res, gammas, r)
    resid = np.concatenate(res)
    return ArStat(stat=(n - r) * kappa / c, df=r - p, resid=resid)


def joint_statistic(stats: list[ArStat]) -> tuple[float, float]:
    """(statistic, degrees of freedom) of the equations' joint null, χ²-distributed under
    it (module docstring); one equation: (AR, r − p)."""
    if len(stats) == 1:
        return stats[0].stat, float(stats[0].df)
    if len(stats) != 2:
        raise ValueError("one or two equations")
    a, b = stats
    rho = float(np.corrcoef(a.resid, b.resid)[0, 1]) if a.resid.std() and b.resid.std() \
        else 0.0
    s = 1.0 + rho * rho
    return (a.stat + b.stat) / s, (a.df + b.df) / s


def joint_pvalue(stats: list[ArStat]) -> float:
    """p-value of :func:`joint_statistic`."""
    stat, dof = joint_statistic(stats)
    return float(chi2.sf(stat, dof))


@dataclass(frozen=True)
class ConfidenceSet:
    """Projections of the non-rejected grid points on each parameter."""

    lo: tuple[float, float]   # (τ, d) smallest non-rejected
    hi: tuple[float, float]   # (τ, d) largest non-rejected
    at_edge: bool             # a non-rejected point on the grid's boundary
    empty: bool               # every grid point rejected
    misfit: float             # min over the grid of statistic / dof (at least 1)


def confidence_set(grids: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                   bounds: tuple[tuple[float, float], tuple[float, float]]
                   ) -> ConfidenceSet:
    """Projection of the grid points the test does not reject at :data:`LEVEL`.

    ``grids``: (τ values, d values, statistic table (τ, d), degrees-of-freedom table) of
    each grid evaluated (a coarse grid over the whole range, a fine one near the minimum);
    ``bounds``: the range's ((τ min, τ max), (d min, d max)).

    ``misfit``: the smallest statistic over degrees of freedom on the grid (at least 1):
    above about 1.3 with some hundred degrees of freedom, no (τ, d) passes — the
    instruments see a misfit no (τ, d) removes, and the set is empty.
    """
    misfit = max(1.0, float(min(np.nanmin(st / dof) for _, _, st, dof in grids)))
    pts = []
    for taus, delays, st, dof in grids:
        i, j = np.nonzero(chi2.sf(st, dof) > 1.0 - LEVEL)
        pts.extend(zip(taus[i], delays[j], strict=True))
    if not pts:
        return ConfidenceSet((np.nan, np.nan), (np.nan, np.nan), False, True, misfit)
    a = np.array(pts, dtype=float)
    lo, hi = a.min(0), a.max(0)
    (t0, t1), (d0, d1) = bounds
    edge = bool(lo[0] <= t0 * (1 + 1e-9) or hi[0] >= t1 * (1 - 1e-9)
                or lo[1] <= d0 + 1e-9 or hi[1] >= d1 - 1e-9)
    return ConfidenceSet((float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1])),
                         edge, False, misfit)
