"""Plain-numpy reference of the eTS recursion, written for reading, not for speed.

It follows ``docs/ets.md`` step by step with whole-vector numpy operations and Python
lists of rules, independently of the numba kernels; the tests require both to agree to
1e-9. It also holds the textbook forms of the potential used to check the kernels:
:func:`brute_force_potential` (the definition) and :func:`recursive_potential` (the
Cauchy-form recursion of Angelov & Filev 2004, eqs. as quoted in the issue).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from etsid.ets.params import DEFAULTS


def brute_force_potential(Z: np.ndarray) -> np.ndarray:
    """P_k(z_k) = 1 / (1 + mean_{l<k} ||z_k - z_l||^2) for every k (P_1 = 1).

    Parameters
    ----------
    Z : numpy.ndarray, shape (N, d)
        Samples, already normalised.
    """
    N = Z.shape[0]
    P = np.ones(N)
    for k in range(1, N):
        P[k] = 1.0 / (1.0 + np.mean(np.sum((Z[:k] - Z[k]) ** 2, axis=1)))
    return P


def recursive_potential(Z: np.ndarray) -> np.ndarray:
    """Cauchy-form recursion P_k(z_k) = (k-1) / ((k-1)(theta_k + 1) + sigma_k - 2 nu_k).

    theta_k = sum_j z_kj^2, sigma_k = sum_{l<k} sum_j z_lj^2, nu_k = sum_j z_kj b_kj,
    b_kj = sum_{l<k} z_lj (Angelov & Filev 2004); k is 1-based, P_1 = 1.
    """
    N, d = Z.shape
    P = np.ones(N)
    sigma = 0.0
    b = np.zeros(d)
    for i in range(N):
        k = i + 1
        z = Z[i]
        if k > 1:
            theta = float(z @ z)
            nu = float(z @ b)
            P[i] = (k - 1) / ((k - 1) * (theta + 1.0) + sigma - 2.0 * nu)
        sigma += float(z @ z)
        b += z
    return P


def recursive_focal_update(p_prev: float, k: int, dist2: float) -> float:
    """P_k(z*) = (k-1) P_{k-1}(z*) / (k - 2 + P_{k-1}(z*) (1 + ||z* - z_k||^2))."""
    return (k - 1) * p_prev / (k - 2 + p_prev * (1.0 + dist2))


def _trace(C: np.ndarray) -> float:
    """Sum of the diagonal, left to right (the kernels' order)."""
    tr = 0.0
    for a in range(C.shape[0]):
        tr += float(C[a, a])
    return tr


@dataclass
class RefRule:
    """One rule of the reference model (focal point in raw units)."""

    rid: int
    z: np.ndarray
    rad: np.ndarray
    scat: np.ndarray
    pot: float
    birth: int
    Pi: np.ndarray
    C: np.ndarray | None
    support: int = 1
    lamsum: float = 0.0
    tsum: float = 0.0


@dataclass
class ReferenceETS:
    """Reference eTS learner with the same parameters as :class:`etsid.ets.ETS`."""

    n: int
    m: int
    radius: np.ndarray
    omega: float = DEFAULTS.omega
    variant: str = DEFAULTS.variant
    max_rules: int = DEFAULTS.max_rules
    rls: str = DEFAULTS.rls
    forgetting: float = DEFAULTS.forgetting
    utility_threshold: float = DEFAULTS.utility_threshold
    min_support: int = DEFAULTS.min_support
    prune_after: int = DEFAULTS.prune_after
    adaptive_spread: bool = DEFAULTS.adaptive_spread
    coverage: bool = DEFAULTS.coverage
    clustering: str = DEFAULTS.clustering
    na: int | None = None
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    fixed: np.ndarray | None = None
    rules: list[RefRule] = field(default_factory=list)
    k: int = 0
    next_id: int = 0
    Cg: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    shared_outputs: tuple[int, ...] = ()
    events: list[tuple[int, str, int]] = field(default_factory=list)
    history: list[tuple[int, float, float, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        # scheduled (na given): z = [s; y; x], antecedents on s, potentials on s alone;
        # else z = [x; y], antecedents on x, potentials on z
        self.sched = self.na is not None
        if not self.sched:
            self.na = self.n
        self.xo = self.na + self.m if self.sched else 0
        self.dp = self.na if self.sched else self.n + self.m
        d = self.na + self.m + (self.n if self.sched else 0)
        self.lo = np.zeros(d) if self.lo is None else np.array(self.lo, dtype=float)
        self.hi = np.zeros(d) if self.hi is None else np.array(self.hi, dtype=float)
        self.fixed = np.zeros(d, bool) if self.fixed is None else np.array(self.fixed, bool)
        self.data: list[np.ndarray] = []
        # shared outputs: one consequent common to every rule, plain RLS on Cs
        self.sh = np.array(sorted(self.shared_outputs), dtype=int)
        self.Cs = self.omega * np.eye(self.n + 1)

    # normalisation ----------------------------------------------------------------
    def _s(self) -> np.ndarray:
        w = self.hi - self.lo
        return np.where(w > 0, w, 1.0)

    def _lam(self, a: np.ndarray, s: np.ndarray) -> np.ndarray:
        na = self.na
        sa = s[:na]
        e = np.array([-4.0 * np.sum(((a - r.z[:na]) / (sa * r.rad)) ** 2) for r in self.rules])
        t = np.exp(e - e.max())
        return t / t.sum()

    def _xe(self, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        xs = slice(self.xo, self.xo + self.n)
        return np.concatenate([[1.0], (x - self.lo[xs]) / s[xs]])

    def _potential(self, z: np.ndarray, s: np.ndarray) -> float:
        # the definition, over every sample stored so far (self included, divisor k-1)
        if self.k < 2:
            return 1.0
        dp = self.dp
        D = np.array(self.data)[:, :dp]
        return 1.0 / (1.0 + np.sum(((D - z[:dp]) / s[:dp]) ** 2) / (self.k - 1))

    def predict(self, x: np.ndarray, a: np.ndarray | None = None) -> np.ndarray:
        """Output with the current rules (NaN without rules); ``a`` = s if scheduled."""
        if not self.rules:
            return np.full(self.m, np.nan)
        a = x if a is None else a
        s = self._s()
        lam = self._lam(a, s)
        xe = self._xe(x, s)
        return sum(li * (xe @ r.Pi) for li, r in zip(lam, self.rules, strict=True))

    # learning ---------------------------------------------------------------------
    def learn(self, x: np.ndarray, y: np.ndarray, a: np.ndarray | None = None) -> np.ndarray:
        """Predict, then learn one sample (``a`` = s if scheduled); returns the prediction."""
        n, na = self.n, self.na
        a = x if a is None else a
        yhat = self.predict(x, a)
        z = np.concatenate([a, y, x]) if self.sched else np.concatenate([x, y])
        lo_old, hi_old, s_old = self.lo.copy(), self.hi.copy(), self._s()
        free = ~self.fixed
        if self.k == 0:
            self.lo[free] = z[free]
            self.hi[free] = z[free]
        else:
            self.lo[free] = np.minimum(self.lo[free], z[free])
            self.hi[free] = np.maximum(self.hi[free], z[free])
        s = self._s()
        xs = slice(self.xo, self.xo + n)
        if self.rules and (np.any(self.lo[xs] != lo_old[xs]) or np.any(self.hi[xs] != hi_old[xs])):
            so = np.where(hi_old[xs] - lo_old[xs] > 0, s_old[xs], s[xs])
            T = np.eye(n + 1)
            T[1:, 0] = (self.lo[xs] - lo_old[xs]) / so
            T[1:, 1:] = np.diag(s[xs] / so)
            for r in self.rules:
                r.Pi = T.T @ r.Pi
                if r.C is not None:
                    r.C = T.T @ r.C @ T
                    r.C = 0.5 * (r.C + r.C.T)
            if self.rls == "global":
                Tb = np.kron(np.eye(len(self.rules)), T)
                self.Cg = Tb.T @ self.Cg @ Tb
                self.Cg = 0.5 * (self.Cg + self.Cg.T)
            if self.sh.size:
                self.Cs = T.T @ self.Cs @ T
                self.Cs = 0.5 * (self.Cs + self.Cs.T)
        self.k += 1
        self.data.append(z)
        k = self.k
        P = self._potential(z, s)
        for r in self.rules:
            r.pot = self._potential(r.z, s)
        born = False
        if not self.rules:
            self._add(z, P, np.zeros((n + 1, self.m)), s)
            born = True
        else:
            pots = np.array([r.pot for r in self.rules])
            high = pots.max() * (1.0 + 1e-10) < P
            low = self.variant == "ets+" and (pots.min() * (1.0 - 1e-10) > P or self.coverage)
            evq = self.clustering == "evq"
            if evq or high or low:
                q = np.array([np.abs(a - r.z[:na]) / (s[:na] * r.rad) for r in self.rules])
                d2 = np.sum(q**2, axis=1)
                inear = int(np.argmin(d2))
                cov = np.where(q.max(axis=1) < 0.5)[0]
                icov = int(cov[np.argmin(d2[cov])]) if cov.size else -1
                if evq:
                    replace, target, grow = False, inear, icov < 0
                elif self.variant == "ets":
                    replace = P / pots.max() - np.sqrt(d2[inear]) >= 1.0
                    target, grow = inear, not replace
                else:
                    replace, target, grow = high and icov >= 0, icov, icov < 0
                if grow and len(self.rules) >= self.max_rules:
                    replace, target, grow = True, inear, False
                if replace:
                    self.rules[target].z = z.copy()
                    self.rules[target].pot = P
                    self.events.append((k, "replace", self.rules[target].rid))
                elif grow:
                    lam = self._lam(a, s)
                    pnew = sum(li * r.Pi for li, r in zip(lam, self.rules, strict=True))
                    self._add(z, P, pnew, s)
                    born = True
        lam = self._lam(a, s)
        xe = self._xe(x, s)
        if not born:
            w = int(np.argmax(lam))
            r = self.rules[w]
            r.support += 1
            r.tsum += k
            if self.adaptive_spread:
                r.scat = r.scat + ((a - r.z[:na]) ** 2 - r.scat) / r.support
                rad = 0.5 * r.rad + 0.5 * np.sqrt(8.0) * np.sqrt(r.scat) / s[:na]
                r.rad = np.maximum(rad, 0.01 * self.radius)
            if self.clustering == "evq":
                r.z = r.z + (z - r.z) / r.support
        for li, r in zip(lam, self.rules, strict=True):
            r.lamsum += li
        f = self.forgetting
        if self.rls == "global":
            phi = np.concatenate([li * xe for li in lam])
            theta = np.concatenate([r.Pi for r in self.rules], axis=0)
            err = y - phi @ theta
            g = self.Cg @ phi
            if _trace(self.Cg) > self.omega * phi.size:
                f = 1.0  # wind-up guard: no forgetting while the trace is above Ω p
            den = f + phi @ g
            self.Cg = (self.Cg - np.outer(g, g) / den) / f
            theta = theta + np.outer(g / den, err)
            for i, r in enumerate(self.rules):
                r.Pi = theta[i * (n + 1) : (i + 1) * (n + 1)]
        else:
            if self.sh.size:  # shared outputs: plain RLS on the common consequent
                theta = self.rules[0].Pi[:, self.sh]
                fs = f if _trace(self.Cs) <= self.omega * (n + 1) else 1.0
                g = self.Cs @ xe
                den = fs + xe @ g
                self.Cs = (self.Cs - np.outer(g, g) / den) / fs
                theta = theta + np.outer(g / den, y[self.sh] - xe @ theta)
            for li, r in zip(lam, self.rules, strict=True):
                # wind-up guard: forget only while trace(C_i) <= Ω (n + 1)
                bounded = _trace(r.C) <= self.omega * (n + 1)
                fi = 1.0 - li * (1.0 - f) if bounded else 1.0
                g = r.C @ xe
                den = fi + li * xe @ g
                r.C = (r.C - (li / den) * np.outer(g, g)) / fi
                r.Pi = r.Pi + (li / den) * np.outer(g, y - xe @ r.Pi)
                if self.sh.size:
                    r.Pi[:, self.sh] = theta
        if self.variant == "ets+":
            for i in range(len(self.rules) - 1, -1, -1):
                if len(self.rules) <= 1:
                    break
                r = self.rules[i]
                life = k - r.birth
                if life >= self.prune_after and (
                    r.lamsum / (life + 1.0) < self.utility_threshold or r.support < self.min_support
                ):
                    self._remove(i, k)
        pots = [r.pot for r in self.rules]
        self.history.append((len(self.rules), P, max(pots), min(pots)))
        return yhat

    def _add(self, z: np.ndarray, P: float, pnew: np.ndarray, s: np.ndarray) -> None:
        n = self.n
        R = len(self.rules)
        local = None if self.rls == "global" else self.omega * np.eye(n + 1)
        if self.rls == "global":
            rho = (R * R + 1.0) / (R * R) if R > 0 else 1.0
            Cg = np.zeros(((R + 1) * (n + 1),) * 2)
            Cg[: R * (n + 1), : R * (n + 1)] = rho * self.Cg
            Cg[R * (n + 1) :, R * (n + 1) :] = self.omega * np.eye(n + 1)
            self.Cg = Cg
        scat0 = (self.radius * s[: self.na] / np.sqrt(8.0)) ** 2
        rule = RefRule(self.next_id, z.copy(), self.radius.copy(), scat0, P, self.k,
                       np.array(pnew, dtype=float), local, tsum=float(self.k))  # fmt: skip
        self.rules.append(rule)
        self.events.append((self.k, "birth", self.next_id))
        self.next_id += 1

    def _remove(self, i: int, k: int) -> None:
        n1 = self.n + 1
        self.events.append((k, "removal", self.rules[i].rid))
        del self.rules[i]
        if self.rls == "global":
            keep = np.r_[0 : i * n1, (i + 1) * n1 : self.Cg.shape[0]]
            self.Cg = self.Cg[np.ix_(keep, keep)]

    def run(self, X: np.ndarray, Y: np.ndarray, S: np.ndarray | None = None) -> np.ndarray:
        """Predict-then-learn over all rows (antecedents on ``S`` if given); returns the
        predictions (N, m)."""
        if S is None:
            return np.array([self.learn(x, y) for x, y in zip(X, Y, strict=True)])
        rows = zip(X, Y, S, strict=True)
        return np.array([self.learn(x, y, a) for x, y, a in rows])

    def state(self) -> dict[str, Any]:
        """Arrays comparable with the kernel state of the live rules."""
        return {
            "ids": np.array([r.rid for r in self.rules]),
            "cz": np.array([r.z for r in self.rules]),
            "Pi": np.array([r.Pi for r in self.rules]),
            "pot": np.array([r.pot for r in self.rules]),
            "support": np.array([r.support for r in self.rules]),
            "rad": np.array([r.rad for r in self.rules]),
        }
