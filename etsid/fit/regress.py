"""Robust linear least squares with standard errors corrected for autocorrelation.

Flight-log residuals are coloured (filtered signals, slow disturbances), so the textbook
OLS standard error is too small by the square root of the autocorrelation time. Here the
covariance is the Newey–West (Bartlett-kernel HAC) sandwich, with its bandwidth taken
from the residuals' own autocorrelation, and the fit is a Huber IRLS (a few outliers —
touch-downs, glitches — do not move it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft

HUBER_K = 1.345
"""Huber's tuning constant: 95 % efficiency under Gaussian noise."""


@dataclass(frozen=True)
class LinearFit:
    """Result of :func:`robust_lstsq`."""

    coef: np.ndarray      # (p,) coefficients
    se: np.ndarray        # (p,) HAC standard errors
    cov: np.ndarray       # (p, p) HAC covariance
    resid: np.ndarray     # (n,) residuals
    ssr: float            # sum of squared residuals
    n: int                # samples
    n_eff: float          # effective sample size of the residuals
    r2: float             # explained share of the target's variance


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Autocorrelation ρ(0 … max_lag) of a series (mean removed, biased estimator)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    var = float(np.dot(x, x))
    if var <= 0:
        return np.zeros(max_lag + 1)
    size = next_fast_len(2 * n, real=True)
    f = rfft(x, size)
    return irfft(f.real ** 2 + f.imag ** 2, size)[: max_lag + 1] / var


def integrated_time(acf: np.ndarray) -> float:
    """τ_int = 1 + 2 Σ ρ_k (1 − k/(m+1)) over the initial run of lags with ρ_k ≥ 0.05
    (Geyer-style cut), m + 1 the length of ``acf``."""
    m = len(acf) - 1
    low = np.nonzero(acf[1:] < 0.05)[0]
    stop = int(low[0]) if low.size else m
    k = np.arange(1, stop + 1)
    return max(1.0 + 2.0 * float(np.sum(acf[1:stop + 1] * (1.0 - k / (m + 1)))), 1.0)


def correlation_time(resid: np.ndarray, max_lag: int = 2000) -> float:
    """Integrated autocorrelation time τ_int = 1 + 2 Σ ρ_k of ``resid`` (samples), summed
    over the initial run of lags whose correlation stays above 0.05 (Geyer-style cut)."""
    n = np.asarray(resid).size
    if n < 4 or float(np.var(resid)) <= 0:
        return 1.0
    return integrated_time(autocorrelation(resid, min(max_lag, n // 4)))


def effective_n(resid: np.ndarray) -> float:
    """Effective number of independent samples, n / τ_int."""
    return float(np.asarray(resid).size / correlation_time(resid))


def hac_cov(x: np.ndarray, resid: np.ndarray, weights: np.ndarray | None = None,
            slope: np.ndarray | None = None) -> np.ndarray:
    """Newey–West covariance of least-squares coefficients, bandwidth 3 τ_int samples
    (τ_int of the scores x_j r).

    Parameters
    ----------
    x : ndarray (n, p)
        Regressors.
    resid : ndarray (n,)
        Residuals of the fit.
    weights : ndarray (n,), optional
        IRLS weights of the fit, ψ(r)/r (the scores are x ψ(r)).
    slope : ndarray (n,), optional
        ψ'(r) of the M-estimator (1 inside Huber's corner, 0 outside): the bread.
    """
    w = np.ones(len(resid)) if weights is None else weights
    d = w if slope is None else slope
    bread = np.linalg.pinv((x * d[:, None]).T @ x)
    u = x * (w * resid)[:, None]
    # bandwidth from the scores' own correlation time (a product of two coloured series
    # is correlated longer than either), three times it for the Bartlett kernel's bias
    lag = max(1, int(np.ceil(3.0 * max(correlation_time(u[:, j]) for j in range(u.shape[1])
                                       if np.any(u[:, j])))))
    lag = min(lag, len(resid) // 4 or 1)
    meat = u.T @ u
    for k in range(1, lag + 1):
        g = u[k:].T @ u[:-k]
        meat += (1.0 - k / (lag + 1)) * (g + g.T)
    return bread @ meat @ bread


def robust_lstsq(x: np.ndarray, y: np.ndarray, *, iterations: int = 5) -> LinearFit:
    """Huber IRLS fit of ``y ≈ x @ coef`` with HAC standard errors.

    Rows with a non-finite value are left out (the caller counts them).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(y) & np.all(np.isfinite(x), axis=1)
    x, y = x[ok], y[ok]
    if len(y) <= x.shape[1]:
        raise ValueError(f"{len(y)} samples for {x.shape[1]} coefficients")
    w = np.ones(len(y))
    slope = np.ones(len(y))
    coef = np.linalg.lstsq(x, y, rcond=None)[0]
    for _ in range(iterations):
        r = y - x @ coef
        scale = 1.4826 * np.median(np.abs(r - np.median(r))) or float(np.std(r)) or 1.0
        a = np.abs(r) / (HUBER_K * scale)
        w = np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1e-12))
        slope = (a <= 1.0).astype(float)
        sw = np.sqrt(w)
        coef = np.linalg.lstsq(x * sw[:, None], y * sw, rcond=None)[0]
    r = y - x @ coef
    cov = hac_cov(x, r, w, slope)
    ssr = float(np.dot(r, r))
    var_y = float(np.var(y)) * len(y)
    return LinearFit(coef=coef, se=np.sqrt(np.maximum(np.diag(cov), 0.0)), cov=cov, resid=r,
                     ssr=ssr, n=len(y), n_eff=effective_n(r),
                     r2=1.0 - ssr / var_y if var_y > 0 else 0.0)


N_BLOCKS = 10
"""Contiguous blocks of the delete-one-block jackknife (blocks of several seconds, far
longer than the residuals' correlation time, so the blocks are nearly independent)."""


def instrument_basis(z: np.ndarray) -> np.ndarray:
    """Orthonormal basis (n, r) of the instrument columns ``z`` (standardised; columns
    without variance or linearly dependent ones are dropped by the rank-revealing QR)."""
    z = np.asarray(z, dtype=float)
    sd = z.std(axis=0)
    keep = sd > 1e-12
    zs = (z[:, keep] - z[:, keep].mean(axis=0)) / sd[keep]
    zs = np.column_stack([np.ones(len(z)), zs])
    q, r = np.linalg.qr(zs)
    d = np.abs(np.diag(r))
    return q[:, d > 1e-8 * d.max()]


@dataclass
class Moments:
    """Per-block cross products of a (projected) regression: enough to refit with any
    block left out."""

    xtx: np.ndarray   # (B, p, p)
    xty: np.ndarray   # (B, p)
    yty: np.ndarray   # (B,)

    @classmethod
    def of(cls, x: np.ndarray, y: np.ndarray, block: np.ndarray, n_blocks: int) -> Moments:
        p = x.shape[1]
        xtx = np.zeros((n_blocks, p, p))
        xty = np.zeros((n_blocks, p))
        yty = np.zeros(n_blocks)
        edges = np.searchsorted(block, np.arange(n_blocks + 1))  # blocks are contiguous
        for b in range(n_blocks):
            xb, yb = x[edges[b]:edges[b + 1]], y[edges[b]:edges[b + 1]]
            if not len(yb):
                continue
            xtx[b] = xb.T @ xb
            xty[b] = xb.T @ yb
            yty[b] = yb @ yb
        return cls(xtx, xty, yty)

    def __add__(self, other: Moments) -> Moments:
        return Moments(self.xtx + other.xtx, self.xty + other.xty, self.yty + other.yty)

    def solve(self, leave_out: int | None = None) -> tuple[np.ndarray, float]:
        """(coefficients, SSR) with all blocks or one left out."""
        keep = np.ones(len(self.yty), dtype=bool)
        if leave_out is not None:
            keep[leave_out] = False
        a = self.xtx[keep].sum(0)
        c = self.xty[keep].sum(0)
        try:
            beta = np.linalg.solve(a, c)
        except np.linalg.LinAlgError:
            beta = np.linalg.lstsq(a, c, rcond=None)[0]
        ssr = float(self.yty[keep].sum() - 2 * beta @ c + beta @ a @ beta)
        return beta, max(ssr, 1e-300)

    def jackknife(self) -> tuple[np.ndarray, np.ndarray]:
        """(coefficients on all blocks, delete-one-block jackknife standard errors)."""
        full, _ = self.solve()
        b = len(self.yty)
        reps = np.array([self.solve(i)[0] for i in range(b) if self.yty[i] > 0])
        nb = len(reps)
        se = np.sqrt((nb - 1) / nb * np.sum((reps - reps.mean(0)) ** 2, axis=0))
        return full, se


def block_ids(n: int, n_blocks: int = N_BLOCKS) -> np.ndarray:
    """Block number 0..n_blocks−1 of each of n consecutive samples."""
    return np.minimum((np.arange(n) * n_blocks) // max(n, 1), n_blocks - 1)


def jackknife_se(estimates: np.ndarray) -> float:
    """Jackknife standard error of delete-one-block re-estimates."""
    e = np.asarray(estimates, dtype=float)
    nb = len(e)
    return float(np.sqrt((nb - 1) / nb * np.sum((e - e.mean()) ** 2)))
