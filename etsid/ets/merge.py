"""Rule merging: two neighbouring rules whose consequents are statistically
indistinguishable become one.

Evolving fuzzy systems grow rules where the data go, not where the modelled function
changes; rules that drift together or that split one regime carry redundant consequents.
Lughofer, Bouchot & Shaker (2011, "On-line elimination of local redundancies in evolving
fuzzy systems", Evolving Systems 2(3):165–187) merge two rules when their antecedents touch
and their consequents are similar; here "similar" is a statistical test on the learning data
(docs/ets.md, *Rule merging*):

* each rule's consequent θ_i (normalised regressors, one column per output) has the
  covariance σ_i² C_i — C_i its fuzzily weighted RLS matrix, σ_i² the residual variance of
  its own local model over the samples it leads (dof n + 1 removed); for weights ≤ 1 this
  bounds the true covariance from above, so the test errs towards merging;
* two rules are *indistinguishable* when, for every output, the Wald statistic
  W = (θ_i − θ_j)ᵀ (σ_i² C_i + σ_j² C_j)⁻¹ (θ_i − θ_j) stays below the χ²(n + 1) quantile
  at 1 − α/m (Bonferroni over the m outputs; α = :data:`ALPHA`);
* a rule leading fewer samples than its n + 1 parameters has no estimate of its own: it
  is merged into its nearest neighbour;
* only neighbours are tested: each rule with the rule nearest to it in the antecedent space
  (normalised distance between focal points). The pair with the smallest W / quantile
  merges first; the test is repeated until no pair qualifies.

The merged rule: focal point, potential and scatter the support-weighted means, support and
firing sums added, birth the earlier; consequent the information-weighted combination
θ = (C_i⁻¹ + C_j⁻¹ − I/ω)⁻¹ (C_i⁻¹ θ_i + C_j⁻¹ θ_j) — the least-squares estimate on the union
of both rules' data (the prior I/ω counted once) — with that matrix as its C. It keeps the id
of the rule with more support; the other's id is recorded in a ``merge`` event.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.special import gammaincinv

from etsid.ets.state import LearnedState

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ets.model import ETS

ALPHA = 0.05
"""Family-wise level of the equality test over the outputs."""


def _residual_var(model: ETS, X: np.ndarray, Y: np.ndarray, lead: np.ndarray, i: int
                  ) -> np.ndarray | None:
    """Residual variance (m,) of rule ``i``'s own consequent over the rows it leads; None
    when it leads no more rows than its parameters."""
    rows = lead == i
    k = int(np.count_nonzero(rows))
    p = X.shape[1] + 1
    if k <= p:
        return None
    cons = model.consequents_raw()[i]
    resid = Y[rows] - (cons[0] + X[rows] @ cons[1:])
    return np.sum(resid * resid, axis=0) / (k - p)


def _wald_ratio(state: LearnedState, var: list[np.ndarray | None], i: int, j: int,
                shared: np.ndarray) -> float:
    """max over outputs of W / χ² quantile for rules i, j (0 when either has no estimate:
    no evidence of a difference)."""
    if var[i] is None or var[j] is None:
        return 0.0
    Pi, C = state.consequents, state.covariances
    p, m = Pi.shape[1], Pi.shape[2]
    # χ²(p) quantile, as scipy.stats.chi2.ppf computes it (bit for bit) without importing
    # scipy.stats (29 MB and 0.45 s in every worker process)
    crit = 2.0 * gammaincinv(p / 2.0, 1.0 - ALPHA / m)
    worst = 0.0
    for o in range(m):
        if shared[o]:
            continue
        d = Pi[i, :, o] - Pi[j, :, o]
        cov = var[i][o] * C[i] + var[j][o] * C[j]
        try:
            w = float(d @ np.linalg.solve(cov, d))
        except np.linalg.LinAlgError:
            return np.inf
        worst = max(worst, w / crit)
    return worst


def _neighbours(model: ETS, state: LearnedState) -> list[tuple[int, int]]:
    """Each rule with its nearest rule in the (normalised) antecedent space, as sorted
    pairs without repeats."""
    na = len(model.antecedents())
    width = model.scales()[:na]
    focal = state.focal_points[:, :na] / width
    R = len(focal)
    pairs = set()
    for i in range(R):
        d = np.sum((focal - focal[i]) ** 2, axis=1)
        d[i] = np.inf
        j = int(np.argmin(d))
        pairs.add((min(i, j), max(i, j)))
    return sorted(pairs)


def _merged(state: LearnedState, i: int, j: int, omega: float, shared: np.ndarray
            ) -> tuple[LearnedState, int, int]:
    """The state with rules i and j replaced by their merge at position min(i, j), the id
    of the absorbed rule and of the kept one."""
    keep, drop = (i, j) if state.support[i] >= state.support[j] else (j, i)
    w = np.array([max(state.support[i], 1), max(state.support[j], 1)], dtype=float)
    w /= w.sum()
    Ci, Cj = state.covariances[i], state.covariances[j]
    p = Ci.shape[0]
    info_i, info_j = np.linalg.inv(Ci), np.linalg.inv(Cj)
    C = np.linalg.inv(info_i + info_j - np.eye(p) / omega)
    C = 0.5 * (C + C.T)
    Pi = C @ (info_i @ state.consequents[i] + info_j @ state.consequents[j])
    Pi[:, shared] = state.consequents[keep][:, shared]  # one model common to every rule

    def pair(a: np.ndarray, how: str) -> np.ndarray:
        out = np.delete(np.array(a, copy=True), max(i, j), axis=0)
        pos = min(i, j)
        if how == "mean":
            out[pos] = w[0] * a[i] + w[1] * a[j]
        elif how == "sum":
            out[pos] = a[i] + a[j]
        elif how == "min":
            out[pos] = min(a[i], a[j])
        elif how == "max":
            out[pos] = np.maximum(a[i], a[j])
        elif how == "keep":
            out[pos] = a[keep]
        return out

    cons = np.delete(np.array(state.consequents, copy=True), max(i, j), axis=0)
    cons[min(i, j)] = Pi
    covs = np.delete(np.array(state.covariances, copy=True), max(i, j), axis=0)
    covs[min(i, j)] = C
    return LearnedState(
        n_inputs=state.n_inputs, n_outputs=state.n_outputs, y_1d=state.y_1d,
        samples=state.samples, next_rule_id=state.next_rule_id,
        low=np.array(state.low), high=np.array(state.high), fixed=np.array(state.fixed),
        mean=np.array(state.mean), m2=np.array(state.m2),
        rule_ids=pair(state.rule_ids, "keep"), focal_points=pair(state.focal_points, "mean"),
        radii=pair(state.radii, "max"), scatter=pair(state.scatter, "mean"),
        potentials=pair(state.potentials, "mean"), births=pair(state.births, "min"),
        support=pair(state.support, "sum"), firing_sums=pair(state.firing_sums, "sum"),
        time_sums=pair(state.time_sums, "sum"), consequents=cons, covariances=covs,
        global_covariance=None, scheduled=state.scheduled, n_antecedents=state.n_antecedents,
        shared_covariance=None if state.shared_covariance is None
        else np.array(state.shared_covariance),
    ), int(state.rule_ids[drop]), int(state.rule_ids[keep])


def merge_rules(model: ETS, X: Any, Y: Any, S: Any = None) -> list[dict[str, int]]:
    """Merge the model's statistically indistinguishable neighbouring rules (module
    docstring), judged on the samples ``X`` (N, n), ``Y`` (N, m) and, for a scheduled model,
    ``S`` (N, na) — normally the data it learnt from. The model is changed in place; each
    merge is recorded as a ``merge`` history event (``rule_id`` the absorbed rule) at the
    model's current step. Returns the merges as ``{"kept", "absorbed"}`` rule ids."""
    if not model._fitted or model.rls == "global" or model.n_rules < 2:
        return []
    X = np.asarray(X, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(len(X), -1)
    A = X if S is None else np.asarray(S, dtype=float)
    shared = np.asarray(model.state_["sh"], dtype=bool)
    merges: list[dict[str, int]] = []
    while model.n_rules > 1:
        state = model.export_state()
        lead = model.leading_rule(A)
        var = [_residual_var(model, X, Y, lead, i) for i in range(model.n_rules)]
        scored = [(_wald_ratio(state, var, i, j, shared), i, j)
                  for i, j in _neighbours(model, state)]
        best = min(scored)
        if best[0] >= 1.0:
            break
        new, absorbed, kept = _merged(state, best[1], best[2], float(model.omega), shared)
        recorder = model.recorder_
        model.restore_state(new)  # (re-allocates the state and a fresh recorder)
        model.recorder_ = recorder
        recorder.add_event(new.samples, "merge", absorbed)
        merges.append({"kept": kept, "absorbed": absorbed})
    return merges
