"""eTS normalisation ranges for ``--normalise``: fixed from the learning part, a priori, or
the eTS running min/max (docs/identify.md)."""

from __future__ import annotations

import numpy as np

from etsid.errors import IdentError
from etsid.ident.choices import NORMALISE_MODES as NORMALISE_MODES
from etsid.ident.column_bounds import column_bounds
from etsid.ident.regressors import Regression, RegressorSpec

RANGE_MARGIN = 0.05
"""Fixed ranges are widened by this fraction of their width on each side."""

APRIORI_RANGES = {"u_roll": (-1.0, 1.0), "u_pitch": (-1.0, 1.0), "u_yaw": (-1.0, 1.0),
                  "u_thrust": (0.0, 1.0)}
"""FlightTable contract ranges of the loop commands (``--normalise apriori``)."""

SCHEDULE_RANGES = {"inv_alt": (0.0, 5.0)}
"""Fixed ranges of scheduling terms (m⁻¹ for ``inv_alt``: every height from 0.2 m up), used
whatever the flight: a flight that stays at one height then keeps one rule instead of
being split by altitude noise over its own tiny range, and the radius means the same on
every flight."""


def learn_range(v: np.ndarray) -> tuple[float, float]:
    """[low, high] of learning-part values, widened by :data:`RANGE_MARGIN` of the width
    on each side; a (near-)constant column gets width 1 around its value (the eTS rule for
    a zero range) so that later excursions are not blown up."""
    v = v[np.isfinite(v)]
    if v.size == 0:
        return -0.5, 0.5
    return _widened(float(v.min()), float(v.max()))


def _widened(lo: float, hi: float) -> tuple[float, float]:
    """:func:`learn_range` of values whose min and max are ``lo`` and ``hi``."""
    width = hi - lo
    if width <= 1e-9 * max(1.0, abs(lo), abs(hi)):
        mid = 0.5 * (lo + hi)
        return mid - 0.5, mid + 0.5
    return lo - RANGE_MARGIN * width, hi + RANGE_MARGIN * width


def fixed_ranges(reg: Regression, spec: RegressorSpec, split: int,
                 mode: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """eTS ``x_range``, ``y_range`` for ``--normalise mode`` (None, None for ``running``).

    ``learn``: each regressor's and output's min/max over the learning part (the first
    ``split`` rows), widened by :data:`RANGE_MARGIN`. ``apriori``: regressors of the loop
    commands get :data:`APRIORI_RANGES` (the FlightTable contract), everything else as in
    ``learn``.
    """
    if mode not in NORMALISE_MODES:
        raise IdentError(f"--normalise {mode!r}: choose one of {', '.join(NORMALISE_MODES)}")
    if mode == "running":
        return None, None
    x_range, y_range = _columns_range(reg.X[:split]), _columns_range(reg.Y[:split])
    if mode == "apriori":
        for j, term in enumerate(spec.terms):
            if term.name in APRIORI_RANGES:
                x_range[j] = APRIORI_RANGES[term.name]
    return x_range, y_range


def _columns_range(A: np.ndarray) -> np.ndarray:
    """:func:`learn_range` of each column of ``A``, shape (n_columns, 2); min and max over
    the whole array at once when every value is finite (the same numbers, faster)."""
    if len(A) and A.ndim == 2:
        lo, hi, finite = column_bounds(A)
        if finite:
            return np.array([_widened(a, b) for a, b in
                             zip(lo.tolist(), hi.tolist(), strict=True)])
    return np.array([learn_range(A[:, j]) for j in range(A.shape[1])])


def schedule_range(reg: Regression, spec: RegressorSpec, split: int,
                   mode: str) -> np.ndarray | None:
    """eTS ``s_range`` of the scheduling inputs: :data:`SCHEDULE_RANGES` where a term has
    one, else (``learn``, ``apriori``) the learning-part min/max widened by
    :data:`RANGE_MARGIN`; for ``running`` the a-priori ranges when every term has one, else
    None (running min/max); None when the rules fire on the regressors. The radius of a
    scheduled model is a fraction of it."""
    if reg.S is None:
        return None
    if mode == "running":  # a-priori ranges are causal; the rest stays running
        known = [SCHEDULE_RANGES.get(term.name) for term in spec.antecedent]
        return None if None in known else np.array(known, dtype=float)
    S = reg.S[:split]
    return np.array([SCHEDULE_RANGES.get(term.name) or learn_range(S[:, j])
                     for j, term in enumerate(spec.antecedent)])
