"""A rule base read by a flight engineer: per rule its focal point in physical units and,
per output, the terms that dominate its consequent with their share.

The share of term j in output o of rule i is |θ_ijo| · (x_j,max − x_j,min) over the sum of
the same for every term: the part of the output's swing over the learnt input ranges that
the term can cause (the intercept is left out and given apart). Rules are numbered 1…N in
the order of rules.json, as ``etsid rules``, the report's tables and the identify summary
number them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from etsid.table import COLUMNS

DERIVED_UNITS = {"inv_alt": "1/m"}
"""Units of derived columns the regressor specs know."""

TOP = 4
"""Terms shown per output of a rule by default."""


@dataclass
class Term:
    """One consequent term: name, coefficient (original units) and share (0…1)."""

    name: str
    coefficient: float
    share: float


@dataclass
class RuleSummary:
    """One rule: 1-based number, id, focal point, support and the terms per output."""

    number: int
    rule_id: int
    focal: dict[str, float]
    support: int
    intercept: dict[str, float]
    terms: dict[str, list[Term]]


def unit_of(term: str) -> str:
    """Physical unit of a regressor term (``u_roll[k-1]`` → ``1``), '' when unknown."""
    name = term.split("[", 1)[0]
    if name in DERIVED_UNITS:
        return DERIVED_UNITS[name]
    spec = COLUMNS.get(name)
    return spec.unit if spec is not None else ""


def physical(name: str, value: float) -> str:
    """``inv_alt[k-1] ≈ 3.855 1/m (alt 0.259 m)``: a focal value with its unit."""
    unit = unit_of(name)
    text = f"{name} ≈ {value:.4g}" + (f" {unit}" if unit and unit != "1" else "")
    if name.startswith("inv_alt") and value > 0:
        text += f" (alt {1.0 / value:.3g} m)"
    return text


def summarize(rules: dict[str, Any], trusted: bool = False) -> list[RuleSummary]:
    """Every rule of a rules.json dict, its terms sorted by share (largest first);
    ``trusted``: skip the schema check (a rule base already checked or made by etsid).

    Raises
    ------
    EtsidError, ValueError, KeyError
        A rule base the model loader refuses.
    """
    from etsid.ets import ETS

    model = ETS.from_dict(rules, trusted=trusted)
    if model.n_rules == 0:
        return []
    state = model.export_state()
    inputs, outputs = model.names()
    antecedents = model.antecedents()
    cons = model.consequents_raw()  # (R, n + 1, m), row 0 the intercept
    swing = _input_swing(model, state, len(inputs))
    out = []
    for i in range(state.n_rules):
        terms = {}
        for o, y in enumerate(outputs):
            weight = np.abs(cons[i, 1:, o]) * swing
            total = float(weight.sum())
            order = np.argsort(-weight, kind="stable")
            terms[y] = [Term(inputs[j], float(cons[i, j + 1, o]),
                             float(weight[j] / total) if total > 0 else 0.0) for j in order]
        out.append(RuleSummary(
            i + 1, int(state.rule_ids[i]),
            {a: float(state.focal_points[i, j]) for j, a in enumerate(antecedents)},
            int(state.support[i]), {y: float(cons[i, 0, o]) for o, y in enumerate(outputs)},
            terms))
    return out


def _input_swing(model: Any, state: Any, n: int) -> np.ndarray:
    """max − min of each regressor: the fixed ranges the model was given, else the ones it
    learnt (z = [scheduling inputs,] regressors, outputs)."""
    if model.x_range is not None:
        ranges = np.asarray(model.x_range, dtype=float).reshape(n, 2)
        return np.abs(ranges[:, 1] - ranges[:, 0])
    offset = state.n_antecedents if state.scheduled else 0
    low = np.asarray(state.low, dtype=float)[offset:offset + n]
    high = np.asarray(state.high, dtype=float)[offset:offset + n]
    return np.nan_to_num(np.abs(high - low))


def _term_text(term: Term) -> str:
    return f"{term.coefficient:+.4g}·{term.name} ({100 * term.share:.0f} %)"


def readable(rules: dict[str, Any], top: int = TOP, width: int = 100,
             trusted: bool = False) -> str:
    """The rule base in short lines: per rule its focal point and, per output, the ``top``
    terms by share and what the others add up to (``trusted``: see :func:`summarize`)."""
    summaries = summarize(rules, trusted)
    if not summaries:
        return "(no rules)"
    lines = []
    for rule in summaries:
        focal = list(rule.focal.items())
        shown = " AND ".join(physical(n, v) for n, v in focal[:3])
        if len(focal) > 3:
            shown += f" AND {len(focal) - 3} more antecedent terms (--full)"
        lines.append(f"Rule {rule.number} (support {rule.support}): IF {shown}")
        for y, terms in rule.terms.items():
            head = f"  THEN {y} = {rule.intercept[y]:.4g}"
            parts = [_term_text(t) for t in terms[:top]]
            rest = terms[top:]
            if rest:
                parts.append(f"… {len(rest)} more terms "
                             f"({100 * sum(t.share for t in rest):.0f} %)")
            lines.extend(_wrap(head, parts, width))
    lines.append(f"({len(summaries)} rules; share = |θ| × input range over the sum of all "
                 "terms; every term: etsid rules --full)")
    return "\n".join(lines)


def _wrap(head: str, parts: list[str], width: int) -> list[str]:
    """``head`` followed by `` parts`` joined, wrapped at ``width`` with an indent."""
    lines, line = [], head
    for part in parts:
        if len(line) + 1 + len(part) > width and line.strip():
            lines.append(line)
            line = "      " + part
        else:
            line = f"{line} {part}"
    lines.append(line)
    return lines
