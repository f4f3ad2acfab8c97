"""The per-sample eTS / eTS+ recursion as two numba kernels: learn (predict-then-learn) and predict.

See ``kernels.py`` for the state layout and ``docs/ets.md`` for every formula and choice.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from etsid.ets.kernels import (
    EV_BIRTH,
    EV_REMOVAL,
    EV_REPLACE,
    FP_FORGET,
    FP_OMEGA,
    FP_SPREAD_RHO,
    FP_UTILITY,
    IP_ADAPTIVE,
    IP_COVERAGE,
    IP_GLOBAL,
    IP_MAX_RULES,
    IP_MIN_SUPPORT,
    IP_PRUNE_AFTER,
    IP_VARIANT,
    RADIUS_FLOOR,
    SQRT8,
    TIE,
    firing,
    output,
    potential,
    regressor,
    remove_rule,
    reparametrise,
    scales,
)


@njit(cache=True)
def predict_kernel(X, Yhat, n_rules, lo, hi, cz, rad, Pi) -> None:
    """Batch prediction with frozen rules; NaN rows when the model has no rule."""
    N, n = X.shape
    m = Yhat.shape[1]
    d = lo.shape[0]
    s = np.empty(d)
    scales(lo, hi, s)
    lam = np.empty(max(n_rules, 1))
    xe = np.empty(n + 1)
    yh = np.empty(m)
    for t in range(N):
        if n_rules == 0:
            for o in range(m):
                Yhat[t, o] = np.nan
            continue
        firing(X[t], cz, rad, s, n_rules, lam)
        regressor(X[t], lo, s, xe)
        output(xe, lam, Pi, n_rules, yh)
        for o in range(m):
            Yhat[t, o] = yh[o]


@njit(cache=True)
def _add_rule(
    z,
    P,
    k,
    pnew,
    si,
    r0,
    s,
    omega,
    scat0,
    ids,
    cz,
    rad,
    scat,
    pot,
    birth,
    support,
    lamsum,
    tsum,
    Pi,
    Cl,
    Cg,
    is_global,
) -> int:
    """Append a rule centred on z (raw units); returns its id."""
    R = si[1]
    n = r0.shape[0]
    n1 = n + 1
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
def learn_kernel(
    X,
    Y,
    Yhat,
    hist,
    ev,
    nev,
    si,
    lo,
    hi,
    fixed,
    mean,
    m2,
    ids,
    cz,
    rad,
    scat,
    pot,
    birth,
    support,
    lamsum,
    tsum,
    Pi,
    Cl,
    Cg,
    r0,
    fp,
    ip,
) -> None:
    """Online predict-then-learn over all rows of X (N, n), Y (N, m); mutates the state.

    Writes the one-step predictions made *before* each update into ``Yhat`` and the
    per-sample history (rules, potential, focal max, focal min) into ``hist``. Events
    (step, kind, rule id) are appended to ``ev`` from row ``nev[0]``; the caller sizes ``ev``
    for the worst case (4 N + max_rules rows).
    """
    N, n = X.shape
    m = Y.shape[1]
    d = n + m
    n1 = n + 1
    variant = ip[IP_VARIANT]
    is_global = ip[IP_GLOBAL] == 1
    rmax = ip[IP_MAX_RULES]
    min_support = ip[IP_MIN_SUPPORT]
    prune_after = ip[IP_PRUNE_AFTER]
    adaptive = ip[IP_ADAPTIVE] == 1
    omega = fp[FP_OMEGA]
    forget = fp[FP_FORGET]
    umin = fp[FP_UTILITY]
    rho_s = fp[FP_SPREAD_RHO]
    coverage = ip[IP_COVERAGE] == 1

    s = np.empty(d)
    lo_old = np.empty(n)
    hi_old = np.empty(n)
    lam = np.empty(rmax)
    xe = np.empty(n1)
    z = np.empty(d)
    w2 = np.empty(d)
    yh = np.empty(m)
    err = np.empty(m)
    pnew = np.zeros((n1, m))
    scat0 = np.empty(n)
    g = np.empty(rmax * n1 if is_global else n1)
    phi = np.empty(rmax * n1 if is_global else 1)

    for t in range(N):
        x = X[t]
        y = Y[t]
        k = si[0]
        R = si[1]
        scales(lo, hi, s)
        # 1. one-step prediction before any update
        if R > 0:
            firing(x, cz, rad, s, R, lam)
            regressor(x, lo, s, xe)
            output(xe, lam, Pi, R, yh)
            for o in range(m):
                Yhat[t, o] = yh[o]
        else:
            for o in range(m):
                Yhat[t, o] = np.nan
        # 2. widen running ranges; rewrite consequents if an input range moved
        for j in range(n):
            lo_old[j] = lo[j]
            hi_old[j] = hi[j]
        changed_x = False
        for j in range(d):
            v = x[j] if j < n else y[j - n]
            z[j] = v
            if fixed[j] == 1:
                continue
            if k == 0:
                lo[j] = v
                hi[j] = v
            elif v < lo[j]:
                lo[j] = v
                changed_x = changed_x or j < n
            elif v > hi[j]:
                hi[j] = v
                changed_x = changed_x or j < n
        scales(lo, hi, s)
        if changed_x and R > 0:
            reparametrise(lo_old, hi_old, lo, s, R, Pi, Cl, Cg, is_global)
        # 3. running mean / variance of z (Welford)
        k += 1
        si[0] = k
        for j in range(d):
            dj = z[j] - mean[j]
            mean[j] += dj / k
            m2[j] += dj * (z[j] - mean[j])
        # 4. potentials of the sample and of every focal point
        P = potential(z, mean, m2, s, k)
        pmax = -np.inf
        pmin = np.inf
        if k >= 2:
            # same expansion as potential(), with the variance term shared by all rules
            vterm = 0.0
            for j in range(d):
                w2[j] = 1.0 / (s[j] * s[j])
                vterm += m2[j] / k * w2[j]
            kk = k / (k - 1.0)
            for i in range(R):
                acc = vterm
                for j in range(d):
                    dj = cz[i, j] - mean[j]
                    acc += dj * dj * w2[j]
                pi_ = 1.0 / (1.0 + acc * kk)
                pot[i] = pi_
                pmax = max(pmax, pi_)
                pmin = min(pmin, pi_)
        else:
            for i in range(R):
                pot[i] = 1.0
            pmax = pmin = 1.0 if R > 0 else 0.0
        # 5. structure
        for j in range(n):
            scat0[j] = (r0[j] * s[j] / SQRT8) ** 2
        changed = changed_x
        born = False
        if R == 0:
            pnew[:, :] = 0.0
            rid = _add_rule(
                z,
                P,
                k,
                pnew,
                si,
                r0,
                s,
                omega,
                scat0,
                ids,
                cz,
                rad,
                scat,
                pot,
                birth,
                support,
                lamsum,
                tsum,
                Pi,
                Cl,
                Cg,
                is_global,
            )
            ev[nev[0], 0] = k
            ev[nev[0], 1] = EV_BIRTH
            ev[nev[0], 2] = rid
            nev[0] += 1
            changed = True
            born = True
        else:
            high = pmax * (1.0 + TIE) < P
            low = variant == 1 and (pmin * (1.0 - TIE) > P or coverage)
            if high or low:
                dmin = np.inf
                inear = 0
                dcov = np.inf
                icov = -1
                for i in range(R):
                    d2 = 0.0
                    dinf = 0.0
                    for j in range(n):
                        q = abs(x[j] - cz[i, j]) / (s[j] * rad[i, j])
                        d2 += q * q
                        dinf = max(dinf, q)
                    if d2 < dmin:
                        dmin = d2
                        inear = i
                    if dinf < 0.5 and d2 < dcov:
                        dcov = d2
                        icov = i
                if variant == 0:
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
                    ev[nev[0], 0] = k
                    ev[nev[0], 1] = EV_REPLACE
                    ev[nev[0], 2] = ids[target]
                    nev[0] += 1
                    changed = True
                elif grow:
                    if changed_x:
                        firing(x, cz, rad, s, R, lam)
                        regressor(x, lo, s, xe)
                    for a in range(n1):
                        for o in range(m):
                            acc = 0.0
                            for i in range(R):
                                acc += lam[i] * Pi[i, a, o]
                            pnew[a, o] = acc
                    rid = _add_rule(
                        z,
                        P,
                        k,
                        pnew,
                        si,
                        r0,
                        s,
                        omega,
                        scat0,
                        ids,
                        cz,
                        rad,
                        scat,
                        pot,
                        birth,
                        support,
                        lamsum,
                        tsum,
                        Pi,
                        Cl,
                        Cg,
                        is_global,
                    )
                    ev[nev[0], 0] = k
                    ev[nev[0], 1] = EV_BIRTH
                    ev[nev[0], 2] = rid
                    nev[0] += 1
                    changed = True
                    born = True
        R = si[1]
        # 6. firing with the updated rule base; support, age, spreads, utility
        if changed:
            firing(x, cz, rad, s, R, lam)
            regressor(x, lo, s, xe)
        if not born:
            w = 0
            for i in range(1, R):
                if lam[i] > lam[w]:
                    w = i
            support[w] += 1
            tsum[w] += k
            if adaptive:
                for j in range(n):
                    dx = x[j] - cz[w, j]
                    scat[w, j] += (dx * dx - scat[w, j]) / support[w]
                    rj = rho_s * rad[w, j] + (1.0 - rho_s) * SQRT8 * np.sqrt(scat[w, j]) / s[j]
                    rad[w, j] = max(rj, RADIUS_FLOOR * r0[j])
        for i in range(R):
            lamsum[i] += lam[i]
        # 7. consequents: fuzzily weighted RLS
        if is_global:
            p = R * n1
            for i in range(R):
                for a in range(n1):
                    phi[i * n1 + a] = lam[i] * xe[a]
            output(xe, lam, Pi, R, yh)
            for o in range(m):
                err[o] = y[o] - yh[o]
            den = forget
            for a in range(p):
                acc = 0.0
                for b in range(p):
                    acc += Cg[a, b] * phi[b]
                g[a] = acc
                den += phi[a] * acc
            iden = 1.0 / den
            ifg = 1.0 / forget
            for a in range(p):
                ga = g[a] * iden
                for b in range(a, p):
                    v = (Cg[a, b] - ga * g[b]) * ifg
                    Cg[a, b] = v
                    Cg[b, a] = v
            for i in range(R):
                for a in range(n1):
                    ga = g[i * n1 + a] / den
                    for o in range(m):
                        Pi[i, a, o] += ga * err[o]
        else:
            for i in range(R):
                wi = lam[i]
                fi = 1.0 - wi * (1.0 - forget)
                den = fi
                for a in range(n1):
                    acc = 0.0
                    for b in range(n1):
                        acc += Cl[i, a, b] * xe[b]
                    g[a] = acc
                    den += wi * xe[a] * acc
                cw = wi / den
                ifi = 1.0 / fi
                for a in range(n1):
                    ga = cw * g[a]
                    for b in range(a, n1):
                        v = Cl[i, a, b] - ga * g[b]
                        if fi != 1.0:
                            v *= ifi
                        Cl[i, a, b] = v
                        Cl[i, b, a] = v
                for o in range(m):
                    acc = y[o]
                    for a in range(n1):
                        acc -= xe[a] * Pi[i, a, o]
                    err[o] = acc
                for a in range(n1):
                    ga = cw * g[a]
                    for o in range(m):
                        Pi[i, a, o] += ga * err[o]
        # 8. eTS+ quality: remove rules of low utility or tiny support
        if variant == 1:
            i = R - 1
            while i >= 0 and R > 1:
                life = k - birth[i]
                if life >= prune_after:
                    u = lamsum[i] / (life + 1.0)
                    if u < umin or support[i] < min_support:
                        ev[nev[0], 0] = k
                        ev[nev[0], 1] = EV_REMOVAL
                        ev[nev[0], 2] = ids[i]
                        nev[0] += 1
                        remove_rule(
                            i,
                            R,
                            ids,
                            cz,
                            rad,
                            scat,
                            pot,
                            birth,
                            support,
                            lamsum,
                            tsum,
                            Pi,
                            Cl,
                            Cg,
                            is_global,
                        )
                        R -= 1
                        si[1] = R
                i -= 1
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
