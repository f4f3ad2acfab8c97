"""NARX regressor specs and lag matrices that never straddle a gap.

A spec names the outputs (predicted at sample k) and the regressors, each a table
column at a lag: ``"co2[k-1],input_gas_rate[k-4]"``. A range ``u_roll[k-1..k-3]``
expands to three lags. Lag 0 (``u_roll[k]``) is allowed for inputs, never for outputs.

>>> spec = RegressorSpec.parse("co2[k-1],input_gas_rate[k-4]", outputs=["co2"])
>>> [str(term) for term in spec.terms]
['co2[k-1]', 'input_gas_rate[k-4]']
>>> spec.max_lag
4
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError
from etsid.ident.bare import bare
from etsid.table import SEGMENT

_TERM = re.compile(
    r"^\s*(?P<name>[A-Za-z_][A-Za-z0-9_.]*)\s*\[\s*k\s*(?:-\s*(?P<a>\d+))?\s*"
    r"(?:\.\.\s*k\s*(?:-\s*(?P<b>\d+))?\s*)?\]\s*$"
)


@dataclass(frozen=True)
class Term:
    """One regressor: column ``name`` at sample ``k - lag``."""

    name: str
    lag: int

    def __str__(self) -> str:
        return f"{self.name}[k-{self.lag}]" if self.lag else f"{self.name}[k]"


def _split_terms(text: str) -> list[str]:
    """Split on commas that are not inside brackets."""
    parts, depth, current = [], 0, []
    for char in text:
        if char == "[":
            depth += 1
        elif char == "]":
            depth -= 1
        if char == "," and depth == 0:
            parts.append("".join(current))
            current = []
        else:
            current.append(char)
    parts.append("".join(current))
    return [p for p in (s.strip() for s in parts) if p]


def parse_terms(text: str) -> list[Term]:
    """Parse ``"y[k-1],u[k-1..k-3]"`` into terms, in the order written.

    Raises
    ------
    IdentError
        A term that does not look like ``NAME[k-LAG]`` or ``NAME[k-A..k-B]``, or a repeat.
    """
    terms: list[Term] = []
    for part in _split_terms(text):
        match = _TERM.match(part)
        if match is None:
            raise IdentError(f"bad regressor {part!r}: write NAME[k-LAG] or NAME[k-A..k-B], "
                             "e.g. co2[k-1],input_gas_rate[k-4]")
        a = int(match["a"] or 0)
        b = a if match["b"] is None and ".." not in part else int(match["b"] or 0)
        step = 1 if b >= a else -1
        for lag in range(a, b + step, step):
            term = Term(match["name"], lag)
            if term in terms:
                raise IdentError(f"regressor {term} appears twice in {text!r}")
            terms.append(term)
    if not terms:
        raise IdentError("empty regressor spec: give at least one term, e.g. y[k-1]")
    return terms


ALT_FLOOR_M = 0.05
"""Altitudes below this (m) count as this in ``inv_alt`` (landing-gear height and below)."""

DERIVED: dict[str, str] = {"inv_alt": "alt"}
"""Derived columns a term may name, and the table column each is computed from.

``inv_alt`` = 1 / max(alt, :data:`ALT_FLOOR_M`), m⁻¹: the ground-effect coordinate. Every
image term of the ground-effect ratio decays like (R/z)² (docs/physics.md), so thrust and
control effectiveness change within a few rotor radii of the ground and not above: on the
range-normalised 1/z scale all heights out of ground effect lie close together and the
heights in it far apart, so a rule radius separates the two regimes (docs/identify.md).
"""


def column_values(table: pd.DataFrame, name: str) -> np.ndarray:
    """Values of column ``name`` of ``table``, or of the derived column (:data:`DERIVED`)."""
    if name == "inv_alt" and name not in table.columns:
        return 1.0 / np.maximum(table["alt"].to_numpy(dtype=float), ALT_FLOOR_M)
    return table[name].to_numpy(dtype=float)


@dataclass(frozen=True)
class RegressorSpec:
    """Outputs and lagged regressors of a NARX model.

    Parameters
    ----------
    outputs
        Columns predicted at sample k.
    terms
        Regressors in model-input order.
    """

    outputs: tuple[str, ...]
    terms: tuple[Term, ...]
    antecedent: tuple[Term, ...] = ()

    @classmethod
    def parse(cls, text: str, outputs: list[str] | tuple[str, ...],
              antecedent: str | None = None) -> RegressorSpec:
        """Spec from a regressor string and the output names.

        Raises
        ------
        IdentError
            Bad syntax, no outputs, or an output used at lag 0 (that would leak the answer).
        """
        outputs = tuple(outputs)
        if not outputs:
            raise IdentError("no output given: name at least one column to predict (--output)")
        if len(set(outputs)) != len(outputs):
            raise IdentError(f"output named twice: {', '.join(outputs)}")
        terms = tuple(parse_terms(text))
        for term in terms:
            if term.name in outputs and term.lag == 0:
                raise IdentError(f"regressor {term} is the output itself at k; use a lag ≥ 1")
        ante = tuple(parse_terms(antecedent)) if antecedent else ()
        for term in ante:
            if term.name in outputs:
                raise IdentError(f"antecedent {term} is an output; schedule on measured "
                                 "inputs such as alt[k-1],u_thrust[k-1]")
        return cls(outputs, terms, ante)

    @property
    def text(self) -> str:
        """Canonical spec string (one term per lag), parseable by :meth:`parse`."""
        return ",".join(str(t) for t in self.terms)

    @property
    def antecedent_text(self) -> str | None:
        """Canonical antecedent (scheduling) spec, None when the rules fire on the
        regressors."""
        return ",".join(str(t) for t in self.antecedent) or None

    @property
    def antecedent_names(self) -> list[str] | None:
        """Scheduling input names (None: not scheduled)."""
        return [str(t) for t in self.antecedent] or None

    @property
    def input_names(self) -> list[str]:
        """Model input names, one per term, e.g. ``p[k-1]``."""
        return [str(t) for t in self.terms]

    @property
    def columns(self) -> list[str]:
        """Table columns the spec needs (outputs first, no repeats)."""
        seen: dict[str, None] = dict.fromkeys(self.outputs)
        seen.update(dict.fromkeys(DERIVED.get(t.name, t.name) for t in self.terms))
        seen.update(dict.fromkeys(DERIVED.get(t.name, t.name) for t in self.antecedent))
        return list(seen)

    @property
    def max_lag(self) -> int:
        """Longest lag, samples."""
        return max(t.lag for t in (*self.terms, *self.antecedent))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form stored in rules.json and config.json."""
        out = {"outputs": list(self.outputs), "regressors": self.text,
               "lags": {str(t): t.lag for t in self.terms}}
        if self.antecedent:
            out["antecedent"] = self.antecedent_text
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RegressorSpec:
        """Inverse of :meth:`to_dict`."""
        try:
            return cls.parse(data["regressors"], data["outputs"], data.get("antecedent"))
        except (KeyError, TypeError) as err:
            raise IdentError(f"regressor spec needs 'outputs' and 'regressors', got {data!r}"
                             ) from err


@dataclass
class Regression:
    """Lag matrices built from a table.

    Attributes
    ----------
    X : ndarray, shape (N, n)
        Regressors of the usable rows.
    Y : ndarray, shape (N, m)
        Outputs of the usable rows, in the outputs' units.
    rows : ndarray of int, shape (N,)
        Positions of the usable rows in the table.
    t : ndarray, shape (N,)
        Time of each usable row, s.
    skipped : dict
        Table rows not used and why (``history`` = too close to the start of a segment,
        ``missing`` = NaN in a needed sample).
    segment : ndarray of int, shape (N,), optional
        Segment of each usable row (None: one segment).
    S : ndarray, shape (N, na), optional
        Scheduling inputs of the antecedents (None: the rules fire on ``X``).
    kinematics : ndarray, shape (n_table, 6), optional
        Time (s), measured ``roll pitch`` (rad) and ``p q r`` (rad/s) of every table row,
        when the model's attitude terms are integrated in free run (:func:`attitude_map`);
        the initial conditions of that integration.
    """

    X: np.ndarray
    Y: np.ndarray
    rows: np.ndarray
    t: np.ndarray
    skipped: dict[str, int] = field(default_factory=dict)
    segment: np.ndarray | None = None
    S: np.ndarray | None = None
    kinematics: np.ndarray | None = None

    @property
    def n_skipped(self) -> int:
        """Table rows without a full regressor history, total."""
        return int(sum(self.skipped.values()))


def check_columns(table: pd.DataFrame, names: list[str], what: str = "model") -> None:
    """Refuse a table that lacks ``names`` or has no data in them, listing what exists.

    Raises
    ------
    IdentError
        One line naming the missing columns and the columns the table has.
    """
    missing = [n for n in names if n not in table.columns]
    empty = [n for n in names if n in table.columns and not table[n].notna().any()]
    if missing or empty:
        have = ", ".join(c for c in table.columns if c != SEGMENT) or "none"
        problem = []
        if missing:
            problem.append(f"missing column(s) {', '.join(missing)}")
        if empty:
            problem.append(f"no data in {', '.join(empty)}")
        raise IdentError(f"the {what} needs {', '.join(names)}: {'; '.join(problem)}; "
                         f"the table has: {have}")


def segments_of(table: pd.DataFrame) -> np.ndarray:
    """Segment number of every row (all 0 when the table has no ``segment`` column)."""
    if SEGMENT in table.columns:
        return table[SEGMENT].to_numpy(dtype=np.int64)
    return np.zeros(len(table), dtype=np.int64)


def _lag_matrix(values: dict[str, np.ndarray], terms: Sequence[Term], n: int) -> np.ndarray:
    """The (n, len(terms)) matrix whose column j is ``lagged(values[name_j], lag_j)``,
    written in place (no column array per term, no stacking copy)."""
    out = np.full((n, len(terms)), np.nan)
    for j, term in enumerate(terms):
        v = values[term.name]
        if term.lag == 0:
            out[:, j] = v
        elif term.lag < n:
            out[term.lag:, j] = v[:-term.lag]
    return out


def lagged(values: np.ndarray, lag: int) -> np.ndarray:
    """``values`` shifted so that row k holds ``values[k - lag]`` (NaN where k < lag)."""
    out = np.full(values.shape, np.nan)
    if lag == 0:
        out[:] = values
    elif lag < values.shape[0]:
        out[lag:] = values[:-lag]
    return out


def build(table: pd.DataFrame, spec: RegressorSpec) -> Regression:
    """Lag matrices for ``spec``: a row is used only if every sample it needs is finite
    and lies in the same segment as the row itself.

    Raises
    ------
    IdentError
        Missing columns, or no usable row.
    """
    table = bare(table)  # (etsid.ident.bare)
    check_columns(table, spec.columns)
    n = len(table)
    seg = segments_of(table)
    idx = np.arange(n)
    first_of_segment = np.zeros(n, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
    first_of_segment = starts[np.searchsorted(starts, idx, side="right") - 1]
    history_ok = idx - spec.max_lag >= first_of_segment
    values: dict[str, np.ndarray] = {}
    for t in (*spec.terms, *spec.antecedent):
        if t.name not in values:
            values[t.name] = column_values(table, t.name)
    X = _lag_matrix(values, spec.terms, n)
    Y = table[list(spec.outputs)].to_numpy(dtype=float)
    S = _lag_matrix(values, spec.antecedent, n) if spec.antecedent else None
    finite = np.isfinite(X).all(axis=1) & np.isfinite(Y).all(axis=1)
    if S is not None:
        finite &= np.isfinite(S).all(axis=1)
    use = history_ok & finite
    skipped = {"history": int((~history_ok).sum()), "missing": int((history_ok & ~finite).sum())}
    if not use.any():
        raise IdentError(f"no row has a full regressor history ({spec.text}): "
                         f"{skipped['history']} rows too close to a segment start, "
                         f"{skipped['missing']} with NaN in a needed column")
    rows = idx[use]
    t = np.asarray(table.index, dtype=float)[rows]
    kinematics = None
    if attitude_map(spec):
        kinematics = np.column_stack([np.asarray(table.index, dtype=float)]
                                     + [table[c].to_numpy(dtype=float)
                                        for c in (*ATTITUDE_STATES, *RATES)])
        kinematics.flags.writeable = False  # shared by every free run (simulate.py caches)
    return Regression(X[use], Y[use], rows, t, skipped, seg[use],
                      None if S is None else S[use], kinematics)


def feedback_map(spec: RegressorSpec) -> list[tuple[int, int, int]]:
    """For free-run simulation: ``(term index, output index, lag)`` of every term that is a
    lagged output, to be replaced by the model's own past predictions."""
    out = list(spec.outputs)
    return [(i, out.index(t.name), t.lag) for i, t in enumerate(spec.terms) if t.name in out]


ATTITUDE_STATES = ("roll", "pitch")
"""Attitude columns (rad) that a model of the body rates ``p q r`` carries as states: in free
run their lagged terms are not measured but integrated from the simulated rates (ZYX Euler
kinematics), like the lagged outputs are fed back (:func:`attitude_map`)."""

RATES = ("p", "q", "r")


def attitude_map(spec: RegressorSpec) -> list[tuple[int, int, int]]:
    """For free-run simulation: ``(term index, angle index in ATTITUDE_STATES, lag)`` of every
    attitude term of a model whose outputs include ``p q r`` (empty otherwise: attitude
    terms of other models are exogenous inputs, taken from the table)."""
    if not set(RATES) <= set(spec.outputs):
        return []
    return [(i, ATTITUDE_STATES.index(t.name), t.lag) for i, t in enumerate(spec.terms)
            if t.name in ATTITUDE_STATES and t.lag >= 1]
