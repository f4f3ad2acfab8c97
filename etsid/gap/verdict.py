"""The verdict rules of ``etsid gap``, in one place (docs/gap.md, "Verdict rules").

Every rule is a small function with a test of its own (tests/gap/test_gap_verdict.py):

1. :func:`mismatched` — a channel is mismatched when its mean squared error on REAL is more
   than :data:`Z_MISMATCH` times its floor (RMSE above twice the floor).
2. :func:`can_be_consistent` — ``consistent`` only while *every* channel is within that
   threshold with nothing fitted, on all of REAL's evidence and on its held-out part.
3. :func:`worsened` — an effect is not kept if it raises any channel's held-out RMSE by
   more than that channel's floor (``√z_after − √z_before > WORSEN_Z``).
4. :func:`at_bound` — a fitted parameter at, or within :data:`BOUND_SHARE` of, a search
   bound that is not the law's "no effect" value is not a finding: the difference exceeds
   the vocabulary's range (another airframe, or a larger effect than modelled).
5. :func:`leftover` — after the named effects, every channel still mismatched on held-out
   data is reported with its size.
6. :func:`decide` — the verdict from the above: ``different-vehicle`` (evidence from
   :mod:`etsid.gap.vehicle_check`), ``consistent``, or ``mismatch``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from etsid.gap.candidates import Candidate

Z_MISMATCH = 4.0
"""A channel is mismatched when REAL's mean squared error is this many times its floor
(RMSE twice the floor)."""
Z_SMALL = 2.5
"""Small but structured tier: with no channel above :data:`Z_MISMATCH`, channels above this
are offered to the library, and only an effect that removes half their excess is kept."""
WORSEN_Z = 1.0
"""Largest rise of any channel's held-out RMSE, in units of its floor, an effect may cause:
its noise."""
BOUND_SHARE = 0.02
GEOMETRIC_RATIO = 20.0
"""A parameter within :data:`BOUND_SHARE` of its search range from a bound is at the bound;
for a range spanning more than :data:`GEOMETRIC_RATIO` times (a time constant from 3 ms to
0.5 s) within that share of the bound's own value."""

VERDICTS = ("consistent", "mismatch", "insufficient", "different-vehicle")


def mismatched(z: dict[str, float], threshold: float = Z_MISMATCH,
               exclude: tuple[str, ...] = ()) -> list[str]:
    """Channels whose z exceeds ``threshold``, largest first (``exclude``: never these)."""
    return [c for c, v in sorted(z.items(), key=lambda kv: -kv[1])
            if v > threshold and c not in exclude]


def can_be_consistent(z_all: dict[str, float], z_hold: dict[str, float]) -> bool:
    """Rule 2: nothing fitted, every channel within the threshold on all evidence and on
    the held-out part."""
    return not mismatched(z_all) and not mismatched(z_hold)


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


def at_bound(cand: Candidate, theta: np.ndarray) -> list[BoundHit]:
    """Rule 4: the parameters of ``cand`` that sit at a search bound. A bound equal to the
    law's no-effect value (zero delay, zero drag, zero offset) is not a range limit."""
    hits = []
    for p, v in zip(cand.params, np.asarray(theta, dtype=float), strict=True):
        for b in (p.lo, p.hi):
            if b == p.null:
                continue
            geometric = p.lo > 0 and p.hi / p.lo > GEOMETRIC_RATIO
            tol = BOUND_SHARE * (abs(b) if geometric else p.hi - p.lo)
            if abs(v - b) <= tol:
                hits.append(BoundHit(cand.name, p.name, float(v), float(b), p.unit))
    return hits


def leftover(z_after: dict[str, float], channels: list[str] | tuple[str, ...]
             ) -> dict[str, float]:
    """Rule 5: channel → held-out z, for the ``channels`` still above the threshold."""
    return {c: z_after[c] for c in channels if z_after.get(c, 0.0) > Z_MISMATCH}


def decide(different: list[str], consistent_ok: bool, named: list[str]) -> str:
    """Rule 6: the verdict.

    ``different`` is the different-airframe evidence; ``consistent_ok`` rule 2's answer;
    ``named`` the kept effects. A mismatch stays a mismatch whether or not anything
    explains it (its leftovers are said, rule 5).
    """
    if different:
        return "different-vehicle"
    if consistent_ok and not named:
        return "consistent"
    return "mismatch"
