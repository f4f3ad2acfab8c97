"""Flight regimes by height above ground, and what a rule base says about them.

Three things for metrics.json ``regimes`` (:func:`regime_summary`), rendered by
:mod:`etsid.report.regimes`:

* scores per regime on the validation part: one-step and free-run RMSE and fit of eTS and
  ARX on the rows of each altitude band (:func:`regime_metrics`);
* the rule → regime table: per rule of the frozen rule base its focal point in the
  antecedent variables, the altitude where it leads, support, birth time, lifetime and
  regime (:func:`rule_table`);
* one sentence of what the model learnt, from the rules' consequents
  (:func:`learnt_sentence`): the input gain of each rule's local ARX (the coefficient of
  the input's shortest lag: the response one sample after a unit command; see
  :func:`input_gains` for why not the sum or the static gain) compared between the rule at
  the lowest and the rule at the highest altitude.

Bands. When the rotor radius R is known (``table.attrs["rotor_radius_m"]``; the simulator
writes it) the bands are in z/R: *in ground effect* below z/R = 2 (one rotor diameter; the
Cheeseman–Bennett thrust gain 1 / (1 − (R/4z)²) is 1.6 % there and grows fast below),
*transition* from 2 to 4, *out of ground effect* from z/R = 4 (gain below 0.4 %). Otherwise
the bands are altitudes in metres (below 0.5 m, 0.5–1 m, above 1 m) and are named so: no
claim about ground effect is made without a rotor radius.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from etsid.ident.bare import bare
from etsid.ident.gain_ci import coefficient_se, ratio_interval, sign_interval
from etsid.ident.metrics import scores

IGE_BELOW_ZR = 2.0
"""z/R below which a rotor is in ground effect (one rotor diameter)."""
OGE_FROM_ZR = 4.0
"""z/R from which a rotor is out of ground effect (thrust gain below 0.4 %)."""
METRE_EDGES = (0.5, 1.0)
"""Altitude band edges, m, when the rotor radius is not known."""
ALTITUDE = "alt"
INV_ALTITUDE = "inv_alt"
"""The ground-effect coordinate 1/alt (1/m) the default model schedules its rules on."""
THRUST = "u_thrust"
"""Thrust command column (0 … 1) of the rule table's thrust column."""
#: the commanded input of each body rate in the default rate model
RATE_INPUTS = {"p": "u_roll", "q": "u_pitch", "r": "u_yaw"}
AXIS_WORDS = {"p": "roll", "q": "pitch", "r": "yaw"}


@dataclass(frozen=True)
class Bands:
    """Altitude bands of a flight.

    Attributes
    ----------
    basis : str
        ``"z/R"`` (rotor radius known) or ``"m"`` (altitude in metres).
    rotor_radius_m : float or None
        Rotor radius R, m.
    edges_m : tuple of float
        The two band edges as altitudes, m.
    names : tuple of str
        Band names, lowest first.
    labels : tuple of str
        Band ranges in words (``z/R < 2 (alt < 0.33 m)``, ``alt < 0.5 m`` …).
    """

    basis: str
    rotor_radius_m: float | None
    edges_m: tuple[float, float]
    names: tuple[str, str, str]
    labels: tuple[str, str, str]

    def of(self, alt: np.ndarray) -> np.ndarray:
        """Band index (0, 1, 2) of each altitude, m; −1 where the altitude is not finite."""
        alt = np.asarray(alt, dtype=float)
        out = np.searchsorted(np.asarray(self.edges_m), alt, side="right").astype(np.int64)
        out[~np.isfinite(alt)] = -1
        return out

    def name_of(self, alt: float | None) -> str | None:
        """The band name of one altitude, m (None when unknown)."""
        if alt is None or not math.isfinite(alt):
            return None
        return self.names[int(self.of(np.array([alt]))[0])]

    def to_dict(self) -> dict[str, Any]:
        """The bands for metrics.json."""
        low = (None, *self.edges_m)
        high = (*self.edges_m, None)
        return {"basis": self.basis, "rotor_radius_m": self.rotor_radius_m,
                "bands": [{"name": n, "label": lab, "alt_from_m": a, "alt_below_m": b}
                          for n, lab, a, b in zip(self.names, self.labels, low, high,
                                                  strict=True)]}


def rotor_radius(attrs: dict[str, Any]) -> float | None:
    """Rotor radius, m, from table attributes (``rotor_radius_m``), else None."""
    value = attrs.get("rotor_radius_m")
    if isinstance(value, (int, float)) and not isinstance(value, bool) and \
            math.isfinite(value) and value > 0:
        return float(value)
    return None


def bands_for(radius_m: float | None) -> Bands:
    """The altitude bands: in z/R when ``radius_m`` is known, else in metres."""
    if radius_m:
        a, b = IGE_BELOW_ZR * radius_m, OGE_FROM_ZR * radius_m
        return Bands("z/R", radius_m, (a, b),
                     ("in ground effect", "transition", "out of ground effect"),
                     (f"z/R < {IGE_BELOW_ZR:g} (alt < {a:.2f} m)",
                      f"{IGE_BELOW_ZR:g} ≤ z/R < {OGE_FROM_ZR:g} ({a:.2f}–{b:.2f} m)",
                      f"z/R ≥ {OGE_FROM_ZR:g} (alt ≥ {b:.2f} m)"))
    a, b = METRE_EDGES
    return Bands("m", None, (a, b), (f"below {a:g} m", f"{a:g}–{b:g} m", f"above {b:g} m"),
                 (f"alt < {a:g} m", f"{a:g} m ≤ alt < {b:g} m", f"alt ≥ {b:g} m"))


def _column(term: str) -> str:
    """The table column of a regressor term (``u_roll[k-2]`` → ``u_roll``)."""
    return re.sub(r"\[.*$", "", term)


MIN_REGIME_S = 5.0
"""Least validation time in a band, s, for its fit % to be informative."""
STILL_STD = 0.05
"""Least standard deviation of a body rate in a band's validation rows, rad/s, for its
fit % to be informative (the excitation threshold of :mod:`etsid.ident.flight`)."""
BODY_RATES = ("p", "q", "r")


def _informative(y: np.ndarray, name: str, seconds: float) -> tuple[bool, str | None]:
    """Whether a band's scores of output ``name`` mean something, and why not."""
    if seconds < MIN_REGIME_S:
        return False, f"too few samples ({seconds:.1f} s < {MIN_REGIME_S:g} s)"
    std = float(np.nanstd(y)) if np.isfinite(y).any() else 0.0
    if name in BODY_RATES and std < STILL_STD:
        return False, f"too still (std {std:.3g} rad/s < {STILL_STD:g})"
    return True, None


def regime_metrics(alt: np.ndarray, bands: Bands, Y: np.ndarray, outputs: list[str],
                   cols: dict[str, np.ndarray], split: int, t: np.ndarray | None = None
                   ) -> list[dict[str, Any]]:
    """Scores per altitude band on the validation rows (``split`` onwards).

    A band with less than :data:`MIN_REGIME_S` of validation data, or whose body rate moves
    less than :data:`STILL_STD` there, gets ``informative`` false, a ``reason``, and its
    fit % (and VAF, NDEI) as None, the number kept as ``fit_raw``: a fit of −408 % on 3 s
    of near-still data says nothing about the model.

    Parameters
    ----------
    alt
        Altitude of every regression row, m.
    Y
        Measured outputs (N, m).
    cols
        Prediction columns (:func:`etsid.ident.evaluate.prediction_columns`): ``y_val``,
        ``y_sim`` (eTS one-step, free-run), ``y_arx_val``, ``y_arx_sim``.
    """
    band = bands.of(alt)
    n = len(Y)
    learn = np.zeros(n, dtype=bool)
    learn[:split] = True
    out = []
    dt = float(np.median(np.diff(t))) if t is not None and len(t) > 1 else 0.0
    for b, name in enumerate(bands.names):
        rows = (band == b) & ~learn
        entry: dict[str, Any] = {"name": name, "label": bands.labels[b],
                                 "n_learn": int(np.count_nonzero((band == b) & learn)),
                                 "n_validation": int(np.count_nonzero(rows)), "outputs": {}}
        if rows.any():
            for o, y in enumerate(outputs):
                block: dict[str, Any] = {
                    key: scores(Y[rows, o], cols[col][rows, o])
                    for key, col in (("one_step", "y_val"), ("free_run", "y_sim"),
                                     ("arx_one_step", "y_arx_val"),
                                     ("arx_free_run", "y_arx_sim"))}
                seconds = np.count_nonzero(rows) * dt if dt else float("inf")
                ok, reason = _informative(Y[rows, o], y, seconds)
                if not ok:
                    for key in list(block):
                        sc = dict(block[key])
                        sc["fit_raw"] = sc.get("fit")
                        for field in ("fit", "vaf", "ndei"):
                            sc[field] = None
                        block[key] = sc
                block["informative"], block["reason"] = ok, reason
                entry["outputs"][y] = block
        out.append(entry)
    return out


def rule_table(rules: dict[str, Any], A: np.ndarray | None, alt: np.ndarray | None,
               t: np.ndarray, split: int, bands: Bands | None, learnt_here: bool = True,
               thrust: np.ndarray | None = None) -> list[dict[str, Any]]:
    """One entry per rule of the frozen rule base ``rules`` (a rules.json dict).

    Parameters
    ----------
    A
        The antecedent inputs of every regression row (the scheduling vector S of a
        scheduled model, else the regressors X), or None.
    alt
        Altitude of every row, m, or None when the log has none.
    t
        Time of every row, s.
    split
        Rows learned before the model was frozen.
    learnt_here
        False for a rule base applied to another flight (``etsid predict``): the rules lead
        over every row and their birth times (steps of the learning flight) are not given.
    thrust
        Thrust command ``u_thrust`` (0 … 1) of every row, or None.

    Each entry: ``rule`` (1-based, as ``etsid rules`` prints), ``id``, ``focal`` (antecedent
    name → focal value, raw units), ``alt_m`` and ``alt_source`` (the focal altitude when
    altitude or 1/altitude is an antecedent, else the median altitude of the learning rows
    the rule leads), ``thrust`` and ``thrust_source`` (the same for the thrust command),
    ``share`` (fraction of the learning rows it leads), ``support``, ``born_t`` (s),
    ``lifetime_s`` (from birth to the freeze), ``regime``.
    """
    from etsid.ets import ETS

    model = ETS.from_dict(rules, trusted=True)  # made or validated by identify/predict
    state = model.export_state()
    names = model.antecedents()
    na = len(names)
    R = state.n_rules
    focal = state.focal_points[:, :na]
    lead = np.full(0, -1)
    rows = split if learnt_here else (0 if A is None else len(A))
    if A is not None and rows > 0 and R:
        lead = model.leading_rule(A[:rows])
    alt_term = next((j for j, name in enumerate(names) if _column(name) == ALTITUDE), None)
    inv_term = next((j for j, name in enumerate(names) if _column(name) == INV_ALTITUDE),
                    None)
    thrust_term = next((j for j, name in enumerate(names) if _column(name) == THRUST), None)
    t_freeze = float(t[split - 1]) if split > 0 else float("nan")
    out = []
    for i in range(R):
        mine = lead == i
        if alt_term is not None:
            alt_m, source = float(focal[i, alt_term]), "focal"
        elif inv_term is not None and focal[i, inv_term] > 0:
            # the altitude of the focal point, as `etsid rules` and the rule book print it
            alt_m, source = 1.0 / float(focal[i, inv_term]), "focal"
        elif alt is not None and mine.any():
            alt_m, source = float(np.nanmedian(alt[:rows][mine])), "led rows"
        else:
            alt_m, source = None, None
        if thrust_term is not None:
            thrust_v, thrust_source = float(focal[i, thrust_term]), "focal"
        elif thrust is not None and mine.any() and np.isfinite(thrust[:rows][mine]).any():
            thrust_v, thrust_source = float(np.nanmedian(thrust[:rows][mine])), "led rows"
        else:
            thrust_v, thrust_source = None, None
        birth = int(state.births[i])  # 1-based sample counter
        born_t = float(t[min(max(birth - 1, 0), len(t) - 1)]) if len(t) and learnt_here \
            else None
        out.append({
            "rule": i + 1, "id": int(state.rule_ids[i]),
            "focal": {name: float(focal[i, j]) for j, name in enumerate(names)}
            if na <= 4 else {},
            "n_antecedents": na,
            "alt_m": alt_m, "alt_source": source,
            "thrust": thrust_v, "thrust_source": thrust_source,
            "share": float(np.mean(mine)) if lead.size else None,
            "support": int(state.support[i]),
            "born_t": born_t,
            "lifetime_s": t_freeze - born_t if born_t is not None else None,
            "regime": (("whole flight" if bands is not None else "whole record") if R == 1 else
                       bands.name_of(alt_m) if bands is not None else None),
        })
    return out


def _lag(term: str) -> int:
    """The lag of a regressor term in samples (``u[k-3]`` → 3, ``u[k]`` → 0)."""
    found = re.search(r"\[k(?:-(\d+))?\]", term)
    return int(found.group(1) or 0) if found else 0


def input_gains(rules: dict[str, Any]) -> list[dict[str, Any]]:
    """Input gains of every rule's local ARX for each output/input pair (original units:
    output unit per input unit). Inputs are the regressor columns that are not outputs.

    ``per_rule``: the coefficient of the input's shortest lag — the response one sample
    after a unit command, the control effectiveness the rule has learnt. ``sum_per_rule``:
    the sum over every lag. The sentence uses the first: with an attitude loop closed
    around the sticks a held stick gives an angle, not a rate, so the sum of the input
    coefficients (and the static gain) of a rate model is close to zero, and a ratio of
    two such sums is noise.
    """
    from etsid.ets import ETS

    model = ETS.from_dict(rules, trusted=True)  # made or validated by identify/predict
    inputs, outputs = model.names()
    cons = model.consequents_raw()  # (R, n + 1, m)
    columns = [_column(x) for x in inputs]
    out = []
    for o, y in enumerate(outputs):
        for u in dict.fromkeys(c for c in columns if c not in outputs):
            idx = [j for j, c in enumerate(columns) if c == u]
            first = min(idx, key=lambda j: _lag(inputs[j])) + 1
            out.append({"output": y, "input": u, "term": inputs[first - 1],
                        "per_rule": [float(v) for v in cons[:, first, o]],
                        "sum_per_rule": [float(v) for v in
                                         cons[:, [j + 1 for j in idx], o].sum(axis=1)]})
    return out


def _pairs(gains: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The pair of each output worth a sentence: its commanded input in the rate model,
    else the input with the largest mean |gain|."""
    chosen = []
    for y in dict.fromkeys(g["output"] for g in gains):
        mine = [g for g in gains if g["output"] == y]
        match = [g for g in mine if RATE_INPUTS.get(y) == g["input"]]
        chosen.append(match[0] if match else
                      max(mine, key=lambda g: float(np.mean(np.abs(g["per_rule"])))))
    return chosen


def _ratio(low: float, high: float) -> float | None:
    if high == 0 or low * high <= 0:
        return None
    return low / high


MIN_ROWS_PER_PARAM = 10
"""A rule takes part in the sentence when it leads at least this many learning rows per
consequent parameter (the same 10 per parameter as the learning part's warning)."""


def _supported(table: list[dict[str, Any]], min_rows: int, n_learn: int
               ) -> list[dict[str, Any]]:
    return [r for r in table
            if r.get("share") is not None and r["share"] * n_learn >= min_rows]


def _interval_text(ci: tuple[float, float]) -> str:
    return f"95 % interval {ci[0]:.2f}–{ci[1]:.2f}×"


def learnt_sentence(table: list[dict[str, Any]], gains: list[dict[str, Any]],
                    bands: Bands | None, se: dict[tuple[str, str], list[float]] | None = None,
                    min_rows: int = 0, n_learn: int = 0) -> tuple[str, dict[str, Any]]:
    """One plain sentence of what the rule base learnt (see the module docstring), and its
    facts for metrics.json (``learnt``: whether a regime difference is claimed, ``ratio``,
    ``ratio_ci``, ``rules_compared``, ``reason``).

    Only rules leading ≥ ``min_rows`` of the ``n_learn`` learning rows are compared; a
    difference is claimed only when the 95 % interval of the gain ratio (``se``: standard
    error per (output, input) and rule, :mod:`etsid.ident.gain_ci`) excludes 1; a change of
    sign is flagged as physically implausible, not reported."""
    pairs = _pairs(gains)
    facts: dict[str, Any] = {"learnt": False, "ratio": None, "ratio_ci": None,
                             "rules_compared": None, "reason": None}
    if not table:
        return "The rule base holds no rules.", {**facts, "reason": "no rules"}
    if len(table) == 1 or not pairs:
        if not pairs:
            return ("One rule: the model found one regime (no input to compare).",
                    {**facts, "reason": "one rule"})
        g = pairs[0]
        what = "flight" if bands is not None else "record"
        return (f"One rule: the model found one regime — a single linear model over the whole "
                f"{what} ({_words(g)} {g['per_rule'][0]:.3g} per unit {g['input']} one step "
                "after it).", {**facts, "reason": "one rule"})
    strong = _supported(table, min_rows, n_learn) if min_rows else table
    if len(strong) < 2:
        only = (f"only rule {strong[0]['rule']} leads" if strong else "no rule leads")
        return (f"{len(table)} rules, but {only} enough learning samples (≥ {min_rows}, "
                f"{MIN_ROWS_PER_PARAM} per consequent parameter) to be compared: no regime "
                "difference learnt.", {**facts, "reason": "too little support"})
    placed = [r for r in strong if r["alt_m"] is not None]
    if len(placed) < 2:
        key, what = _first_antecedent(strong)
        if key is None:
            return (f"{len(table)} rules, but neither altitude nor a scheduling variable to "
                    "place them by: the rules cannot be compared by regime.",
                    {**facts, "reason": "no placement"})
        order = sorted(strong, key=lambda r: r["focal"][key])
        lo, hi = order[0], order[-1]
        where_lo = f"at {what} {lo['focal'][key]:.3g} (rule {lo['rule']})"
        where_hi = f"at {what} {hi['focal'][key]:.3g} (rule {hi['rule']})"
    else:
        order = sorted(placed, key=lambda r: r["alt_m"])
        lo, hi = order[0], order[-1]
        where_lo, where_hi = _place(lo, bands), _place(hi, bands)
    i, j = lo["rule"] - 1, hi["rule"] - 1
    facts["rules_compared"] = [lo["rule"], hi["rule"]]
    count = f"{len(table)} rules, {len(strong)} with enough support"
    results = []
    for g in pairs:
        a, b = g["per_rule"][i], g["per_rule"][j]
        errs = (se or {}).get((g["output"], g["input"]))
        ci = ratio_interval(a, errs[i], b, errs[j]) if errs is not None else None
        flip = a * b < 0 and (errs is None or (sign_interval(a, errs[i])
                                                and sign_interval(b, errs[j])))
        results.append((g, _ratio(a, b), ci, flip))
    g, ratio, ci, flip = results[0]
    subject = f"{_words(g)} per unit {g['input']}"
    if flip or ratio is None:
        facts["reason"] = "sign change (implausible)"
        return (f"Not learnt: the {subject} has opposite signs {where_lo} and {where_hi} — "
                "physically implausible for a control effectiveness, so no regime difference "
                f"is reported ({count}).", facts)
    facts["ratio"], facts["ratio_ci"] = ratio, list(ci) if ci else None
    others, flat = [], []
    for g2, r2, ci2, flip2 in results[1:]:
        name = AXIS_WORDS.get(g2["output"], g2["output"])
        if flip2 or r2 is None:
            others.append(f"{name} changes sign (implausible)")
        elif ci2 is not None and (ci2[0] > 1 or ci2[1] < 1):
            others.append(f"{name} {r2:.2f}× ({ci2[0]:.2f}–{ci2[1]:.2f})")
        else:
            flat.append(name)
    if flat:
        others.append(f"{' and '.join(flat)} no difference beyond "
                      f"{'its' if len(flat) == 1 else 'their'} interval"
                      f"{'' if len(flat) == 1 else 's'}")
    tail = f"{count}; low/high: {', '.join(others)}" if others else count
    if ci is None or not (ci[0] > 1 or ci[1] < 1):
        facts["reason"] = ("no interval" if ci is None else "within the interval")
        interval = f" ({_interval_text(ci)}, which includes 1; {tail})" if ci else \
            f" (no interval; {tail})"
        return (f"No regime difference learnt: the {subject} {where_lo} is ×{ratio:.2f} the "
                f"one {where_hi}{interval}.", facts)
    facts["learnt"] = True
    factor = ratio if ratio >= 1 else 1.0 / ratio
    size = f"{factor:.2f}× {'larger' if ratio >= 1 else 'smaller'}"
    return (f"{subject[0].upper()}{subject[1:]} is {size} {where_lo} than {where_hi} "
            f"(ratio {ratio:.2f}, {_interval_text(ci)}; {tail}).", facts)


def _words(gain: dict[str, Any]) -> str:
    y = gain["output"]
    return f"{AXIS_WORDS[y]}-rate response" if y in AXIS_WORDS else f"{y} response"


def _place(rule: dict[str, Any], bands: Bands | None) -> str:
    regime = f"{rule['regime']}, " if rule.get("regime") and bands is not None \
        and bands.basis == "z/R" else ""
    return f"at {rule['alt_m']:.2f} m ({regime}rule {rule['rule']})"


def _first_antecedent(table: list[dict[str, Any]]) -> tuple[str | None, str]:
    focal = table[0].get("focal") or {}
    if not focal:
        return None, ""
    key = next(iter(focal))
    return key, key


def regime_summary_of(rules: dict[str, Any] | None, table: Any, reg: Any, outputs: list[str],
                      cols: dict[str, np.ndarray], split: int, learnt_here: bool = True,
                      rotor_radius_m: float | None = None) -> dict[str, Any]:
    """:func:`regime_summary` for a run: altitude, thrust command and antecedent inputs
    taken from ``table`` (the identification table) at the rows of ``reg`` (its
    :class:`etsid.ident.regressors.Regression`); ``rotor_radius_m`` (m) stands in for the
    table's own when given."""
    columns = bare(table)  # (no copy of the attrs per column read)

    def at_rows(column: str) -> np.ndarray | None:
        return (columns[column].to_numpy(dtype=float)[reg.rows]
                if column in columns.columns else None)

    attrs = table.attrs if rotor_radius_m is None else {**table.attrs,
                                                        "rotor_radius_m": rotor_radius_m}
    return regime_summary(rules, at_rows(ALTITUDE), attrs,
                          reg.X if reg.S is None else reg.S, reg.t, reg.Y, outputs, cols,
                          split, learnt_here, at_rows(THRUST), X=reg.X)


def regime_summary(rules: dict[str, Any] | None, alt: np.ndarray | None,
                   attrs: dict[str, Any], A: np.ndarray | None, t: np.ndarray, Y: np.ndarray,
                   outputs: list[str], cols: dict[str, np.ndarray], split: int,
                   learnt_here: bool = True, thrust: np.ndarray | None = None,
                   X: np.ndarray | None = None) -> dict[str, Any]:
    """metrics.json ``regimes``: bands, scores per band, the rule → regime table, the input
    gains per rule and the sentence (see the module docstring).

    ``alt`` (m, one per regression row) None: no altitude in the log, so no bands (the
    rule table and the sentence are still given). ``thrust`` (``u_thrust`` per regression
    row, or None) fills the rule table's thrust column. ``X`` (the regressors) gives the
    consequents' standard errors for the sentence's interval. The sentence describes what a
    run learnt: a rule base applied to another flight (``learnt_here`` False) gets none."""
    bands = bands_for(rotor_radius(attrs)) if alt is not None and np.isfinite(alt).any() \
        else None
    out: dict[str, Any] = {"basis": None, "rotor_radius_m": None, "bands": [],
                           "per_regime": [], "rules": [], "gains": [], "sentence": None}
    if bands is not None:
        out.update(bands.to_dict())
        out["per_regime"] = regime_metrics(alt, bands, Y, outputs, cols, split, t)
        out["note"] = ("bands by altitude over rotor radius z/R (rotor radius "
                       f"{bands.rotor_radius_m:g} m)" if bands.basis == "z/R" else
                       "rotor radius unknown: bands are altitudes in metres, not ground-"
                       "effect regimes")
    else:
        out["note"] = "no altitude in the log: no regimes"
    if rules and rules.get("rules"):
        out["rules"] = rule_table(rules, A, alt if bands is not None else None, t, split,
                                  bands, learnt_here, thrust)
        out["gains"] = input_gains(rules)
        out["gain_kind"] = ("the coefficient of the input's shortest lag in the rule's "
                            "consequent (the response one sample after a unit command)")
        if learnt_here:
            out["sentence"], out["sentence_facts"] = _sentence(rules, out, bands, A, X, Y,
                                                               split)
    return out


def _sentence(rules: dict[str, Any], out: dict[str, Any], bands: Bands | None,
              A: np.ndarray | None, X: np.ndarray | None, Y: np.ndarray, split: int
              ) -> tuple[str, dict[str, Any]]:
    """The learnt sentence with the support threshold and the gains' standard errors."""
    se = None
    n_params = None
    if X is not None and A is not None and split > 0 and len(out["rules"]) > 1:
        from etsid.ets import ETS

        lead = ETS.from_dict(rules, trusted=True).leading_rule(A[:split])
        errs = coefficient_se(rules, X[:split], Y[:split], lead)
        n_params = X.shape[1] + 1
        if errs is not None:
            se = {}
            inputs = [g["term"] for g in out["gains"]]
            names = list(rules.get("inputs") or [])
            outs = list(rules.get("outputs") or [])
            for g, term in zip(out["gains"], inputs, strict=True):
                if term in names and g["output"] in outs:
                    se[(g["output"], g["input"])] = [
                        float(v) for v in errs[:, names.index(term) + 1,
                                               outs.index(g["output"])]]
    min_rows = MIN_ROWS_PER_PARAM * n_params if n_params else 0
    return learnt_sentence(out["rules"], out["gains"], bands, se, min_rows, split)
