"""Readable IF … THEN … rules in the original units of the data."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ets.model import ETS


def _num(v: float, precision: int) -> str:
    return f"{v:.{precision}g}"


def format_rules(model: ETS, precision: int = 4) -> str:
    """Render every live rule of ``model``.

    Each antecedent reads ``name ≈ centre (±half-width)``: the half-width r·s/2 is where
    the membership of that input alone falls to exp(-1). Consequents are rewritten from
    the normalised regressor to the original units: y = c_0 + sum_j c_j x_j.
    """
    if model.n_rules == 0:
        return "(no rules)"
    state = model.export_state()
    n, R, k = state.n_inputs, state.n_rules, state.samples
    xin, yout = model.names()
    s = model.scales()[:n]
    cons = model.consequents_raw()
    utility, age = state.utility(), state.age()
    lines = []
    for i in range(R):
        lines.append(
            f"Rule {i + 1} (id {int(state.rule_ids[i])}; support {int(state.support[i])}, "
            f"utility {utility[i]:.3f}, age {age[i]:.1f}, potential "
            f"{state.potentials[i]:.3f})"
        )
        ante = " AND ".join(
            f"{xin[j]} ≈ {_num(state.focal_points[i, j], precision)} "
            f"(±{_num(0.5 * state.radii[i, j] * s[j], precision)})"
            for j in range(n)
        )
        lines.append(f"  IF {ante}")
        for o in range(state.n_outputs):
            terms = [_num(cons[i, 0, o], precision)]
            for j in range(n):
                c = cons[i, j + 1, o]
                sign = "-" if c < 0 else "+"
                terms.append(f"{sign} {_num(abs(c), precision)}·{xin[j]}")
            lead = "THEN" if o == 0 else " AND"
            lines.append(f"  {lead} {yout[o]} = {' '.join(terms)}")
    return (
        "\n".join(lines)
        + "\n"
        + f"({R} rules after {k} samples; {np.sum(state.fixed)} fixed ranges)"
    )
