"""Numba kernels of the normalisation: widths s = hi − lo, and the exact rewrite of the
consequents and covariances when an input range widens (docs/ets.md, *Normalisation*)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def scales(lo: np.ndarray, hi: np.ndarray, s: np.ndarray) -> None:
    """Write the normalisation widths ``hi - lo`` into ``s`` (1 where the range is zero)."""
    for j in range(lo.shape[0]):
        w = hi[j] - lo[j]
        s[j] = w if w > 0.0 else 1.0


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
