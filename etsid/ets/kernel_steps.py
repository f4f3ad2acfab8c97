"""Steps of the per-sample eTS recursion that both learning kernels run the same way:
:func:`etsid.ets.kernels.learn_kernel` (rule-major) and
:func:`etsid.ets.kernels_lanes.learn_lanes` (rule-minor lanes).

Each helper is inlined into the kernels by numba (``inline="always"``, at the level of
numba's own code, before LLVM), so a step costs no call and no reference counting of its
array arguments, and its arithmetic is the one written here in this order: the two kernels
stay bit-identical to each other and to what they computed before the steps were shared
(``python benchmarks/ets.py --compare``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from etsid.ets.layout import (
    FP_FORGET,
    FP_OMEGA,
    FP_SPREAD_RHO,
    FP_UTILITY,
    IP_ADAPTIVE,
    IP_CLUSTERING,
    IP_COVERAGE,
    IP_GLOBAL,
    IP_MAX_RULES,
    IP_MIN_SUPPORT,
    IP_PRUNE_AFTER,
    IP_VARIANT,
    RADIUS_FLOOR,
    SQRT8,
    TIE,
)


@njit(inline="always")
def read_parameters(ip, fp):
    """The model's parameters from its integer and float parameter arrays (``layout.py``):
    (variant, global RLS, max rules, min support, prune after, adaptive spreads, Ω,
    forgetting factor, utility threshold, spread ρ, coverage test, evq clustering)."""
    return (ip[IP_VARIANT], ip[IP_GLOBAL] == 1, ip[IP_MAX_RULES], ip[IP_MIN_SUPPORT],
            ip[IP_PRUNE_AFTER], ip[IP_ADAPTIVE] == 1, fp[FP_OMEGA], fp[FP_FORGET],
            fp[FP_UTILITY], fp[FP_SPREAD_RHO], ip[IP_COVERAGE] == 1, ip[IP_CLUSTERING] == 1)


@njit(inline="always")
def add_event(ev, nev, k, kind, rid) -> None:
    """Append the event (step ``k``, ``kind``, rule id ``rid``) at row ``nev[0]``."""
    q = nev[0]
    ev[q, 0] = k
    ev[q, 1] = kind
    ev[q, 2] = rid
    nev[0] = q + 1


@njit(inline="always")
def normalise_firing(ex, lam, R) -> None:
    """lam_i = exp(emin − ex_i) / Σ exp(emin − ex_j) over rules 0..R-1 (the smallest
    exponent subtracted first); exp(0) = 1 exactly, so the nearest rule needs no call."""
    emin = np.inf
    for i in range(R):
        emin = min(emin, ex[i])
    tot = 0.0
    for i in range(R):
        v = 1.0 if ex[i] == emin else np.exp(emin - ex[i])
        lam[i] = v
        tot += v
    itot = 1.0 / tot
    for i in range(R):
        lam[i] *= itot


@njit(inline="always")
def widen_ranges(z, k, fixed, lo, hi, lo_old, hi_old, n, na, xo):
    """Widen the running ranges ``lo``/``hi`` of z to the sample (the first sample sets
    them); before the first change the consequent inputs' old ranges are kept in
    ``lo_old``/``hi_old``. Returns (changed_x, changed_a, changed_any): an input range of
    the consequents moved, an antecedent range moved (both only after the first sample),
    any range moved."""
    changed_x = False
    changed_a = False
    changed_y = False
    for j in range(lo.shape[0]):
        if fixed[j] == 1:
            continue
        v = z[j]
        if k == 0 or v < lo[j] or v > hi[j]:
            if not changed_x and not changed_y:
                for q in range(n):
                    lo_old[q] = lo[xo + q]
                    hi_old[q] = hi[xo + q]
            if k == 0:
                lo[j] = v
                hi[j] = v
            elif v < lo[j]:
                lo[j] = v
            else:
                hi[j] = v
            if xo <= j < xo + n:
                changed_x = k > 0 or changed_x
            if j < na:
                changed_a = k > 0 or changed_a
            changed_y = True
    return changed_x, changed_a, changed_y


@njit(inline="always")
def welford(z, mean, m2, ik) -> None:
    """Running mean and sum of squared deviations of z after its k-th sample (ik = 1/k)."""
    for j in range(mean.shape[0]):
        dj = z[j] - mean[j]
        mean[j] += dj * ik
        m2[j] += dj * (z[j] - mean[j])


@njit(inline="always")
def sample_potential(z, mean, m2, w2, dp, ik, k):
    """The exact recursive potential of the sample over the first ``dp`` dimensions
    (k ≥ 2). Returns (P, vterm, kk): the potential, the variance term Σ m2_j w2_j / k and
    k / (k − 1), which the focal points' potentials reuse."""
    vterm = 0.0
    acc = 0.0
    for j in range(dp):
        vterm += m2[j] * w2[j]
        dj = z[j] - mean[j]
        acc += dj * dj * w2[j]
    vterm *= ik
    kk = k / (k - 1.0)
    return 1.0 / (1.0 + (acc + vterm) * kk), vterm, kk


@njit(inline="always")
def structure_decision(z, cz, s, rad, R, na, P, pmax, pmin, variant, coverage, evq, rmax):
    """Step 5 of the recursion for a non-empty rule base: whether the sample replaces
    (moves) a rule's focal point, which one, or grows a new rule (docs/ets.md).

    Returns
    -------
    (replace, target, grow) : (bool, int, bool)
        Neither when the sample's potential calls for no change.
    """
    replace = False
    grow = False
    target = -1
    high = pmax * (1.0 + TIE) < P
    low = variant == 1 and (pmin * (1.0 - TIE) > P or coverage)
    if evq or high or low:
        dmin = np.inf
        inear = 0
        dcov = np.inf
        icov = -1
        for i in range(R):
            d2 = 0.0
            dinf = 0.0
            for j in range(na):
                q = abs(z[j] - cz[i, j]) / (s[j] * rad[i, j])
                d2 += q * q
                dinf = max(dinf, q)
            if d2 < dmin:
                dmin = d2
                inear = i
            if dinf < 0.5 and d2 < dcov:
                dcov = d2
                icov = i
        if evq:
            # evolving vector quantisation: grow where nothing covers the sample
            target = inear
            grow = icov < 0
        elif variant == 0:
            replace = P / pmax - np.sqrt(dmin) >= 1.0
            target = inear
            grow = not replace
        else:
            replace = high and icov >= 0
            target = icov
            grow = icov < 0
        if grow and rmax <= R:
            # at the cap a birth becomes a move of the nearest rule (keeps its consequent)
            replace = True
            target = inear
            grow = False
    return replace, target, grow


@njit(inline="always")
def global_gain(R, n1, lam, xe, z, na, yh, err, g, phi, Cg, forget, omega):
    """Global RLS (one covariance over every rule's consequents): the regressor
    phi = [λ_i x_e], the errors of the blended prediction, g = Cg phi, and Cg updated in
    place (trace-bounded forgetting, docs/ets.md). Returns 1 / (f + phiᵀ g); each kernel
    applies g · that · err to its own consequent layout."""
    p = R * n1
    for i in range(R):
        for a in range(n1):
            phi[i * n1 + a] = lam[i] * xe[a]
    for o in range(err.shape[0]):
        err[o] = z[na + o] - yh[o]
    # g = Cg phi as a sum of columns; Cg is exactly symmetric, so column b equals
    # row b and every g[a] is summed in the same order as the row dot product
    for a in range(p):
        g[a] = 0.0
    for b in range(p):
        pb = phi[b]
        for a in range(p):
            g[a] += Cg[b, a] * pb
    # wind-up guard (trace-bounded forgetting): forget only while trace(C) <= omega p
    fg = forget
    if forget != 1.0:
        tr = 0.0
        for a in range(p):
            tr += Cg[a, a]
        if tr > omega * p:
            fg = 1.0
    den = fg
    for a in range(p):
        den += phi[a] * g[a]
    iden = 1.0 / den
    # C_ab - (g_a g_b) / den is exactly symmetric: no mirroring needed
    if fg == 1.0:
        for a in range(p):
            ga = g[a]
            for b in range(p):
                Cg[a, b] -= (ga * g[b]) * iden
    else:
        ifg = 1.0 / fg
        for a in range(p):
            ga = g[a]
            for b in range(p):
                Cg[a, b] = (Cg[a, b] - (ga * g[b]) * iden) * ifg
    return iden


@njit(inline="always")
def shared_rls(xe, z, na, sh, p0, Cs, gs, ths, forget, cbound) -> None:
    """Plain RLS of the shared outputs' common consequent ``p0`` (n + 1, m), one rule's
    column (read only here): the new consequent into ``ths`` (columns with ``sh[o] = 1``),
    ``Cs`` updated in place with the rules' forgetting and wind-up guard."""
    n1 = xe.shape[0]
    for a in range(n1):
        acc = 0.0
        for b in range(n1):
            acc += Cs[a, b] * xe[b]
        gs[a] = acc
    fs = forget
    if forget != 1.0:
        tr = 0.0
        for a in range(n1):
            tr += Cs[a, a]
        if tr > cbound:
            fs = 1.0
    den = fs
    for a in range(n1):
        den += xe[a] * gs[a]
    iden = 1.0 / den
    for o in range(sh.shape[0]):
        if sh[o] == 1:
            eo = z[na + o]
            for a in range(n1):
                eo -= xe[a] * p0[a, o]
            for a in range(n1):
                ths[a, o] = p0[a, o] + gs[a] * iden * eo
    ifs = 1.0 / fs
    for a in range(n1):
        ga = gs[a]
        for b in range(n1):
            Cs[a, b] = (Cs[a, b] - (ga * gs[b]) * iden) * ifs


@njit(inline="always")
def reward_winner(z, lam, R, k, support, tsum, scat, rad, cz, s, r0, rho_s, na, adaptive,
                  evq):
    """Credit the sample to the rule that fires most (the first of equals): support and
    summed age; with ``adaptive`` its scatter and spreads (radius floor RADIUS_FLOOR r0);
    with ``evq`` its focal point moves to the mean of the samples it won. Returns the
    winner; the caller refreshes its firing coefficients (and its copy of the focal
    point)."""
    w = 0
    for i in range(1, R):
        if lam[i] > lam[w]:
            w = i
    support[w] += 1
    tsum[w] += k
    if adaptive:
        for j in range(na):
            dx = z[j] - cz[w, j]
            scat[w, j] += (dx * dx - scat[w, j]) / support[w]
            rj = rho_s * rad[w, j] + (1.0 - rho_s) * SQRT8 * np.sqrt(scat[w, j]) / s[j]
            rad[w, j] = max(rj, RADIUS_FLOOR * r0[j])
    if evq:
        # the winner's focal point is the mean of the samples it has won
        for j in range(cz.shape[1]):
            cz[w, j] += (z[j] - cz[w, j]) / support[w]
    return w
