"""Which model structure a flight supports, decided on the learning part; and how the
chosen eTS stands against the baselines on the validation part.

Candidates of the default rate model (``--structure auto``):

``scheduled``
    eTS with rules firing on ``--antecedent`` (default ``inv_alt[k-1]``; only when the log
    has altitude) — the model that can learn a regime change.
``unscheduled``
    eTS with rules on the regressors (radius 2, potential clustering: the pre-scheduling
    default).
``arx``
    eTS capped at one rule with a weak RLS prior (:data:`ARX_OMEGA`): one local linear
    model learnt by recursive least squares, i.e. ARX.

The learning part's last ``validate`` share of excited rows is an inner validation (as
:mod:`etsid.ident.attitude_check`); each candidate learns online on the rows before it and
is frozen and simulated over it. Criterion, fixed before any run: the mean free-run fit %
over the body-rate outputs that move in the inner validation (std ≥ 0.05 rad/s); the
simplest candidate (``arx`` < ``unscheduled`` < ``scheduled``) within :data:`MARGIN`
points of the best is chosen, so a structure must earn its rules. The same holds per output
of a chosen scheduled model: an output whose scheduling gains less than :data:`MARGIN`
points over one rule on the inner split (or that does not move there) gets one linear model
shared by every rule (``--unscheduled``; :func:`unpaid_outputs`). The validation part is
never looked at. When the learning part is too short for an inner split nothing can be
checked, and the simplest candidate (one rule, ARX) is taken and said to be unchecked. On
the validation part every candidate is scored and the chosen one is
compared with ARX and no-change persistence (:func:`behind_lines`).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from etsid.ets import ETS
from etsid.ets.merge import merge_rules
from etsid.ident.checks import split_excited
from etsid.ident.config import IdentConfig
from etsid.ident.metrics import fit_percent, rmse
from etsid.ident.ranges import fixed_ranges, schedule_range
from etsid.ident.regressors import Regression, RegressorSpec, build
from etsid.ident.simulate import envelope, free_run

ARX_OMEGA = 1e4
"""RLS initial covariance of the one-rule candidate, so that one rule learnt recursively is
ARX's least squares: identify's ω = 10³ shrinks coefficients that are large in normalised
units (yaw one-step RMSE +0.6–0.8 % over ARX on hover flights), 10⁴ is within 0.06 % of
ARX on validation and keeps the online start-up below online ARX's; 10⁶ (the classic
weak prior) adds a start-up of +5–11 % online (docs/identify.md, "Structure")."""
ORDER = ("arx", "unscheduled", "scheduled")
"""Candidates, simplest first."""
MARGIN = 0.5
"""Points of mean inner free-run fit a more complex structure must gain to be chosen."""
MIN_INNER_ROWS = 50
"""Fewest inner-validation rows for a decision; with fewer (or too few rows to learn on
before them) nothing can be checked and the simplest candidate, one rule (ARX), is kept."""
MOVING_STD = 0.05
"""Least std of an output in the inner validation to take part in the criterion, rad/s."""
BEHIND = 1.02
"""eTS one-step RMSE above this multiple of ARX's counts as behind it."""
NOISE_FLOOR = 0.85
"""ARX one-step RMSE at least this share of persistence's: nothing much to predict."""


@dataclass
class StructureChoice:
    """The structure chosen and the evidence."""

    chosen: str
    spec: RegressorSpec
    config: IdentConfig
    note: str
    inner: dict[str, dict[str, float]] = field(default_factory=dict)
    online: dict[str, tuple[ETS, np.ndarray]] = field(default_factory=dict, repr=False)
    """Each candidate's eTS as learnt online up to the inner validation (not merged, not
    frozen) and the times of the rows it learnt: :func:`validation_table` goes on learning
    it to the validation part instead of learning the same rows again."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (metrics.json ``structure``)."""
        return {"chosen": self.chosen, "inner_free_run_fit": self.inner, "note": self.note,
                "margin_points": MARGIN}


def candidate(name: str, spec: RegressorSpec, config: IdentConfig
              ) -> tuple[RegressorSpec, IdentConfig]:
    """Spec and config of candidate ``name``."""
    if name == "scheduled":
        return spec, config
    lean = replace(spec, antecedent=())
    loose = replace(config, antecedent="none", unscheduled="none",
                    blend=None if config.blend == "interpolate" else config.blend)
    return lean, (replace(loose, max_rules=1, omega=ARX_OMEGA) if name == "arx" else loose)


def _regression(reg: Regression, spec: RegressorSpec, end: int) -> Regression:
    return Regression(reg.X[:end], reg.Y[:end], reg.rows[:end], reg.t[:end], {},
                      None if reg.segment is None else reg.segment[:end],
                      reg.S[:end] if spec.antecedent and reg.S is not None else None,
                      reg.kinematics)


def untrained(reg: Regression, spec: RegressorSpec, config: IdentConfig, upto: int) -> ETS:
    """An empty eTS of ``spec``/``config`` with learning-part ranges of rows ``[0, upto)``."""
    scheduled = bool(spec.antecedent)
    x_range, y_range = fixed_ranges(reg, spec, upto, config.normalise)
    params = config.ets_params(scheduled, len(spec.antecedent_names or []))
    return ETS(**params, input_names=spec.input_names,
               output_names=list(spec.outputs), x_range=x_range, y_range=y_range,
               s_range=schedule_range(reg, spec, upto, config.normalise)
               if scheduled else None,
               antecedent_names=spec.antecedent_names,
               shared_outputs=config.shared_outputs(spec.outputs, scheduled))


def merged(model: ETS, reg: Regression, spec: RegressorSpec, config: IdentConfig,
           upto: int) -> ETS:
    """``model``, learnt on rows ``[0, upto)``, with indistinguishable rules merged (as
    identify does; in place)."""
    if config.merge is not False:  # the structure choice is for the rate model
        S = reg.S[:upto] if spec.antecedent else None
        merge_rules(model, reg.X[:upto], reg.Y[:upto], S)
    return model


def train(reg: Regression, spec: RegressorSpec, config: IdentConfig, upto: int) -> ETS:
    """An eTS of ``spec``/``config`` learnt online on rows ``[0, upto)`` with learning-part
    ranges of those rows (indistinguishable rules merged at the end, as identify does)."""
    model = untrained(reg, spec, config, upto)
    model.run(reg.X[:upto], reg.Y[:upto], reg.S[:upto] if spec.antecedent else None)
    return merged(model, reg, spec, config, upto)


def scores_on(model: ETS, reg: Regression, spec: RegressorSpec, start: int, n_table: int
              ) -> tuple[np.ndarray, np.ndarray]:
    """One-step and free-run predictions of ``model`` over rows ``start …`` of ``reg``."""
    S = reg.S[start:] if spec.antecedent else None
    one = np.asarray(model.predict(reg.X[start:], S)).reshape(len(reg.X) - start, -1)
    sim = free_run(model, reg, spec, start, n_table, envelope(reg.Y))
    return one, sim


def choose_structure(reg: Regression, spec: RegressorSpec, config: IdentConfig,
                     excited: np.ndarray, split: int, n_table: int) -> StructureChoice:
    """Choose the structure on the inner split of the learning part (module docstring)."""
    names = [n for n in ORDER if n != "scheduled" or spec.antecedent]
    inner = split_excited(excited[:split], config.validate or 0.3) if split > 0 else 0
    n_params = reg.X.shape[1] + 1
    if split - inner < MIN_INNER_ROWS or inner < 2 * n_params:
        c_spec, c_config = candidate("arx", spec, config)
        return StructureChoice("arx", c_spec, c_config,
                               "structure: one rule (ARX), the simplest, unchecked: the "
                               "learning part is too short for an inner split "
                               f"({inner} learning and {split - inner} checking rows; want "
                               f"≥ {2 * n_params} and ≥ {MIN_INNER_ROWS}), so no richer "
                               "structure could earn its place; --structure to force")
    fits: dict[str, dict[str, float]] = {}
    online: dict[str, tuple[ETS, np.ndarray]] = {}
    for name in names:
        c_spec, c_config = candidate(name, spec, config)
        sub = _regression(reg, c_spec, split)
        model = untrained(sub, c_spec, c_config, inner)
        model.run(sub.X[:inner], sub.Y[:inner], sub.S[:inner] if c_spec.antecedent else None)
        online[name] = (copy.deepcopy(model), sub.t[:inner])
        _, sim = scores_on(merged(model, sub, c_spec, c_config, inner), sub, c_spec, inner,
                           n_table)
        fits[name] = {y: fit_percent(sub.Y[inner:, o], sim[:, o])
                      for o, y in enumerate(spec.outputs)}
    moving = [o for o, y in enumerate(spec.outputs)
              if np.nanstd(reg.Y[inner:split, o]) >= MOVING_STD] or list(range(len(spec.outputs)))

    def mean(name: str) -> float:
        values = [fits[name][spec.outputs[o]] for o in moving]
        return float(np.mean(values)) if all(np.isfinite(values)) else -np.inf

    best = max(mean(n) for n in names)
    chosen = next(n for n in names if mean(n) >= best - MARGIN)
    c_spec, c_config = candidate(chosen, spec, config)
    text = ", ".join(f"{n} {mean(n):.1f}" for n in names)
    note = (f"structure: {chosen} eTS" if chosen != "arx" else "structure: one rule (ARX)") + \
        (f" chosen on an inner split of the learning part (mean free-run fit % of "
         f"{'/'.join(spec.outputs[o] for o in moving)}: {text}; the simplest within "
         f"{MARGIN:g} points of the best; --structure to force)")
    if chosen == "scheduled" and (config.unscheduled or "none").strip().lower() == "none":
        flat = unpaid_outputs(fits, spec.outputs, moving)
        if flat:
            c_config = replace(c_config, unscheduled=",".join(flat))
            gains = ", ".join(f"{y} {fits['scheduled'][y] - fits['arx'][y]:+.2f}" for y in flat)
            note += (f"; {', '.join(flat)} not scheduled: one linear model shared by every "
                     f"rule, the scheduling gaining less than {MARGIN:g} points of free-run "
                     f"fit on the inner split there ({gains}; --structure scheduled to "
                     "schedule every output)")
    return StructureChoice(chosen, c_spec, c_config, note, fits, online)


def unpaid_outputs(fits: dict[str, dict[str, float]], outputs: tuple[str, ...],
                   moving: list[int]) -> list[str]:
    """Outputs of a chosen scheduled model whose scheduling does not pay on the inner split:
    its free-run fit there is less than :data:`MARGIN` points above one rule's (ARX), or
    the output does not move there (no evidence). Empty when that would be every output
    (the scheduled model was chosen for some output's gain)."""
    flat = [y for o, y in enumerate(outputs)
            if o not in moving or not fits["scheduled"][y] >= fits["arx"][y] + MARGIN]
    return flat if len(flat) < len(outputs) else []


def _learnt_to(name: str, c_reg: Regression, c_spec: RegressorSpec, c_config: IdentConfig,
               c_split: int, online: dict[str, tuple[ETS, np.ndarray]]) -> ETS:
    """Candidate ``name`` learnt online on rows ``[0, c_split)`` of ``c_reg``, merged: the
    structure choice's model goes on learning from where it stopped when it learnt the same
    first rows (its ranges are then those of the rows before the inner validation), else
    it is learnt from the first row."""
    model, t_learnt = online.get(name, (None, None))
    done = 0 if t_learnt is None else len(t_learnt)
    if model is None or not (0 < done <= c_split and np.array_equal(c_reg.t[:done],
                                                                      t_learnt)):
        return train(c_reg, c_spec, c_config, c_split)
    model = copy.deepcopy(model)
    if c_split > done:
        model.run(c_reg.X[done:c_split], c_reg.Y[done:c_split],
                  c_reg.S[done:c_split] if c_spec.antecedent else None)
    return merged(model, c_reg, c_spec, c_config, c_split)


def validation_table(table: Any, reg: Regression, spec: RegressorSpec, config: IdentConfig,
                     chosen: str, split: int, cols: dict[str, np.ndarray],
                     requested: Regression | None = None,
                     online: dict[str, tuple[ETS, np.ndarray]] | None = None
                     ) -> dict[str, dict[str, dict[str, float | None]]]:
    """Validation one-step RMSE and free-run fit % per output of every candidate (the
    chosen one from ``cols``), ARX (batch LS) and persistence: ``{model: {y: {...}}}``.

    ``spec`` and ``config`` are the requested ones (before the choice), ``reg`` and
    ``split`` the chosen model's regression and first validation row; each other candidate
    learns on its own rows before the same validation start time, going on from the
    structure choice's ``online`` models where they learnt the same first rows.
    ``requested`` is ``build(table, spec)`` when the caller has it (it is not built
    again)."""
    out: dict[str, dict[str, dict[str, float | None]]] = {}
    built = [(candidate(chosen, spec, config)[0], reg)]  # arx and unscheduled share a spec
    if requested is not None:
        built.append((spec, requested))
    for name in (n for n in ORDER if n != "scheduled" or spec.antecedent):
        label = "eTS one rule" if name == "arx" else f"eTS {name}"
        if name == chosen:
            out[label] = _block(reg, split, cols["y_val"][split:], cols["y_sim"][split:], spec)
            continue
        c_spec, c_config = candidate(name, spec, config)
        c_reg = next((r for s, r in built if s == c_spec), None)
        if c_reg is None:
            c_reg = build(table, c_spec)
            built.append((c_spec, c_reg))
        c_split = int(np.searchsorted(c_reg.t, reg.t[split], side="left"))
        if not 0 < c_split < len(c_reg.t):
            continue
        model = _learnt_to(name, c_reg, c_spec, c_config, c_split, online or {})
        one, sim = scores_on(model, c_reg, c_spec, c_split, len(table))
        out[label] = _block(c_reg, c_split, one, sim, spec)
    out["ARX"] = _block(reg, split, cols["y_arx_val"][split:], cols["y_arx_sim"][split:], spec)
    out["no-change"] = _block(reg, split, cols["y_persist"][split:], None, spec)
    return out


def _block(reg: Regression, split: int, one: np.ndarray, sim: np.ndarray | None,
           spec: RegressorSpec) -> dict[str, dict[str, float | None]]:
    def clean(v: float) -> float | None:
        return float(v) if np.isfinite(v) else None

    return {y: {"one_step_rmse": clean(rmse(reg.Y[split:, o], one[:, o])),
                "free_run_fit": clean(fit_percent(reg.Y[split:, o], sim[:, o]))
                if sim is not None else None}
            for o, y in enumerate(spec.outputs)}


def _one_step(block: dict[str, Any]) -> tuple[dict[str, Any], Any, Any, Any]:
    one = (block.get("validation") or {}).get("one_step") or {}
    arx = ((block.get("arx") or {}).get("validation") or {}).get("one_step") or {}
    pers = (block.get("persistence") or {}).get("validation") or {}
    return one, one.get("rmse"), arx.get("rmse"), pers.get("rmse")


def fallbacks(outputs: dict[str, Any]) -> dict[str, str]:
    """Per informative output where the chosen eTS is behind a baseline on validation
    (one-step RMSE above :data:`BEHIND` × ARX's or above persistence's): the better of the
    two baselines, ``ARX`` or ``no-change``, which is this run's model for that axis."""
    out = {}
    for y, block in outputs.items():
        one, e, a, p = _one_step(block)
        if e is None or one.get("informative") is False:
            continue
        if (a is not None and e > BEHIND * a) or (p is not None and e > p):
            out[y] = "ARX" if a is not None and (p is None or a <= p) else "no-change"
    return out


def behind_lines(outputs: dict[str, Any], rules: int, excited_learn_s: float,
                 rate_hz: float, n_params: int) -> list[str]:
    """One line per informative output where the chosen eTS's validation one-step RMSE is
    above :data:`BEHIND` × ARX's or above persistence's, with the likely reason and the
    baseline this run uses for that axis instead (:func:`fallbacks`)."""
    lines = []
    used = fallbacks(outputs)
    for y, block in outputs.items():
        one, e, a, p = _one_step(block)
        if e is None or one.get("informative") is False:
            continue
        behind = []
        if a is not None and e > BEHIND * a:
            behind.append(f"ARX {a:.4g} ({e / a:.2f}×)")
        if p is not None and e > p:
            behind.append(f"no-change {p:.4g} ({e / p:.2f}×)")
        if not behind:
            continue
        std = one.get("signal_std")
        if excited_learn_s * rate_hz < 10 * n_params:
            why = (f"too little excitation: {excited_learn_s:.1f} s of excited learning data "
                   f"for {n_params} parameters per rule and output")
        elif std is not None and std < 2 * MOVING_STD:
            why = f"too little excitation in the validation part (std {std:.3g})"
        elif a is not None and p is not None and a >= NOISE_FLOOR * p:
            why = (f"noise floor: ARX is only {a / p:.2f}× no-change, the rest is noise or "
                   "input the log does not carry at this rate")
        elif rules > 1:
            why = (f"one regime only: {rules} rules split the learning data without a "
                   "physics difference (variance)")
        else:
            why = ("one regime only: one rule learnt recursively (RLS prior and start-up) "
                   "where batch least squares fits better")
        lines.append(f"warning: {y}: eTS validation one-step RMSE {e:.4g} is behind "
                     f"{' and '.join(behind)}; likely reason: {why}; {y} falls back to "
                     f"{used[y]} (metrics.json outputs.{y}.used)")
    return lines
