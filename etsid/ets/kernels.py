"""Numba kernels of the eTS recursion: one call processes a whole array of samples.

Every formula here is stated, with its source, in ``docs/ets.md``; ``reference.py`` holds
a plain-numpy transcription of the same recursion that the tests compare against (1e-9).

State layout (all preallocated for ``max_rules`` rules, rules ``0 .. R-1`` are live and
kept in birth order; removing a rule shifts the later ones down):

``si``      int64[3]: samples learned ``k``, live rules ``R``, next rule id
``lo, hi``  float64[d]: normalisation range of z = [x; y] (raw units), ``d = n + m``
``fixed``   int8[d]: 1 where the range was given by the caller and is never widened
``mean, m2`` float64[d]: Welford running mean and sum of squared deviations of z (raw units)
``ids``     int64[Rmax]: stable rule ids (never reused)
``cz``      float64[Rmax, d]: focal points z*_i in raw units
``rad``     float64[Rmax, n]: per-rule, per-input radius in normalised units
``scat``    float64[Rmax, n]: local scatter (variance, raw units squared) for exTS spreads
``pot``     float64[Rmax]: focal potentials P_k(z*_i)
``birth``   int64[Rmax]: step t*_i at which the rule was born
``support`` int64[Rmax]: samples for which the rule fired strongest (including its birth)
``lamsum``  float64[Rmax]: sum of normalised firing since birth (utility numerator)
``tsum``    float64[Rmax]: sum of the time indices of the supporting samples (age)
``Pi``      float64[Rmax, n+1, m]: consequents on x_e = [1, (x - lo) / s]
``Cl``      float64[Rmax, n+1, n+1]: local RLS covariances (unused shape for global RLS)
``Cg``      float64[Rmax(n+1), Rmax(n+1)]: global RLS covariance (unused shape for local)
"""

from __future__ import annotations

import numpy as np
from numba import njit

# integer parameters ``ip``
IP_VARIANT = 0  # 0: eTS (2004), 1: eTS+ (2010)
IP_GLOBAL = 1  # 0: local RLS, 1: global RLS
IP_MAX_RULES = 2
IP_MIN_SUPPORT = 3
IP_PRUNE_AFTER = 4
IP_ADAPTIVE = 5
IP_COVERAGE = 6  # eTS+: also grow wherever no rule covers the sample
N_IP = 7
# float parameters ``fp``
FP_OMEGA = 0
FP_FORGET = 1
FP_UTILITY = 2
FP_SPREAD_RHO = 3
N_FP = 4
# event kinds
EV_BIRTH = 0
EV_REPLACE = 1
EV_REMOVAL = 2
EVENT_KINDS = ("birth", "replace", "removal")
#: history columns written per learned sample
HIST_COLUMNS = ("n_rules", "potential", "focal_max", "focal_min")
#: exTS Gaussian exp(-d^2 / (2 sigma^2)) equals exp(-4 d^2 / r^2) when r = sqrt(8) sigma
SQRT8 = np.sqrt(8.0)
#: relative margin for potential comparisons: equal potentials (e.g. the two samples at
#: k = 2) must compare equal whatever the rounding
TIE = 1e-10
#: adaptive radii never shrink below this fraction of the initial radius
RADIUS_FLOOR = 0.01


@njit(cache=True)
def scales(lo: np.ndarray, hi: np.ndarray, s: np.ndarray) -> None:
    """Write the normalisation widths ``hi - lo`` into ``s`` (1 where the range is zero)."""
    for j in range(lo.shape[0]):
        w = hi[j] - lo[j]
        s[j] = w if w > 0.0 else 1.0


@njit(cache=True)
def firing(x, cz, rad, s, n_rules, lam) -> int:
    """Normalised firing strengths lambda_i of rules ``0..n_rules-1``; returns the winner.

    tau_i = exp(-4 sum_j ((x_j - x*_ij) / (s_j r_ij))^2); lambda_i = tau_i / sum_l tau_l,
    evaluated with the largest exponent subtracted so a far point never gives 0/0.
    """
    n = x.shape[0]
    emax = -np.inf
    imax = 0
    for i in range(n_rules):
        e = 0.0
        for j in range(n):
            dj = (x[j] - cz[i, j]) / (s[j] * rad[i, j])
            e += dj * dj
        e *= -4.0
        lam[i] = e
        if e > emax:
            emax = e
            imax = i
    tot = 0.0
    for i in range(n_rules):
        t = np.exp(lam[i] - emax)
        lam[i] = t
        tot += t
    for i in range(n_rules):
        lam[i] /= tot
    return imax


@njit(cache=True)
def regressor(x, lo, s, xe) -> None:
    """x_e = [1, (x - lo) / s]."""
    xe[0] = 1.0
    for j in range(x.shape[0]):
        xe[j + 1] = (x[j] - lo[j]) / s[j]


@njit(cache=True)
def output(xe, lam, Pi, n_rules, out) -> None:
    """y_hat = sum_i lambda_i x_e^T Pi_i."""
    n1 = xe.shape[0]
    m = out.shape[0]
    for o in range(m):
        out[o] = 0.0
    for i in range(n_rules):
        li = lam[i]
        for o in range(m):
            acc = 0.0
            for a in range(n1):
                acc += xe[a] * Pi[i, a, o]
            out[o] += li * acc


@njit(cache=True)
def potential(z, mean, m2, s, k) -> float:
    """P_k(z) = 1 / (1 + (1/(k-1)) sum_{l<=k} ||z - z_l||^2) in normalised units.

    The sum is expanded with the running mean and variance of z_1..z_k:
    sum_l ||z - z_l||^2 = k sum_j ((z_j - mean_j)^2 + var_j) / s_j^2.
    """
    if k < 2:
        return 1.0
    acc = 0.0
    for j in range(z.shape[0]):
        dj = z[j] - mean[j]
        acc += (dj * dj + m2[j] / k) / (s[j] * s[j])
    return 1.0 / (1.0 + acc * k / (k - 1.0))


@njit(cache=True)
def _congruence(C, T, tmp, symmetrise) -> None:
    """C <- T^T C T in place (symmetrised if ``symmetrise``, i.e. for a diagonal block)."""
    n1 = T.shape[0]
    for p in range(n1):
        for q in range(n1):
            acc = 0.0
            for r in range(n1):
                acc += C[p, r] * T[r, q]
            tmp[p, q] = acc
    for p in range(n1):
        for q in range(n1):
            acc = 0.0
            for r in range(n1):
                acc += T[r, p] * tmp[r, q]
            C[p, q] = acc
    if not symmetrise:
        return
    for p in range(n1):
        for q in range(p + 1, n1):
            v = 0.5 * (C[p, q] + C[q, p])
            C[p, q] = v
            C[q, p] = v


@njit(cache=True)
def reparametrise(lo_old, hi_old, lo, s, n_rules, Pi, Cl, Cg, is_global) -> None:
    """Rewrite consequents and covariances after the input range changed.

    Old coordinates x~ = (x - lo) / s_old equal b + a * x~' in the new ones, with
    a = s_new / s_old and b = (lo_new - lo_old) / s_old, i.e. x_e = T x_e'. Then
    Pi' = T^T Pi and C' = T^T C T give identical predictions and identical future RLS
    steps. A dimension whose old range was zero only ever saw x~ = 0, so s_old := s_new.
    """
    n = lo_old.shape[0]
    n1 = n + 1
    T = np.zeros((n1, n1))
    tmp = np.empty((n1, n1))
    T[0, 0] = 1.0
    for j in range(n):
        w_old = hi_old[j] - lo_old[j]
        so = w_old if w_old > 0.0 else s[j]
        T[j + 1, 0] = (lo[j] - lo_old[j]) / so
        T[j + 1, j + 1] = s[j] / so
    m = Pi.shape[2]
    for i in range(n_rules):
        for o in range(m):
            acc = Pi[i, 0, o]
            for j in range(n):
                acc += T[j + 1, 0] * Pi[i, j + 1, o]
            Pi[i, 0, o] = acc
            for j in range(n):
                Pi[i, j + 1, o] *= T[j + 1, j + 1]
    if is_global:
        blk = np.empty((n1, n1))
        for bi in range(n_rules):
            for bj in range(n_rules):
                for p in range(n1):
                    for q in range(n1):
                        blk[p, q] = Cg[bi * n1 + p, bj * n1 + q]
                _congruence(blk, T, tmp, False)
                for p in range(n1):
                    for q in range(n1):
                        Cg[bi * n1 + p, bj * n1 + q] = blk[p, q]
        # exact symmetry across off-diagonal blocks
        p_all = n_rules * n1
        for p in range(p_all):
            for q in range(p + 1, p_all):
                v = 0.5 * (Cg[p, q] + Cg[q, p])
                Cg[p, q] = v
                Cg[q, p] = v
    else:
        for i in range(n_rules):
            _congruence(Cl[i], T, tmp, True)


@njit(cache=True)
def remove_rule(
    i, n_rules, ids, cz, rad, scat, pot, birth, support, lamsum, tsum, Pi, Cl, Cg, is_global
):
    """Delete live rule ``i`` and shift the later rules down (birth order is kept)."""
    for r in range(i, n_rules - 1):
        ids[r] = ids[r + 1]
        cz[r] = cz[r + 1]
        rad[r] = rad[r + 1]
        scat[r] = scat[r + 1]
        pot[r] = pot[r + 1]
        birth[r] = birth[r + 1]
        support[r] = support[r + 1]
        lamsum[r] = lamsum[r + 1]
        tsum[r] = tsum[r + 1]
        Pi[r] = Pi[r + 1]
        if not is_global:
            Cl[r] = Cl[r + 1]
    if is_global:
        n1 = Pi.shape[1]
        p_new = (n_rules - 1) * n1
        cut = i * n1
        for a in range(p_new):
            ao = a if a < cut else a + n1
            for b in range(p_new):
                bo = b if b < cut else b + n1
                Cg[a, b] = Cg[ao, bo]
