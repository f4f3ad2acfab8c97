"""The learned state of an :class:`~etsid.ets.ETS` model in public, named arrays.

:meth:`ETS.export_state <etsid.ets.ETS.export_state>` returns a :class:`LearnedState` of
read-only views (trimmed to the live rules); :meth:`ETS.restore_state
<etsid.ets.ETS.restore_state>` sets a model's state from one. The rule-base JSON
(:mod:`etsid.ets.serialize`) and the readable rules (:mod:`etsid.ets.text`) go through
them; the kernels' own layout is in :mod:`etsid.ets.layout`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LearnedState:
    """Everything an eTS model has learned, for R live rules, n inputs and m outputs
    (d = n + m). Units: "raw" means the original units of the data.

    Attributes
    ----------
    n_inputs, n_outputs
        n and m.
    y_1d
        The model was trained with 1-D ``Y`` (its predictions are then 1-D).
    samples
        Samples learned, k.
    next_rule_id
        Id the next new rule will get (ids are never reused).
    low, high : (d,)
        Normalisation range of z = [x; y], raw units.
    fixed : (d,)
        Nonzero where the range was given by the caller and is never widened.
    mean, m2 : (d,)
        Running mean and sum of squared deviations of z, raw units (Welford).
    rule_ids : (R,)
        Stable rule ids, in birth order.
    focal_points : (R, d)
        Focal points z*_i, raw units.
    radii : (R, n)
        Per-rule, per-input radius, normalised units.
    scatter : (R, n)
        Local scatter (variance, raw units squared) for exTS spreads.
    potentials : (R,)
        Focal potentials P_k(z*_i).
    births, support : (R,)
        Step at which each rule was born; samples for which it fired strongest.
    firing_sums, time_sums : (R,)
        Sum of normalised firing since birth (utility numerator); sum of the time indices
        of the supporting samples (age).
    consequents : (R, n+1, m)
        Consequents on x_e = [1, (x - low) / s] (normalised regressor).
    covariances : (R, n+1, n+1) or None
        Local RLS covariances (None with global RLS).
    global_covariance : (R(n+1), R(n+1)) or None
        Global RLS covariance (None with local RLS).
    scheduled
        The antecedents are on a separate scheduling vector s (na inputs); then
        z = [s; y; x], d = na + m + n, and radii / scatter have na columns.
    n_antecedents
        na (equals n when not scheduled; 0 means "same as n_inputs").
    shared_covariance : (n+1, n+1) or None
        RLS covariance of the shared outputs (``ETS(shared_outputs=…)``: one consequent
        common to every rule); None without shared outputs.
    """

    n_inputs: int
    n_outputs: int
    y_1d: bool
    samples: int
    next_rule_id: int
    low: np.ndarray
    high: np.ndarray
    fixed: np.ndarray
    mean: np.ndarray
    m2: np.ndarray
    rule_ids: np.ndarray
    focal_points: np.ndarray
    radii: np.ndarray
    scatter: np.ndarray
    potentials: np.ndarray
    births: np.ndarray
    support: np.ndarray
    firing_sums: np.ndarray
    time_sums: np.ndarray
    consequents: np.ndarray
    covariances: np.ndarray | None
    global_covariance: np.ndarray | None
    scheduled: bool = False
    n_antecedents: int = 0
    shared_covariance: np.ndarray | None = None

    @property
    def n_rules(self) -> int:
        """Number of live rules R."""
        return len(self.rule_ids)

    def utility(self) -> np.ndarray:
        """eTS+ utility of each rule: mean normalised firing since its birth, (R,)."""
        return self.firing_sums / (self.samples - self.births + 1.0)

    def age(self) -> np.ndarray:
        """eTS+ age of each rule: k minus the mean time index of its support, samples, (R,)."""
        return self.samples - self.time_sums / self.support
