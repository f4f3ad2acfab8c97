"""The learning kernel for larger rule bases ("lanes"): the per-rule loops run over
rule-minor work copies of the focal points, firing coefficients, consequents and local
covariances (rule index last, lanes padded to a multiple of 4), which LLVM vectorises
across rules.

:func:`etsid.ets.kernels.learn_kernel` (rule-major, in place) is faster for a few rules;
this one from about six on (docs/performance.md). Both do the same arithmetic in the same
order, so they give bit-identical results and :class:`~etsid.ets.ETS` switches between
them as the rule count moves (returning from one and calling the other, with hysteresis).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from etsid.ets.kernel_steps import add_event, global_gain, read_parameters, shared_rls
from etsid.ets.kernels import _add_rule, _refresh_scales, remove_rule
from etsid.ets.layout import (
    EV_BIRTH,
    EV_REMOVAL,
    EV_REPLACE,
    IP_SCHEDULED,
    RADIUS_FLOOR,
    SQRT8,
    TIE,
)
from etsid.ets.normalisation import reparametrise

#: the rule loops run over a multiple of this many lanes, so the vectorised loop bodies
#: need no scalar remainder
LANES = 4


@njit(cache=True, boundscheck=False)
def _sync_rule(i, cz, rad, s, czT, aT) -> None:
    """Copy rule i's focal point into the transposed work array and refresh its firing
    coefficients aT[j, i] = 4 / (s_j r_ij)^2 (hoisted inverse radii squared)."""
    for j in range(cz.shape[1]):
        czT[j, i] = cz[i, j]
    for j in range(aT.shape[0]):
        q = s[j] * rad[i, j]
        aT[j, i] = 4.0 / (q * q)


@njit(cache=True, boundscheck=False)
def _fire(X, t, czT, aT, R, ex, lam) -> None:
    """Normalised firing lambda_i of rules 0..R-1 for input row X[t] (rules in the inner loop).

    Same value as the reference's firing: tau_i = exp(-sum_j aT[j, i] (x_j - x*_ij)^2), normalised
    with the smallest exponent subtracted first.
    """
    n = aT.shape[0]
    for i in range(R):
        ex[i] = 0.0
    for j in range(n):
        xj = X[t, j]
        for i in range(R):
            dj = xj - czT[j, i]
            ex[i] += dj * dj * aT[j, i]
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
def _to_soa(R, Pi, Cl, PiT, CT, is_global) -> None:
    """Copy consequents (and local covariances) of rules 0..R-1 into the rule-minor work
    arrays PiT[a, o, i], CT[a, b, i] so the per-rule updates vectorise over rules."""
    n1 = Pi.shape[1]
    m = Pi.shape[2]
    for a in range(n1):
        for o in range(m):
            for i in range(R):
                PiT[a, o, i] = Pi[i, a, o]
        if not is_global:
            for b in range(n1):
                for i in range(R):
                    CT[a, b, i] = Cl[i, a, b]


@njit(cache=True, boundscheck=False)
def _from_soa(R, Pi, Cl, PiT, CT, is_global) -> None:
    """Write the work arrays of rules 0..R-1 back into the state layout."""
    n1 = Pi.shape[1]
    m = Pi.shape[2]
    for i in range(R):
        for a in range(n1):
            for o in range(m):
                Pi[i, a, o] = PiT[a, o, i]
            if not is_global:
                for b in range(n1):
                    Cl[i, a, b] = CT[a, b, i]


@njit(cache=True, boundscheck=False)
def _rule_outputs(xe, PiT, R, yrT) -> None:
    """yrT[o, i] = x_e^T Pi_i[:, o] for every live rule (rules in the inner loop)."""
    n1 = xe.shape[0]
    m = yrT.shape[0]
    for o in range(m):
        for i in range(R):
            yrT[o, i] = 0.0
    for a in range(n1):
        xa = xe[a]
        for o in range(m):
            for i in range(R):
                yrT[o, i] += xa * PiT[a, o, i]


@njit(cache=True, boundscheck=False)
def learn_lanes(X, S, Y, Yhat, hist, ev, nev, snap_k, snap_ids, snap_pi, snap_lo, snap_s, nsnap,
                every, min_rules, si, lo, hi, fixed, mean, m2, ids, cz, rad, scat, pot, birth,
                support, lamsum, tsum, Pi, Cl, Cg, sh, Cs, r0, fp, ip) -> int:
    """:func:`etsid.ets.kernels.learn_kernel` on rule-minor work copies (same arguments,
    same results bit for bit), plus ``min_rules``: the kernel also returns after a sample
    that leaves fewer rules than this (the caller goes on with ``learn_kernel``).

    Speed: focal points, firing coefficients, consequents and local covariances are copied
    once per call into arrays with the rule index last (``czT[j, i]``, ``PiT[a, o, i]``,
    ``CT[a, b, i]``) and back at the end or before a rare edit (range widening, removal);
    firing, potentials, rule outputs and all R local RLS updates are then loops over rule
    lanes that LLVM vectorises; global RLS computes g = C phi as a sum of columns.
    """
    N, n = X.shape
    na = S.shape[1]
    m = Y.shape[1]
    d = lo.shape[0]
    n1 = n + 1
    scheduled = ip[IP_SCHEDULED] == 1
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
    # rule-minor work arrays, lanes padded to a multiple of LANES; the padding lanes are
    # zero or hold a removed rule, have lambda = 0 and are never read into a result
    rpad = (rmax + LANES - 1) // LANES * LANES
    czT = np.zeros((d, rpad))
    aT = np.zeros((na, rpad))
    ex = np.zeros(rpad)
    lam = np.zeros(rpad)
    yrT = np.zeros((m, rpad))
    PiT = np.zeros((n1, m, rpad))
    CT = np.zeros((1, 1, 1) if is_global else (n1, n1, rpad))
    gT = np.zeros((n1, rpad))
    cw = np.zeros(rpad)
    fiv = np.zeros(rpad)
    xe = np.empty(n1)
    z = np.empty(d)
    yh = np.empty(m)
    err = np.empty(m)
    pnew = np.zeros((n1, m))
    scat0 = np.empty(na)
    g = np.empty(rmax * n1 if is_global else n1)
    phi = np.empty(rmax * n1 if is_global else 1)
    n_shared = 0
    for o in range(m):
        n_shared += sh[o]
    gs = np.empty(n1)
    ths = np.empty((n1, m))
    p_none = np.zeros((1, n1, 0))
    cs3 = Cs.reshape((1, n1, n1)) if n_shared > 0 else np.zeros((1, 1, 1))

    _refresh_scales(lo, hi, s, w2, isx, n, xo)
    for i in range(si[1]):
        _sync_rule(i, cz, rad, s, czT, aT)
    _to_soa(si[1], Pi, Cl, PiT, CT, is_global)

    for t in range(N):
        k = si[0]
        R = si[1]
        for j in range(na):
            z[j] = S[t, j]
        for o in range(m):
            z[na + o] = Y[t, o]
        if scheduled:
            for j in range(n):
                z[xo + j] = X[t, j]
        # lanes processed by the vectorised rule loops: R rounded up to a multiple of LANES
        RL = (R + LANES - 1) // LANES * LANES
        # 1. one-step prediction before any update (lam, x_e and the rule outputs are kept).
        # _fire and _rule_outputs written out: a call costs an atomic reference-count
        # increment and decrement per array argument, more than the arithmetic here
        if R > 0:
            for i in range(RL):
                ex[i] = 0.0
            for j in range(na):
                xj = z[j]
                for i in range(RL):
                    dj = xj - czT[j, i]
                    ex[i] += dj * dj * aT[j, i]
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
            xe[0] = 1.0
            for j in range(n):
                xe[j + 1] = (z[xo + j] - lo[xo + j]) * isx[j]
            for o in range(m):
                for i in range(RL):
                    yrT[o, i] = 0.0
            for a in range(n1):
                xa = xe[a]
                for o in range(m):
                    for i in range(RL):
                        yrT[o, i] += xa * PiT[a, o, i]
            for o in range(m):
                acc = 0.0
                for i in range(R):
                    acc += lam[i] * yrT[o, i]
                Yhat[t, o] = acc
                yh[o] = acc
        else:
            for o in range(m):
                Yhat[t, o] = np.nan
        # 2. widen running ranges; rewrite consequents if an input range moved
        changed_x = False
        changed_a = False
        changed_y = False
        for j in range(d):
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
        if changed_y:
            _refresh_scales(lo, hi, s, w2, isx, n, xo)
        if changed_a:
            for i in range(R):
                _sync_rule(i, cz, rad, s, czT, aT)
        if changed_x and R > 0:
            _from_soa(R, Pi, Cl, PiT, CT, is_global)
            reparametrise(lo_old, hi_old, lo[xo : xo + n], s[xo : xo + n], R, Pi, Cl, Cg,
                          is_global)
            if n_shared > 0:
                reparametrise(lo_old, hi_old, lo[xo : xo + n], s[xo : xo + n], 1, p_none,
                              cs3, Cg, False)
            _to_soa(R, Pi, Cl, PiT, CT, is_global)
        # 3. running mean / variance of z (Welford)
        k += 1
        si[0] = k
        ik = 1.0 / k
        for j in range(d):
            dj = z[j] - mean[j]
            mean[j] += dj * ik
            m2[j] += dj * (z[j] - mean[j])
        # 4. potentials of the sample and of every focal point (rules in the inner loop)
        pmax = -np.inf
        pmin = np.inf
        if k >= 2:
            vterm = 0.0
            acc = 0.0
            for j in range(dp):
                vterm += m2[j] * w2[j]
                dj = z[j] - mean[j]
                acc += dj * dj * w2[j]
            vterm *= ik
            kk = k / (k - 1.0)
            P = 1.0 / (1.0 + (acc + vterm) * kk)
            for i in range(RL):
                ex[i] = vterm
            for j in range(dp):
                mj = mean[j]
                wj = w2[j]
                for i in range(RL):
                    dj = czT[j, i] - mj
                    ex[i] += dj * dj * wj
            for i in range(R):
                pi_ = 1.0 / (1.0 + ex[i] * kk)
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
                    _sync_rule(target, cz, rad, s, czT, aT)
                    add_event(ev, nev, k, EV_REPLACE, ids[target])
                    changed = True
                elif grow:
                    if changed_a:
                        _fire(S, t, czT, aT, R, ex, lam)
                    for a in range(n1):
                        for o in range(m):
                            acc = 0.0
                            for i in range(R):
                                acc += lam[i] * PiT[a, o, i]
                            pnew[a, o] = acc
        if grow:
            for j in range(na):
                scat0[j] = (r0[j] * s[j] / SQRT8) ** 2
            rid = _add_rule(z, P, k, pnew, si, r0, s, omega, scat0, ids, cz, rad, scat, pot, birth,
                            support, lamsum, tsum, Pi, Cl, Cg, is_global)
            _sync_rule(R, cz, rad, s, czT, aT)
            for a in range(n1):
                for o in range(m):
                    PiT[a, o, R] = Pi[R, a, o]
                if not is_global:
                    for b in range(n1):
                        CT[a, b, R] = Cl[R, a, b]
            add_event(ev, nev, k, EV_BIRTH, rid)
            changed = True
            born = True
        R = si[1]
        RL = (R + LANES - 1) // LANES * LANES
        # 6. firing with the updated rule base; support, age, spreads, utility
        if changed:
            _fire(S, t, czT, aT, R, ex, lam)
            xe[0] = 1.0
            for j in range(n):
                xe[j + 1] = (z[xo + j] - lo[xo + j]) * isx[j]
            _rule_outputs(xe, PiT, R, yrT)
            for o in range(m):
                acc = 0.0
                for i in range(R):
                    acc += lam[i] * yrT[o, i]
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
                    aT[j, w] = 4.0 / (q * q)  # as _sync_rule
            if evq:
                # the winner's focal point is the mean of the samples it has won
                for j in range(d):
                    cz[w, j] += (z[j] - cz[w, j]) / support[w]
                _sync_rule(w, cz, rad, s, czT, aT)
        for i in range(R, RL):
            lam[i] = 0.0  # padding lanes: no update
        for i in range(R):
            lamsum[i] += lam[i]
        # 7. consequents: fuzzily weighted RLS
        if is_global:
            iden = global_gain(R, n1, lam, xe, z, na, yh, err, g, phi, Cg, forget, omega)
            for a in range(n1):
                for i in range(R):
                    gT[a, i] = g[i * n1 + a] * iden
            for a in range(n1):
                for o in range(m):
                    eo = err[o]
                    for i in range(R):
                        PiT[a, o, i] += gT[a, i] * eo
        else:
            if n_shared > 0:
                # shared outputs: plain RLS on the common consequent (rule 0's column)
                shared_rls(xe, z, na, sh, PiT[:, :, 0], Cs, gs, ths, forget, cbound)
            # every rule at once, rules in the inner (contiguous) loop; a rule with
            # lambda = 0 gets f_i = 1 and gain 0, i.e. exactly no change
            for i in range(RL):
                fiv[i] = 1.0 - lam[i] * omf
                cw[i] = 0.0
            if forget != 1.0:
                # wind-up guard (trace-bounded forgetting): rule i forgets only while
                # trace(C_i) <= omega (n + 1), the trace of a new rule's covariance
                for i in range(R):
                    tr = 0.0
                    for a in range(n1):
                        tr += CT[a, a, i]
                    if tr > cbound:
                        fiv[i] = 1.0
            for a in range(n1):
                for i in range(RL):
                    gT[a, i] = 0.0
                for b in range(n1):
                    xb = xe[b]
                    for i in range(RL):
                        gT[a, i] += CT[a, b, i] * xb
            for a in range(n1):
                xa = xe[a]
                for i in range(RL):
                    cw[i] += xa * gT[a, i]
            for i in range(RL):
                wi = lam[i]
                cw[i] = wi / (fiv[i] + wi * cw[i])
            # C_ab - c (g_a g_b) is exactly symmetric: no mirroring needed
            for a in range(n1):
                for b in range(n1):
                    for i in range(RL):
                        CT[a, b, i] -= cw[i] * (gT[a, i] * gT[b, i])
            if forget != 1.0:
                for i in range(RL):
                    fiv[i] = 1.0 / fiv[i]
                for a in range(n1):
                    for b in range(n1):
                        for i in range(RL):
                            CT[a, b, i] *= fiv[i]
            for o in range(m):
                yo = z[na + o]
                for i in range(RL):
                    yrT[o, i] = yo - yrT[o, i]
            for a in range(n1):
                for i in range(RL):
                    gT[a, i] *= cw[i]
                for o in range(m):
                    for i in range(RL):
                        PiT[a, o, i] += gT[a, i] * yrT[o, i]
            if n_shared > 0:
                for a in range(n1):
                    for o in range(m):
                        if sh[o] == 1:
                            for i in range(R):
                                PiT[a, o, i] = ths[a, o]
        # 8. eTS+ quality: remove rules of low utility or tiny support
        if variant == 1:
            i = R - 1
            removed = False
            while i >= 0 and R > 1:
                life = k - birth[i]
                if life >= prune_after:
                    u = lamsum[i] / (life + 1.0)
                    if u < umin or support[i] < min_support:
                        add_event(ev, nev, k, EV_REMOVAL, ids[i])
                        if not removed:
                            _from_soa(R, Pi, Cl, PiT, CT, is_global)
                        remove_rule(i, R, ids, cz, rad, scat, pot, birth, support, lamsum, tsum,
                                    Pi, Cl, Cg, is_global)
                        R -= 1
                        si[1] = R
                        removed = True
                i -= 1
            if removed:
                for i in range(R):
                    _sync_rule(i, cz, rad, s, czT, aT)
                _to_soa(R, Pi, Cl, PiT, CT, is_global)
        # 9. history
        fmax = -np.inf
        fmin = np.inf
        for i in range(R):
            fmax = max(fmax, pot[i])
            fmin = min(fmin, pot[i])
        hist[t, 0] = R
        hist[t, 1] = P
        hist[t, 2] = fmax
        hist[t, 3] = fmin
        stop = nev[0] > ev_cap or min_rules > R
        if k == next_snap:
            next_snap += every
            q = nsnap[0]
            snap_k[q] = k
            for i in range(rmax):
                snap_ids[q, i] = ids[i] if i < R else -1
            for i in range(R):
                for a in range(n1):
                    for o in range(m):
                        snap_pi[q, i, a, o] = PiT[a, o, i]
            for j in range(n):
                snap_lo[q, j] = lo[xo + j]
                snap_s[q, j] = s[xo + j]
            nsnap[0] = q + 1
            stop = stop or q + 1 >= snap_cap
        if stop:
            _from_soa(R, Pi, Cl, PiT, CT, is_global)
            return t + 1
    _from_soa(si[1], Pi, Cl, PiT, CT, is_global)
    return N
