"""The verdict rules of ``etsid gap``, in one place (docs/gap.md, "Verdict rules").

1. A channel is mismatched when its held-out innovations or its offset exceed the calibrated
   thresholds (:func:`etsid.gap.criterion.mismatched`, :mod:`etsid.gap.calibration`);
   ``consistent`` only when none is and no effect is named.
2. :func:`worsened` — an effect is not kept if it raises any channel's held-out RMSE by
   more than that channel's floor (``√z_after − √z_before > WORSEN_Z``).
3. :func:`at_bound` — a fitted parameter whose fit does not prefer it to a search bound
   that is not the law's "no effect" value (the objective there, the other parameters held,
   is no higher: the constrained optimum is on the bound) is not a finding: the difference
   exceeds the vocabulary's range (another airframe, or a larger effect than modelled).
4. A thrust or inertia scale beyond one airframe's faults, fitted or at its bound, says
   another vehicle (:data:`etsid.gap.likelihood.AIRFRAME_SCALES`), as does the airframe
   check of :mod:`etsid.gap.vehicle_check`.
5. After the named effects, every channel still mismatched on held-out data is reported
   with its size, and caps the named effects' confidence (a partial explanation).

The pair's detectable sizes are stated where rule 1 would fire (:mod:`etsid.gap.detectable`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from etsid.gap.candidates import Candidate

WORSEN_Z = 1.0
"""Largest rise of any channel's held-out RMSE, in units of its floor, an effect may cause:
its noise."""

VERDICTS = ("consistent", "mismatch", "insufficient", "different-vehicle")


def worsened(z_before: dict[str, float], z_after: dict[str, float]) -> dict[str, float]:
    """Rule 3: channel → rise of its held-out RMSE in units of its floor, for every channel
    whose RMSE rose by more than :data:`WORSEN_Z` floors (``√z_after − √z_before``)."""
    rise = {c: float(np.sqrt(max(z_after[c], 0.0)) - np.sqrt(max(z_before[c], 0.0)))
            for c in z_before if c in z_after}
    return {c: v for c, v in rise.items() if v > WORSEN_Z}


@dataclass(frozen=True)
class BoundHit:
    """A fitted parameter at its search bound."""

    effect: str
    parameter: str
    value: float
    bound: float
    unit: str

    def describe(self) -> str:
        """``thrust_scale scale = 0.41 at its bound 0.4``."""
        unit = f" {self.unit}" if self.unit not in ("", "1") else ""
        return (f"{self.effect} {self.parameter} = {self.value:.3g}{unit} at its bound "
                f"{self.bound:g}{unit}")


def at_bound(cand: Candidate, theta: np.ndarray, bound_cost: np.ndarray) -> list[BoundHit]:
    """Rule 3: the parameters of ``cand`` whose fit sits at a search bound: the fitting
    objective with the parameter moved to the bound (the others held) is no higher than
    at the fit (``bound_cost`` ≤ 0, rows per parameter, columns lower and upper bound,
    :attr:`etsid.gap.fitting.Fit.bound_cost`), so the bounded search stopped there (or
    short of it) and the data may lie beyond. An interior optimum, however close to a
    bound, costs more there. A bound equal to the law's no-effect value (zero delay, zero
    drag, zero offset) is not a range limit."""
    hits = []
    cost = np.asarray(bound_cost, dtype=float).reshape(len(cand.params), 2)
    for p, v, row in zip(cand.params, np.asarray(theta, dtype=float), cost, strict=True):
        for b, c in zip((p.lo, p.hi), row, strict=True):
            if b != p.null and np.isfinite(c) and c <= 0.0:
                hits.append(BoundHit(cand.name, p.name, float(v), float(b), p.unit))
    return hits
