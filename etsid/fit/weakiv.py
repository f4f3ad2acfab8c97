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
instruments strong (the test checks the over-identifying restrictions too): the AR set is
then empty, and says nothing about τ and d. :func:`distance_set` is the set for that case:
the smallest statistic over its degrees of freedom, φ, measures the misfit as an
over-dispersion of the moment conditions (their variance φ times what the HAC estimate
says, as a quasi-likelihood's dispersion), and with instruments strong enough to reject
every candidate the statistic's excess over its minimum is the distance-metric
(quasi-likelihood-ratio) statistic of (τ, d) (Newey and West 1987): (AR − AR_min) / φ
≈ χ²(2). Its 95 % set is not weak-instrument robust, and is used only where the AR set is
empty — the strong-instrument case.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    """Projections of the set on each parameter: of the grid points bounding it
    (:attr:`points`)."""

    lo: tuple[float, float]   # (τ, d) smallest of the bounding points
    hi: tuple[float, float]   # (τ, d) largest
    at_edge: bool             # a non-rejected point on the whole grid's boundary
    empty: bool               # every grid point rejected
    misfit: float             # min over the grid of statistic / dof (at least 1)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    """(k, 2) grid points bounding the set: the non-rejected ones and, on the finest grid,
    their neighbours (:func:`confidence_set`)."""
    kind: str = "anderson-rubin"
    """"anderson-rubin" or "distance" (:func:`distance_set`, the AR set being empty)."""


def confidence_set(grids: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                   bounds: tuple[tuple[float, float], tuple[float, float]]
                   ) -> ConfidenceSet:
    """Projection of the grid points the test does not reject at :data:`LEVEL`.

    ``grids``: (τ values, d values, statistic table (τ, d), degrees-of-freedom table) of
    each grid evaluated (a coarse grid over the whole range, a fine one near the minimum,
    last); ``bounds``: the range's ((τ min, τ max), (d min, d max)).

    A grid locates the set's boundary only between its last accepted and first rejected
    points: on the last (finest) grid the set is therefore bounded by the accepted points'
    neighbours (one step each way, diagonals included), which are its :attr:`points` and
    projections — a set narrower than one step (the common case with strong instruments:
    15 % in τ, 2 ms in d) is otherwise a single point and says nothing about the error.
    The edge flag is of the accepted points themselves.

    ``misfit``: the smallest statistic over degrees of freedom on the grid (at least 1):
    above about 1.3 with some hundred degrees of freedom, no (τ, d) passes — the
    instruments see a misfit no (τ, d) removes, and the set is empty.
    """
    misfit = max(1.0, float(min(np.nanmin(st / dof) for _, _, st, dof in grids)))
    masks = [chi2.sf(st, dof) > 1.0 - LEVEL for _, _, st, dof in grids]
    if not any(m.any() for m in masks):
        return ConfidenceSet((np.nan, np.nan), (np.nan, np.nan), False, True, misfit)
    return _from_masks(grids, masks, bounds, misfit, "anderson-rubin")


def _dilate(mask: np.ndarray) -> np.ndarray:
    """The mask grown by one grid step each way (3 × 3 neighbourhood)."""
    out = mask.copy()
    padded = np.pad(mask, 1)
    for di in (0, 1, 2):
        for dj in (0, 1, 2):
            out |= padded[di:di + mask.shape[0], dj:dj + mask.shape[1]]
    return out


def _from_masks(grids: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                masks: list[np.ndarray],
                bounds: tuple[tuple[float, float], tuple[float, float]], misfit: float,
                kind: str) -> ConfidenceSet:
    accepted, bound = [], []
    for n, ((taus, delays, _, _), m) in enumerate(zip(grids, masks, strict=True)):
        i, j = np.nonzero(m)
        accepted.extend(zip(taus[i], delays[j], strict=True))
        i, j = np.nonzero(_dilate(m) if n == len(grids) - 1 else m)
        bound.extend(zip(taus[i], delays[j], strict=True))
    acc = np.array(accepted, dtype=float)
    a = np.unique(np.array(bound, dtype=float), axis=0)
    lo, hi = a.min(0), a.max(0)
    (t0, t1), (d0, d1) = bounds
    edge = bool(acc[:, 0].min() <= t0 * (1 + 1e-9) or acc[:, 0].max() >= t1 * (1 - 1e-9)
                or acc[:, 1].min() <= d0 + 1e-9 or acc[:, 1].max() >= d1 - 1e-9)
    return ConfidenceSet((float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1])),
                         edge, False, misfit, a, kind)


N_SET_PARAMS = 2
"""Parameters the set is for (τ, d): the distance statistic's degrees of freedom."""


def distance_set(grids: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                 bounds: tuple[tuple[float, float], tuple[float, float]]
                 ) -> ConfidenceSet:
    """The 95 % set of the misfit-scaled distance statistic (module docstring): the grid
    points with (AR − AR_min) / φ ≤ χ²₉₅(2), φ = min AR / dof (at least 1); arguments as
    :func:`confidence_set`, and bounded on the grid alike. Never empty (the best point is
    in it)."""
    misfit = max(1.0, float(min(np.nanmin(st / dof) for _, _, st, dof in grids)))
    best = float(min(np.nanmin(st) for _, _, st, _ in grids))
    limit = float(chi2.ppf(LEVEL, N_SET_PARAMS))
    masks = [(st - best) / misfit <= limit for _, _, st, _ in grids]
    return _from_masks(grids, masks, bounds, misfit, "distance")
