"""Numba kernels of the per-sample eTS / eTS+ recursion: learn (predict-then-learn) and
predict, each over a whole array of samples, with the rule-base edits they share.

See ``layout.py`` for the state layout, ``docs/ets.md`` for every formula and choice, and
``reference.py`` for the plain-numpy transcription the tests compare against (1e-9).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from numba import njit
from numba.core import config as numba_config

from etsid.ets.kernel_steps import (
    add_event,
    global_gain,
    interp_pair,
    read_parameters,
    shared_rls,
)
from etsid.ets.layout import (
    COLUMN_SUMS,
    EV_BIRTH,
    EV_REMOVAL,
    EV_REPLACE,
    IP_BLEND,
    IP_SCHEDULED,
    RADIUS_FLOOR,
    SQRT8,
    TIE,
)
from etsid.ets.normalisation import reparametrise


@contextmanager
def slp_vectorised() -> Iterator[None]:
    """Compile whatever is compiled inside with LLVM's SLP vectoriser on (numba's
    ``NUMBA_SLP_VECTORIZE``, off by default), for :func:`learn_kernel`: its pair layout
    relies on it to run the two rules of a pair as two-lane vector operations. The
    vectoriser does not reorder floating-point operations, so results are unchanged.
    The setting is read when a function is compiled; a kernel loaded from numba's cache
    keeps the code it was compiled with. Both the environment variable and numba's config
    are set (numba re-reads its config from the environment when that changes)."""
    old_env = os.environ.get("NUMBA_SLP_VECTORIZE")
    old = numba_config.SLP_VECTORIZE
    os.environ["NUMBA_SLP_VECTORIZE"] = "1"
    numba_config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        if old_env is None:
            del os.environ["NUMBA_SLP_VECTORIZE"]
        else:
            os.environ["NUMBA_SLP_VECTORIZE"] = old_env
        numba_config.SLP_VECTORIZE = old


@njit(cache=True)
def _add_rule(z, P, k, pnew, si, r0, s, omega, scat0, ids, cz, rad, scat, pot, birth, support,
              lamsum, tsum, Pi, Cl, Cg, is_global) -> int:
    """Append a rule centred on z (raw units); returns its id."""
    R = si[1]
    n = r0.shape[0]
    n1 = Pi.shape[1]
    m = Pi.shape[2]
    rid = si[2]
    si[2] = rid + 1
    ids[R] = rid
    for j in range(z.shape[0]):
        cz[R, j] = z[j]
    for j in range(n):
        rad[R, j] = r0[j]
        scat[R, j] = scat0[j]
    pot[R] = P
    birth[R] = k
    support[R] = 1
    lamsum[R] = 0.0
    tsum[R] = float(k)
    for a in range(n1):
        for o in range(m):
            Pi[R, a, o] = pnew[a, o]
    if is_global:
        p_old = R * n1
        if R > 0:
            rho = (R * R + 1.0) / (R * R)
            for a in range(p_old):
                for b in range(p_old):
                    Cg[a, b] *= rho
        p_new = p_old + n1
        for a in range(p_new):
            for b in range(p_old, p_new):
                Cg[a, b] = 0.0
                Cg[b, a] = 0.0
        for a in range(p_old, p_new):
            Cg[a, a] = omega
    else:
        for a in range(n1):
            for b in range(n1):
                Cl[R, a, b] = 0.0
            Cl[R, a, a] = omega
    si[1] = R + 1
    return rid


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


@njit(cache=True, boundscheck=False)
def _refresh_scales(lo, hi, s, w2, isx, n, xo) -> None:
    """s = hi - lo (1 where zero), w2 = 1 / s^2 over z, isx = 1 / s over the consequent
    inputs (z[xo : xo + n])."""
    for j in range(lo.shape[0]):
        w = hi[j] - lo[j]
        sj = w if w > 0.0 else 1.0
        s[j] = sj
        w2[j] = 1.0 / (sj * sj)
        if xo <= j < xo + n:
            isx[j - xo] = 1.0 / sj


@njit(cache=True, boundscheck=False)
def _sync_rule(i, rad, s, ac) -> None:
    """Refresh rule i's firing coefficients ac[i, j] = 4 / (s_j r_ij)^2 (hoisted inverse
    radii squared)."""
    for j in range(ac.shape[1]):
        q = s[j] * rad[i, j]
        ac[i, j] = 4.0 / (q * q)


@njit(cache=True, boundscheck=False)
def _fire(z, cz, ac, R, ex, lam) -> None:
    """Normalised firing lambda_i of rules 0..R-1 for the antecedent inputs z[:na].

    tau_i = exp(-sum_j ac[i, j] (z_j - z*_ij)^2), normalised with the smallest exponent
    subtracted first (the reference's firing, same summation order).
    """
    na = ac.shape[1]
    for i in range(R):
        e = 0.0
        for j in range(na):
            dj = z[j] - cz[i, j]
            e += dj * dj * ac[i, j]
        ex[i] = e
    emin = np.inf
    for i in range(R):
        emin = min(emin, ex[i])
    tot = 0.0
    for i in range(R):
        v = np.exp(emin - ex[i])
        lam[i] = v
        tot += v
    itot = 1.0 / tot
    for i in range(R):
        lam[i] *= itot


@njit(cache=True, boundscheck=False)
def _rule_outputs(xe, Pi, R, yr) -> None:
    """yr[i, o] = x_e^T Pi_i[:, o] for every live rule."""
    n1 = xe.shape[0]
    m = yr.shape[1]
    for i in range(R):
        for o in range(m):
            acc = 0.0
            for a in range(n1):
                acc += xe[a] * Pi[i, a, o]
            yr[i, o] = acc


@njit(cache=True, boundscheck=False)
def _gain_by_columns(C, xe, g) -> None:
    """g = C x_e summed by columns, for a covariance C that is exactly symmetric: column b
    is row b, so every g[a] adds the row dot product's terms in its order (the same bits),
    and the inner loop runs along a contiguous row and vectorises. A call of its own (not
    inlined), made only from :data:`~etsid.ets.layout.COLUMN_SUMS` regressors on, so that
    the small rule bases' loop is compiled as before."""
    n1 = xe.shape[0]
    for a in range(n1):
        g[a] = 0.0
    for b in range(n1):
        xb = xe[b]
        for a in range(n1):
            g[a] += C[b, a] * xb


@njit(cache=True, boundscheck=False)
def _pack_pairs(Cl, Pi, W, P2, n_pairs) -> None:
    """Copy the covariances and consequents of rules 0 .. 2 n_pairs − 1 into the pair
    layout of ``learn_kernel``: ``W[p, a, b, h] = Cl[2p + h, a, b]``,
    ``P2[p, a, o, h] = Pi[2p + h, a, o]`` (the two rules of a pair side by side)."""
    for p in range(n_pairs):
        for h in range(2):
            W[p, :, :, h] = Cl[2 * p + h]
            P2[p, :, :, h] = Pi[2 * p + h]


@njit(cache=True, boundscheck=False)
def _unpack_pairs(Cl, Pi, W, P2, n_pairs) -> None:
    """The inverse of :func:`_pack_pairs`: the pairs' values back into ``Cl`` and ``Pi``."""
    for p in range(n_pairs):
        for h in range(2):
            Cl[2 * p + h] = W[p, :, :, h]
            Pi[2 * p + h] = P2[p, :, :, h]


@njit(cache=True, boundscheck=False)
def predict_kernel(X, S, Yhat, n_rules, lo, hi, cz, rad, Pi, xo, interp) -> None:
    """Batch prediction with frozen rules; NaN rows when the model has no rule.

    ``S`` holds the antecedent (scheduling) inputs, ``X`` the consequent inputs (the same
    array when the model is not scheduled); ``xo`` is the offset of x in z; ``interp``:
    the output is interpolated between rules (``blend="interpolate"``, :func:`interp_pair`)
    instead of blended by the firing.
    Same arithmetic, in the same order, as step 1 of ``learn_kernel``, so a prediction
    equals the one ``run`` would have made bit for bit.
    """
    N, n = X.shape
    na = S.shape[1]
    m = Yhat.shape[1]
    d = lo.shape[0]
    n1 = n + 1
    R = n_rules
    if R == 0:
        for t in range(N):
            for o in range(m):
                Yhat[t, o] = np.nan
        return
    s = np.empty(d)
    w2 = np.empty(d)
    isx = np.empty(n)
    _refresh_scales(lo, hi, s, w2, isx, n, xo)
    ac = np.empty((R, na))
    for i in range(R):
        _sync_rule(i, rad, s, ac)
    ex = np.empty(R)
    lam = np.empty(R)
    xe = np.empty(n1)
    yr = np.empty((R, m))
    za = np.empty(na)
    for t in range(N):
        for j in range(na):
            za[j] = S[t, j]
        _fire(za, cz, ac, R, ex, lam)
        xe[0] = 1.0
        for j in range(n):
            xe[j + 1] = (X[t, j] - lo[xo + j]) * isx[j]
        _rule_outputs(xe, Pi, R, yr)
        if interp:
            i0, i1, w = interp_pair(za[0], cz[:, 0], R)
            for o in range(m):
                Yhat[t, o] = (1.0 - w) * yr[i0, o] + w * yr[i1, o]
            continue
        for o in range(m):
            acc = 0.0
            for i in range(R):
                acc += lam[i] * yr[i, o]
            Yhat[t, o] = acc


@njit(cache=True, boundscheck=False)
def learn_kernel(X, S, Y, Yhat, hist, ev, nev, snap_k, snap_ids, snap_pi, snap_lo, snap_s, nsnap,
                 every, max_rules_here, si, lo, hi, fixed, mean, m2, ids, cz, rad, scat, pot,
                 birth, support, lamsum, tsum, Pi, Cl, Cg, sh, Cs, r0, fp, ip) -> int:
    """Online predict-then-learn over the rows of X (N, n), Y (N, m); mutates the state.
    Returns the number of rows learned: all N, or fewer when the event or snapshot buffers
    filled up (the caller empties them and calls again with the remaining rows) or a sample
    left more than ``max_rules_here`` rules (the caller goes on with
    :func:`etsid.ets.kernels_lanes.learn_lanes`, faster for larger rule bases).

    ``S`` (N, na) holds the antecedent inputs: potentials, firing and births work on
    z_a = S (scheduled, ``ip[IP_SCHEDULED] = 1``, then z = [s; y; x] and the potential
    space is s alone) or, unscheduled, on z = [x; y] with ``S`` the same array as ``X``.

    Writes the one-step predictions made *before* each update into ``Yhat`` and the
    per-sample history (rules, potential, focal max, focal min) into ``hist``. Events
    (step, kind, rule id) are appended to ``ev`` from row ``nev[0]``; the kernel stops after
    a sample once fewer than ``max_rules + 2`` rows are left (the most one sample can add).
    Every ``every`` learned samples (k a multiple of ``every``) a snapshot is appended at
    row ``nsnap[0]``: step ``snap_k``, live rule ids ``snap_ids[:, :R]`` (−1 beyond), the
    normalised consequents ``snap_pi[:, :R]`` and the consequent inputs' ``lo`` and widths
    ``s`` of that moment (``ETS.consequents_raw`` turns them into original units); the
    kernel stops when ``snap_k`` is full.

    Wind-up guard (trace-bounded, or conditional, forgetting — a standard remedy for
    estimator wind-up under poor excitation, Åström & Wittenmark, *Adaptive Control*,
    2nd ed. 1995): with f < 1, local rule i uses f_i = 1 − λ_i (1 − f) only while
    trace(C_i) <= Ω (n + 1) (the trace of a new rule's covariance), else f_i = 1; the
    global RLS forgets only while trace(C) <= Ω R (n + 1). A direction the data never
    excite therefore stops growing once the trace reaches the bound (every entry stays
    below Ω (n + 1) / f). With f = 1 the guard is skipped: the arithmetic is unchanged.

    Shared outputs (``sh[o] = 1``, local RLS only): their consequent is one linear model
    common to every rule, learnt by plain RLS (weight 1, covariance ``Cs``, the same
    forgetting and wind-up guard as a rule) and written into every rule's column, so the
    fuzzy blend returns it unchanged; births copy it (the blend of identical columns).

    Speed (docs/performance.md): one call per ``run`` (snapshots and events are written
    here, not by a Python loop per ``history_every`` samples); all work arrays are
    allocated once per call; 1/s, 1/s^2 and the firing coefficients 4/(s r)^2 are
    recomputed only when a range widens, a rule is born, moved or removed, or a spread
    adapts; every per-rule loop works on the state arrays in place (rule-major, no
    transposed copies), over the live rules only; the firing strengths and per-rule
    outputs of the prediction are reused by the update when the rule base and the ranges
    did not change; a rule with λ_i = 0 exactly keeps its consequent and covariance (in
    a pair its update has c = 0, exactly no change; the odd rule alone is skipped);
    covariance updates are written on whole rows as (C_ab − c g_a g_b) / f_i, which is
    exactly symmetric without mirroring, in one pass.
    The firing, the rule outputs, the focal potentials and the local RLS take two rules
    per pass (half the loop entries, two independent chains; each rule's arithmetic and
    every sum's order unchanged), and one pass over z copies the outputs, widens the
    ranges and runs Welford and the sample's potential sums.
    Local RLS with few regressors and no shared output (``pk``): the covariances and
    consequents of each pair live side by side in W and P2 while the rule base does not
    change (the pair's arithmetic then compiles to two-lane vector operations, with
    :func:`slp_vectorised`), and each pair's next gain C x_e is summed from the rows as
    the covariance update writes them, with the next sample's x_e computed ahead (used
    unless the pairs were unpacked in between). Both give the same bits as the plain
    loops (docs/performance.md, "Issue 44, session 9").
    """
    N, n = X.shape
    na = S.shape[1]
    m = Y.shape[1]
    d = lo.shape[0]
    n1 = n + 1
    scheduled = ip[IP_SCHEDULED] == 1
    interp = ip[IP_BLEND] == 1  # the output interpolated (learning still uses lam)
    xo = na + m if scheduled else 0  # offset of x in z
    dp = na if scheduled else na + m  # dimensions of the potential space
    (variant, is_global, rmax, min_support, prune_after, adaptive, omega, forget, umin,
     rho_s, coverage, evq) = read_parameters(ip, fp)
    omf = 1.0 - forget
    cbound = omega * n1  # wind-up guard: largest trace of a local covariance that forgets
    ev_cap = ev.shape[0] - rmax - 2
    snap_cap = snap_k.shape[0]
    next_snap = (si[0] // every + 1) * every  # the next k that is a multiple of every

    s = np.empty(d)
    w2 = np.empty(d)
    isx = np.empty(n)
    lo_old = np.empty(n)
    hi_old = np.empty(n)
    ac = np.zeros((rmax, na))
    ex = np.zeros(rmax)
    lam = np.zeros(rmax)
    yr = np.zeros((rmax, m))
    xe = np.empty(n1)
    z = np.empty(d)
    yh = np.empty(m)
    err = np.empty(m)
    err2 = np.empty(m)
    pnew = np.zeros((n1, m))
    scat0 = np.empty(na)
    g = np.empty(rmax * n1 if is_global else n1)
    g2 = np.empty(n1)
    phi = np.empty(rmax * n1 if is_global else 1)
    n_shared = 0
    for o in range(m):
        n_shared += sh[o]
    gs = np.empty(n1)
    ths = np.empty((n1, m))
    p_none = np.zeros((1, n1, 0))
    cs3 = Cs.reshape((1, n1, n1)) if n_shared > 0 else np.zeros((1, 1, 1))
    # pair layout (local RLS, no shared output, few regressors): while ``packed``, the
    # covariances and consequents of rules 0 .. 2 (R // 2) − 1 live in W and P2, the two
    # rules of a pair side by side (_pack_pairs), so that the pair's arithmetic runs as
    # two-lane vector operations; Cl and Pi hold them again (_unpack_pairs) before any
    # step that reads or changes the rule base, and when the kernel returns
    pk = not is_global and n_shared == 0 and n1 < COLUMN_SUMS
    n_pk = rmax // 2 if pk else 0
    W = np.empty((n_pk, n1, n1, 2))
    P2 = np.empty((n_pk, n1, m, 2))
    # the pairs' gains C x_e, in two buffers: GG[gi] this sample's, GG[1 - gi] the next
    # sample's, summed in the covariance update from the updated rows (g_ok: valid, as
    # long as the pairs stay packed and x_e is the one computed ahead in XN)
    GG = np.empty((2, n_pk, n1, 2))
    gi = 0
    g_ok = False
    XN = np.empty(n1)
    E2 = np.empty((m, 2))
    n_packed = -1  # pairs held in W and P2 (-1: Cl and Pi hold every rule)

    _refresh_scales(lo, hi, s, w2, isx, n, xo)
    for i in range(si[1]):
        _sync_rule(i, rad, s, ac)
    # views of z's outputs and consequent inputs, and of their ranges' lower ends: indexed
    # from 0, so no index needs numba's negative-index fix-up
    zy = z[na : na + m]
    zx = z[xo : xo + n]
    lox = lo[xo : xo + n]

    for t in range(N):
        k = si[0]
        R = si[1]
        if pk and n_packed < 0:
            n_packed = R // 2
            _pack_pairs(Cl, Pi, W, P2, n_packed)
        # the outputs zy are copied in by the pass of steps 2-4 (the prediction uses none)
        for j in range(na):
            z[j] = S[t, j]
        if scheduled:
            for j in range(n):
                zx[j] = X[t, j]
        # 1. one-step prediction before any update (lam, x_e and the rule outputs are kept).
        # _fire and _rule_outputs written out: a call costs an atomic reference-count
        # increment and decrement per array argument, more than the arithmetic here
        if R > 0:
            # exponents and their minimum, two rules per pass (as the RLS of step 7)
            emin = np.inf
            for i0 in range(0, R - 1, 2):
                i1 = i0 + 1
                e0 = 0.0
                e1 = 0.0
                for j in range(na):
                    zj = z[j]
                    d0 = zj - cz[i0, j]
                    d1 = zj - cz[i1, j]
                    e0 += d0 * d0 * ac[i0, j]
                    e1 += d1 * d1 * ac[i1, j]
                ex[i0] = e0
                ex[i1] = e1
                emin = min(emin, e0)
                emin = min(emin, e1)
            if R % 2 == 1:
                i = R - 1
                e = 0.0
                for j in range(na):
                    dj = z[j] - cz[i, j]
                    e += dj * dj * ac[i, j]
                ex[i] = e
                emin = min(emin, e)
            tot = 0.0
            for i in range(R):
                # exp(0) = 1 exactly: the nearest rule needs no call
                v = 1.0 if ex[i] == emin else np.exp(emin - ex[i])
                lam[i] = v
                tot += v
            itot = 1.0 / tot
            for i in range(R):
                lam[i] *= itot
            xe[0] = 1.0
            for j in range(n):
                xe[j + 1] = (zx[j] - lox[j]) * isx[j]
            # rule outputs, two rules per pass, each added to the blend as it comes (the
            # blend's sum over the rules keeps its order)
            for o in range(m):
                yh[o] = 0.0
            for i0 in range(0, R - 1, 2):
                i1 = i0 + 1
                l0 = lam[i0]
                l1 = lam[i1]
                for o in range(m):
                    acc0 = 0.0
                    acc1 = 0.0
                    if n_packed >= 0:
                        # both loads before the sums: the pair is one vector
                        p = i0 // 2
                        for a in range(n1):
                            xa = xe[a]
                            q0 = P2[p, a, o, 0]
                            q1 = P2[p, a, o, 1]
                            acc0 += xa * q0
                            acc1 += xa * q1
                    else:
                        for a in range(n1):
                            xa = xe[a]
                            acc0 += xa * Pi[i0, a, o]
                            acc1 += xa * Pi[i1, a, o]
                    yr[i0, o] = acc0
                    yr[i1, o] = acc1
                    yh[o] = (yh[o] + l0 * acc0) + l1 * acc1
            if R % 2 == 1:
                i = R - 1
                li = lam[i]
                for o in range(m):
                    acc = 0.0
                    for a in range(n1):
                        acc += xe[a] * Pi[i, a, o]
                    yr[i, o] = acc
                    yh[o] += li * acc
            if interp:
                i0, i1, w = interp_pair(z[0], cz[:, 0], R)
                for o in range(m):
                    Yhat[t, o] = (1.0 - w) * yr[i0, o] + w * yr[i1, o]
            else:
                for o in range(m):
                    Yhat[t, o] = yh[o]
        else:
            for o in range(m):
                Yhat[t, o] = np.nan
        # 2-4. one pass over z: the outputs copied in; 2. running ranges widened, with
        # their widths as _refresh_scales computes them (entry by entry: the same values);
        # 3. running mean / variance (Welford); 4. the sample's potential sums over the
        # first dp entries
        changed_x = False
        changed_a = False
        first = True
        k1 = k + 1
        si[0] = k1
        ik = 1.0 / k1
        vterm = 0.0
        acc = 0.0
        for j in range(d):
            if na <= j < na + m:
                zj = Y[t, j - na]
                z[j] = zj
            else:
                zj = z[j]
            if fixed[j] != 1 and (k == 0 or zj < lo[j] or zj > hi[j]):
                if first:
                    first = False
                    for q in range(n):
                        lo_old[q] = lox[q]
                        hi_old[q] = hi[xo + q]
                if k == 0:
                    lo[j] = zj
                    hi[j] = zj
                elif zj < lo[j]:
                    lo[j] = zj
                else:
                    hi[j] = zj
                w = hi[j] - lo[j]
                sj = w if w > 0.0 else 1.0
                s[j] = sj
                w2[j] = 1.0 / (sj * sj)
                if xo <= j < xo + n:
                    isx[j - xo] = 1.0 / sj
                    changed_x = k > 0 or changed_x
                if j < na:
                    changed_a = k > 0 or changed_a
            dj = zj - mean[j]
            mj = mean[j] + dj * ik
            mean[j] = mj
            m2j = m2[j] + dj * (zj - mj)
            m2[j] = m2j
            if j < dp:
                vterm += m2j * w2[j]
                dz = zj - mj
                acc += dz * dz * w2[j]
        k = k1
        # rules and consequents follow a moved range
        if changed_a:
            for i in range(R):
                _sync_rule(i, rad, s, ac)
        if changed_x and R > 0:
            if n_packed >= 0:
                _unpack_pairs(Cl, Pi, W, P2, n_packed)
                n_packed = -1
                g_ok = False
            reparametrise(lo_old, hi_old, lo[xo : xo + n], s[xo : xo + n], R, Pi, Cl, Cg,
                          is_global)
            if n_shared > 0:
                reparametrise(lo_old, hi_old, lo[xo : xo + n], s[xo : xo + n], 1, p_none,
                              cs3, Cg, False)
        # 4. potentials of the sample and of every focal point
        pmax = -np.inf
        pmin = np.inf
        if k >= 2:
            vterm *= ik
            kk = k / (k - 1.0)
            P = 1.0 / (1.0 + (acc + vterm) * kk)
            # two rules per pass (as the RLS of step 7)
            for i0 in range(0, R - 1, 2):
                i1 = i0 + 1
                e0 = vterm
                e1 = vterm
                for j in range(dp):
                    mj = mean[j]
                    wj = w2[j]
                    d0 = cz[i0, j] - mj
                    d1 = cz[i1, j] - mj
                    e0 += d0 * d0 * wj
                    e1 += d1 * d1 * wj
                p0 = 1.0 / (1.0 + e0 * kk)
                p1 = 1.0 / (1.0 + e1 * kk)
                pot[i0] = p0
                pot[i1] = p1
                pmax = max(pmax, p0)
                pmin = min(pmin, p0)
                pmax = max(pmax, p1)
                pmin = min(pmin, p1)
            if R % 2 == 1:
                i = R - 1
                e = vterm
                for j in range(dp):
                    dj = cz[i, j] - mean[j]
                    e += dj * dj * w2[j]
                pi_ = 1.0 / (1.0 + e * kk)
                pot[i] = pi_
                pmax = max(pmax, pi_)
                pmin = min(pmin, pi_)
        else:
            P = 1.0
            for i in range(R):
                pot[i] = 1.0
            pmax = pmin = 1.0 if R > 0 else 0.0
        # 5. structure
        changed = changed_x or changed_a
        born = False
        grow = False
        target = -1
        if R == 0:
            pnew[:, :] = 0.0
            grow = True
        else:
            high = pmax * (1.0 + TIE) < P
            low = variant == 1 and (pmin * (1.0 - TIE) > P or coverage)
            if evq or high or low:
                if n_packed >= 0:
                    _unpack_pairs(Cl, Pi, W, P2, n_packed)
                    n_packed = -1
                    g_ok = False
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
                    replace = False
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
                if replace:
                    for j in range(d):
                        cz[target, j] = z[j]
                    pot[target] = P
                    _sync_rule(target, rad, s, ac)
                    add_event(ev, nev, k, EV_REPLACE, ids[target])
                    changed = True
                elif grow:
                    if changed_a:
                        _fire(z, cz, ac, R, ex, lam)
                    for a in range(n1):
                        for o in range(m):
                            acc = 0.0
                            for i in range(R):
                                acc += lam[i] * Pi[i, a, o]
                            pnew[a, o] = acc
        if grow:
            for j in range(na):
                scat0[j] = (r0[j] * s[j] / SQRT8) ** 2
            rid = _add_rule(z, P, k, pnew, si, r0, s, omega, scat0, ids, cz, rad, scat, pot, birth,
                            support, lamsum, tsum, Pi, Cl, Cg, is_global)
            _sync_rule(R, rad, s, ac)
            add_event(ev, nev, k, EV_BIRTH, rid)
            changed = True
            born = True
        R = si[1]
        # 6. firing with the updated rule base; support, age, spreads, utility
        if changed:
            if n_packed >= 0:
                _unpack_pairs(Cl, Pi, W, P2, n_packed)
                n_packed = -1
                g_ok = False
            _fire(z, cz, ac, R, ex, lam)
            xe[0] = 1.0
            for j in range(n):
                xe[j + 1] = (zx[j] - lox[j]) * isx[j]
            _rule_outputs(xe, Pi, R, yr)
            for o in range(m):
                acc = 0.0
                for i in range(R):
                    acc += lam[i] * yr[i, o]
                yh[o] = acc
        if not born:
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
                    q = s[j] * rad[w, j]
                    ac[w, j] = 4.0 / (q * q)  # as _sync_rule
            if evq:
                # the winner's focal point is the mean of the samples it has won
                for j in range(d):
                    cz[w, j] += (z[j] - cz[w, j]) / support[w]
        for i in range(R):
            lamsum[i] += lam[i]
        # 7. consequents: fuzzily weighted RLS
        if is_global:
            iden = global_gain(R, n1, lam, xe, z, na, yh, err, g, phi, Cg, forget, omega)
            for i in range(R):
                for a in range(n1):
                    ga = g[i * n1 + a] * iden
                    for o in range(m):
                        Pi[i, a, o] += ga * err[o]
        else:
            if n_shared > 0:
                # shared outputs: plain RLS on the common consequent (rule 0's column)
                shared_rls(xe, z, na, sh, Pi[0], Cs, gs, ths, forget, cbound)
            # rules two at a time (one pass over both covariances: half the loop entries,
            # two independent chains), the last one alone when R is odd; each on its own
            # covariance and consequent in place. A rule with lambda = 0 gets f_i = 1 and
            # c = 0: its update is exactly no change (alone it is skipped)
            if pk and n_packed < 0:
                n_packed = R // 2
                _pack_pairs(Cl, Pi, W, P2, n_packed)
            if pk:
                # the next sample's x_e as its prediction will compute it (the ranges only
                # change through steps that unpack)
                tn = t + 1 if t + 1 < N else t
                XN[0] = 1.0
                for j in range(n):
                    xj = X[tn, j] if scheduled else S[tn, j]
                    XN[j + 1] = (xj - lox[j]) * isx[j]
            gn = 1 - gi
            for i0 in range(0, R - 1 if pk else 0, 2):
                # the pair layout: the arithmetic of the loop below, in the same order, on
                # W, P2; each pair's two loads come before its stores (vector operations)
                i1 = i0 + 1
                p = i0 // 2
                w0 = lam[i0]
                w1 = lam[i1]
                f0 = 1.0 - w0 * omf
                f1 = 1.0 - w1 * omf
                if forget != 1.0:
                    tr0 = 0.0
                    tr1 = 0.0
                    for a in range(n1):
                        tr0 += W[p, a, a, 0]
                        tr1 += W[p, a, a, 1]
                    if tr0 > cbound:
                        f0 = 1.0
                    if tr1 > cbound:
                        f1 = 1.0
                if not g_ok:
                    for a in range(n1):
                        acc0 = 0.0
                        acc1 = 0.0
                        for b in range(n1):
                            xb = xe[b]
                            q0 = W[p, a, b, 0]
                            q1 = W[p, a, b, 1]
                            acc0 += q0 * xb
                            acc1 += q1 * xb
                        GG[gi, p, a, 0] = acc0
                        GG[gi, p, a, 1] = acc1
                cw0 = 0.0
                cw1 = 0.0
                for a in range(n1):
                    xa = xe[a]
                    h0 = GG[gi, p, a, 0]
                    h1 = GG[gi, p, a, 1]
                    cw0 += xa * h0
                    cw1 += xa * h1
                c0 = w0 / (f0 + w0 * cw0)
                c1 = w1 / (f1 + w1 * cw1)
                for o in range(m):
                    yo = zy[o]
                    u0 = yr[i0, o]
                    u1 = yr[i1, o]
                    E2[o, 0] = yo - u0
                    E2[o, 1] = yo - u1
                # row a of C_i, the next sample's gain row a from it (the row dot product's
                # sum, in its order), then row a of Pi_i; a factor 1/f_i = 1 leaves the bits
                if0 = 1.0 / f0
                if1 = 1.0 / f1
                for a in range(n1):
                    ga0 = GG[gi, p, a, 0]
                    ga1 = GG[gi, p, a, 1]
                    acc0 = 0.0
                    acc1 = 0.0
                    for b in range(n1):
                        h0 = GG[gi, p, b, 0]
                        h1 = GG[gi, p, b, 1]
                        q0 = W[p, a, b, 0]
                        q1 = W[p, a, b, 1]
                        xb = XN[b]
                        v0 = (q0 - c0 * (ga0 * h0)) * if0
                        v1 = (q1 - c1 * (ga1 * h1)) * if1
                        W[p, a, b, 0] = v0
                        W[p, a, b, 1] = v1
                        acc0 += v0 * xb
                        acc1 += v1 * xb
                    GG[gn, p, a, 0] = acc0
                    GG[gn, p, a, 1] = acc1
                    gc0 = ga0 * c0
                    gc1 = ga1 * c1
                    for o in range(m):
                        e0 = E2[o, 0]
                        e1 = E2[o, 1]
                        q0 = P2[p, a, o, 0]
                        q1 = P2[p, a, o, 1]
                        P2[p, a, o, 0] = q0 + gc0 * e0
                        P2[p, a, o, 1] = q1 + gc1 * e1
            if pk:
                gi = gn
                g_ok = t + 1 < N
            for i0 in range(0, 0 if pk else R - 1, 2):
                i1 = i0 + 1
                w0 = lam[i0]
                w1 = lam[i1]
                f0 = 1.0 - w0 * omf
                f1 = 1.0 - w1 * omf
                if forget != 1.0:
                    # wind-up guard (trace-bounded forgetting): rule i forgets only while
                    # trace(C_i) <= omega (n + 1), the trace of a new rule's covariance
                    tr0 = 0.0
                    tr1 = 0.0
                    for a in range(n1):
                        tr0 += Cl[i0, a, a]
                        tr1 += Cl[i1, a, a]
                    if tr0 > cbound:
                        f0 = 1.0
                    if tr1 > cbound:
                        f1 = 1.0
                # g = C_i x_e, then x_e^T g. Few regressors: row dot products (the sum
                # stays in a register); many: by columns (_gain_by_columns, COLUMN_SUMS)
                if n1 < COLUMN_SUMS:
                    for a in range(n1):
                        acc0 = 0.0
                        acc1 = 0.0
                        for b in range(n1):
                            xb = xe[b]
                            acc0 += Cl[i0, a, b] * xb
                            acc1 += Cl[i1, a, b] * xb
                        g[a] = acc0
                        g2[a] = acc1
                else:
                    _gain_by_columns(Cl[i0], xe, g)
                    _gain_by_columns(Cl[i1], xe, g2)
                cw0 = 0.0
                cw1 = 0.0
                for a in range(n1):
                    cw0 += xe[a] * g[a]
                    cw1 += xe[a] * g2[a]
                c0 = w0 / (f0 + w0 * cw0)
                c1 = w1 / (f1 + w1 * cw1)
                for o in range(m):
                    err[o] = zy[o] - yr[i0, o]
                    err2[o] = zy[o] - yr[i1, o]
                # C_ab - c (g_a g_b) is exactly symmetric: no mirroring needed. Row a of
                # C_i, then row a of Pi_i (gain g_a c); dividing by f_i = 1 is skipped
                if f0 != 1.0 or f1 != 1.0:
                    # x * (1 / 1) = x exactly: one formula for both rules
                    if0 = 1.0 / f0
                    if1 = 1.0 / f1
                    for a in range(n1):
                        ga0 = g[a]
                        ga1 = g2[a]
                        for b in range(n1):
                            Cl[i0, a, b] = (Cl[i0, a, b] - c0 * (ga0 * g[b])) * if0
                            Cl[i1, a, b] = (Cl[i1, a, b] - c1 * (ga1 * g2[b])) * if1
                        gc0 = ga0 * c0
                        gc1 = ga1 * c1
                        for o in range(m):
                            Pi[i0, a, o] += gc0 * err[o]
                            Pi[i1, a, o] += gc1 * err2[o]
                else:
                    for a in range(n1):
                        ga0 = g[a]
                        ga1 = g2[a]
                        for b in range(n1):
                            Cl[i0, a, b] -= c0 * (ga0 * g[b])
                            Cl[i1, a, b] -= c1 * (ga1 * g2[b])
                        gc0 = ga0 * c0
                        gc1 = ga1 * c1
                        for o in range(m):
                            Pi[i0, a, o] += gc0 * err[o]
                            Pi[i1, a, o] += gc1 * err2[o]
            if R % 2 == 1 and lam[R - 1] != 0.0:
                i = R - 1
                wi = lam[i]
                fi = 1.0 - wi * omf
                if forget != 1.0:
                    tr = 0.0
                    for a in range(n1):
                        tr += Cl[i, a, a]
                    if tr > cbound:
                        fi = 1.0
                if n1 < COLUMN_SUMS:
                    for a in range(n1):
                        acc = 0.0
                        for b in range(n1):
                            acc += Cl[i, a, b] * xe[b]
                        g[a] = acc
                else:
                    _gain_by_columns(Cl[i], xe, g)
                cwi = 0.0
                for a in range(n1):
                    cwi += xe[a] * g[a]
                c = wi / (fi + wi * cwi)
                for o in range(m):
                    err[o] = zy[o] - yr[i, o]
                ifi = 1.0 / fi
                for a in range(n1):
                    ga = g[a]
                    if fi != 1.0:
                        for b in range(n1):
                            Cl[i, a, b] = (Cl[i, a, b] - c * (ga * g[b])) * ifi
                    else:
                        for b in range(n1):
                            Cl[i, a, b] -= c * (ga * g[b])
                    gc = ga * c
                    for o in range(m):
                        Pi[i, a, o] += gc * err[o]
            if n_shared > 0:
                for a in range(n1):
                    for o in range(m):
                        if sh[o] == 1:
                            for i in range(R):
                                Pi[i, a, o] = ths[a, o]
        # 8. eTS+ quality: remove rules of low utility or tiny support
        removed = False
        if variant == 1:
            i = R - 1
            while i >= 0 and R > 1:
                life = k - birth[i]
                # lamsum / (life + 1) < umin needs lamsum < umin (life + 1) (1 + 1e-12):
                # the division is made only for the rules that might fail
                if life >= prune_after and (support[i] < min_support or
                                            lamsum[i] < umin * (life + 1.0) * (1.0 + 1e-12)):
                    u = lamsum[i] / (life + 1.0)
                    if u < umin or support[i] < min_support:
                        if n_packed >= 0:
                            _unpack_pairs(Cl, Pi, W, P2, n_packed)
                            n_packed = -1
                            g_ok = False
                        add_event(ev, nev, k, EV_REMOVAL, ids[i])
                        remove_rule(i, R, ids, cz, rad, scat, pot, birth, support, lamsum, tsum,
                                    Pi, Cl, Cg, is_global)
                        R -= 1
                        si[1] = R
                        removed = True
                i -= 1
            if removed:
                for i in range(R):
                    _sync_rule(i, rad, s, ac)
        # 9. history (the focal potentials of step 4 unless the rule base changed since)
        fmax = pmax
        fmin = pmin
        if changed or removed or R == 0:
            fmax = -np.inf
            fmin = np.inf
            for i in range(R):
                fmax = max(fmax, pot[i])
                fmin = min(fmin, pot[i])
        hist[t, 0] = R
        hist[t, 1] = P
        hist[t, 2] = fmax
        hist[t, 3] = fmin
        if k == next_snap:
            if n_packed >= 0:
                _unpack_pairs(Cl, Pi, W, P2, n_packed)
                n_packed = -1
                g_ok = False
            next_snap += every
            q = nsnap[0]
            snap_k[q] = k
            for i in range(rmax):
                snap_ids[q, i] = ids[i] if i < R else -1
            for i in range(R):
                for a in range(n1):
                    for o in range(m):
                        snap_pi[q, i, a, o] = Pi[i, a, o]
            for j in range(n):
                snap_lo[q, j] = lo[xo + j]
                snap_s[q, j] = s[xo + j]
            nsnap[0] = q + 1
            if q + 1 >= snap_cap:
                return t + 1
        if nev[0] > ev_cap or max_rules_here < R:
            if n_packed >= 0:
                _unpack_pairs(Cl, Pi, W, P2, n_packed)
            return t + 1
    if n_packed >= 0:
        _unpack_pairs(Cl, Pi, W, P2, n_packed)
    return N


@njit(cache=True, boundscheck=False)
def predict_setup(lo, hi, rad, n_rules, n, xo):
    """The frozen model's inverse input widths 1/s (n,) and firing coefficients (R, na), as
    ``predict_kernel`` computes them (for :func:`predict_row`)."""
    d = lo.shape[0]
    s = np.empty(d)
    w2 = np.empty(d)
    isx = np.empty(n)
    _refresh_scales(lo, hi, s, w2, isx, n, xo)
    ac = np.empty((n_rules, rad.shape[1]))
    for i in range(n_rules):
        _sync_rule(i, rad, s, ac)
    return isx, ac


@njit(cache=True, boundscheck=False)
def predict_row(x, sv, out, frozen, work) -> bool:
    """One prediction of the frozen model (at least one rule) for consequent inputs ``x``
    (n,) and antecedent inputs ``sv`` (na,): the arithmetic of ``predict_kernel`` for one row,
    in the same order (bit-identical). ``frozen`` packs, flat, the consequent inputs' ``lo``
    (n), ``1/s`` (n), then per rule its focal point on the antecedents (na), firing
    coefficients (na) and consequents (n + 1, m) (``ETS`` builds it once per rule base, from
    :func:`predict_setup`); ``work`` holds 2 R + n + 1 values. Firing coefficients below 0
    (``ETS.frozen_predictor`` negates them for ``blend="interpolate"``) mean the output is
    interpolated (:func:`interp_pair`) on the one antecedent input. Few arguments on purpose:
    the call is made once per free-run step and numba checks every argument's type. Returns
    False, without predicting, when an input is not finite."""
    n = x.shape[0]
    for j in range(n):
        if not np.isfinite(x[j]):
            return False
    for j in range(sv.shape[0]):
        if not np.isfinite(sv[j]):
            return False
    na = sv.shape[0]
    m = out.shape[0]
    n1 = n + 1
    stride = 2 * na + n1 * m
    R = (frozen.shape[0] - 2 * n) // stride
    ex = work[:R]
    lam = work[R : 2 * R]
    xe = work[2 * R :]
    if na > 0 and frozen[2 * n + na] < 0.0:
        return _interpolated_row(x, sv[0], out, frozen, xe, ex, R, stride)
    emin = np.inf
    for i in range(R):
        b = 2 * n + i * stride
        e = 0.0
        for j in range(na):
            dj = sv[j] - frozen[b + j]
            e += dj * dj * frozen[b + na + j]
        ex[i] = e
        emin = min(emin, e)
    tot = 0.0
    for i in range(R):
        v = np.exp(emin - ex[i])
        lam[i] = v
        tot += v
    itot = 1.0 / tot
    for i in range(R):
        lam[i] *= itot
    xe[0] = 1.0
    for j in range(n):
        xe[j + 1] = (x[j] - frozen[j]) * frozen[n + j]
    for o in range(m):
        acc = 0.0
        for i in range(R):
            b = 2 * n + i * stride + 2 * na
            yr = 0.0
            for a in range(n1):
                yr += xe[a] * frozen[b + a * m + o]
            acc += lam[i] * yr
        out[o] = acc
    return True


@njit(cache=True, boundscheck=False)
def _interpolated_row(x, s0, out, frozen, xe, f, R, stride) -> bool:
    """:func:`predict_row` of a model with ``blend="interpolate"`` (one antecedent input):
    the rule outputs as ``predict_kernel`` computes them, then :func:`interp_pair`; ``f``
    (≥ R values) is scratch for the focal values."""
    n = x.shape[0]
    m = out.shape[0]
    n1 = n + 1
    for i in range(R):
        f[i] = frozen[2 * n + i * stride]
    i0, i1, w = interp_pair(s0, f, R)
    xe[0] = 1.0
    for j in range(n):
        xe[j + 1] = (x[j] - frozen[j]) * frozen[n + j]
    b0 = 2 * n + i0 * stride + 2
    b1 = 2 * n + i1 * stride + 2
    for o in range(m):
        y0 = 0.0
        y1 = 0.0
        for a in range(n1):
            y0 += xe[a] * frozen[b0 + a * m + o]
            y1 += xe[a] * frozen[b1 + a * m + o]
        out[o] = (1.0 - w) * y0 + w * y1
    return True
