"""Steps of the per-sample eTS recursion that both learning kernels share:
:func:`etsid.ets.kernels.learn_kernel` (rule-major) and
:func:`etsid.ets.kernels_lanes.learn_lanes` (rule-minor lanes).

Each helper is inlined into the kernels by numba (``inline="always"``, in numba's own
code, before LLVM), and its arithmetic is the one written here in this order: the kernels
stay bit-identical to each other and to what they computed before (``python
benchmarks/ets.py --compare``).

Only steps off the hot path of a small rule base are here: reading the parameters (once
per call), appending an event (a birth, move or removal), the global RLS and the shared
outputs' RLS (each much more arithmetic than a call costs), and the interpolated output
blend (``blend="interpolate"``, also used by the prediction kernels). The steps every sample runs
(firing, range widening, Welford, potentials, the structure test, the winner's update)
stay written out in each kernel. Shared the same way, they made the 2-rule kernel about
1.6× slower (0.29 → 0.47 µs/sample in an alternating A/B). The likely cause: the inlined
copies of an array argument are reference-counted per sample, an atomic increment and
decrement each (docs/performance.md, "Shared kernel steps").
"""

from __future__ import annotations

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
def interp_pair(s0, f, R):
    """The output blend of ``blend="interpolate"``: rules ``(lo, hi, w)`` with
    y = (1 − w) y_lo + w y_hi. ``lo`` is the rule with the greatest focal value ``f[i]`` at
    or below ``s0``, ``hi`` the one with the least above it (the first in rule order on
    ties), w = (s0 − f_lo) / (f_hi − f_lo); beyond the outermost focal values ``lo = hi``
    is the outermost rule and w = 0. ``f`` (≥ R values) holds each rule's focal value on
    the one antecedent input; R ≥ 1."""
    lo = -1
    hi = -1
    for i in range(R):
        c = f[i]
        if c <= s0:
            if lo < 0 or c > f[lo]:
                lo = i
        elif hi < 0 or c < f[hi]:
            hi = i
    if lo < 0:
        return hi, hi, 0.0
    if hi < 0:
        return lo, lo, 0.0
    return lo, hi, (s0 - f[lo]) / (f[hi] - f[lo])


@njit(inline="always")
def add_event(ev, nev, k, kind, rid) -> None:
    """Append the event (step ``k``, ``kind``, rule id ``rid``) at row ``nev[0]``."""
    q = nev[0]
    ev[q, 0] = k
    ev[q, 1] = kind
    ev[q, 2] = rid
    nev[0] = q + 1


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
    # gs = Cs x_e as a sum of columns (Cs is exactly symmetric: the row dot product's order).
    # Written out here and in global_gain as they were timed; sharing kernels._gain_by_columns
    # (inlined or called) was tried, and this VM's per-process spread (up to 1.6x between
    # runs of one code) could not show it cost nothing (docs/performance.md, session 6)
    for a in range(n1):
        gs[a] = 0.0
    for b in range(n1):
        xb = xe[b]
        for a in range(n1):
            gs[a] += Cs[b, a] * xb
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
