"""Blocked validation across the excited flight, and whether the held-out tail informs.

identify's validation part is the tail of the excited rows (:func:`etsid.ident.checks.
split_excited`): the frozen model of rules.json is judged there. A flight whose tail is a
near-still hover is judged on noise. Two things here:

- :func:`tail_informs`: per body rate, whether the tail moves: its standard deviation is
  at least :data:`STILL_SHARE` of the whole airborne flight's and at least the excitation
  threshold (:data:`etsid.ident.flight.EXCITE_STD`);
- :func:`blocked_validation`: :data:`N_BLOCKS` blocks spread over the excited rows, the
  first after :data:`FIRST_BLOCK` of them. **Each block is scored by the model learnt on
  every row before it**: one online pass from the first row, copied, merged and frozen at
  each block's start (as identify freezes its model), with the normalisation ranges of the
  rows before the first block. Learning stays online and causal, no block is scored by a
  model that saw it, and the flight is learnt once, not once per block. ARX is fitted by
  least squares on the same rows; no-change is the previous sample. Scores pool the blocks'
  rows (one-step RMSE) or average the blocks (free-run fit %).

When neither the tail nor any block moves on an axis, the flight cannot be validated on it
(:func:`not_validated_line`).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from etsid.ident.arx import ARX
from etsid.ident.config import IdentConfig
from etsid.ident.metrics import fit_percent
from etsid.ident.regressors import Regression, RegressorSpec
from etsid.ident.simulate import envelope, free_run
from etsid.ident.structure import BEHIND, merged, untrained

N_BLOCKS = 3
"""Validation blocks spread over the excited flight."""
FIRST_BLOCK = 0.4
"""Share of the excited rows learnt before the first block starts (the rest is spread
evenly: with ``--validate 0.3`` the blocks hold the excited rows 40–50, 60–70 and
80–90 %)."""
STILL_SHARE = 0.2
"""A validation part whose body-rate standard deviation is below this share of the whole
airborne flight's is still on that axis: its numbers describe noise (issue 41's three
flights validated on hover: 8–18 %)."""
RATES = ("p", "q", "r")


def block_bounds(excited: np.ndarray, validate: float, n_blocks: int = N_BLOCKS
                 ) -> list[tuple[int, int]]:
    """``[start, end)`` rows of each block: block k holds the excited rows from quantile
    ``FIRST_BLOCK + k (1 − FIRST_BLOCK) / n_blocks`` on, ``validate / n_blocks`` of them
    (and the still rows between them); none without excited rows or ``validate``."""
    idx = np.flatnonzero(excited)
    if idx.size < 2 * n_blocks or validate <= 0:
        return []
    out = []
    for k in range(n_blocks):
        q0 = FIRST_BLOCK + k * (1.0 - FIRST_BLOCK) / n_blocks
        a = int(idx[min(idx.size - 1, int(q0 * idx.size))])
        b = int(idx[min(idx.size - 1, int((q0 + validate / n_blocks) * idx.size))])
        if b > a:
            out.append((a, b))
    return out


def tail_informs(reg: Regression, spec: RegressorSpec, split: int, motion_min: float
                 ) -> dict[str, dict[str, float | bool]]:
    """Per body-rate output: ``std_tail``, ``std_flight`` (rad/s) and ``informs``
    (``std_tail`` ≥ max(``motion_min``, :data:`STILL_SHARE` × ``std_flight``))."""
    out: dict[str, dict[str, float | bool]] = {}
    for o, y in enumerate(spec.outputs):
        if y not in RATES or split >= len(reg.Y):
            continue
        tail, whole = float(np.nanstd(reg.Y[split:, o])), float(np.nanstd(reg.Y[:, o]))
        out[y] = {"std_tail": tail, "std_flight": whole,
                  "informs": bool(tail >= max(motion_min, STILL_SHARE * whole))}
    return out


def _rmse(e: np.ndarray) -> float | None:
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e ** 2))) if e.size else None


def _truncated(reg: Regression, spec: RegressorSpec, end: int) -> Regression:
    return Regression(reg.X[:end], reg.Y[:end], reg.rows[:end], reg.t[:end], {},
                      None if reg.segment is None else reg.segment[:end],
                      reg.S[:end] if spec.antecedent and reg.S is not None else None,
                      reg.kinematics)


def blocked_validation(reg: Regression, spec: RegressorSpec, config: IdentConfig,
                       excited: np.ndarray, validate: float, n_table: int,
                       persist: np.ndarray, motion_min: float) -> dict[str, Any] | None:
    """Scores of the blocks (module docstring): ``{"blocks": [...], "outputs": {y: {...}}}``
    or None when the flight has no blocks (too few excited rows, ``--validate 0``)."""
    bounds = block_bounds(excited, validate)
    if not bounds or bounds[0][0] <= reg.X.shape[1] + 1:
        return None
    m = len(spec.outputs)
    err = {k: [[] for _ in range(m)] for k in ("ets", "arx", "no-change")}
    fits: dict[str, list[list[float]]] = {k: [[] for _ in range(m)] for k in ("ets", "arx")}
    moving = [[] for _ in range(m)]
    blocks = []
    limits = envelope(reg.Y)
    online = untrained(reg, spec, config, bounds[0][0])
    learnt = 0
    for a, b in bounds:
        sub = _truncated(reg, spec, b)
        if a > learnt:
            online.run(reg.X[learnt:a], reg.Y[learnt:a],
                       reg.S[learnt:a] if spec.antecedent else None)
            learnt = a
        model = merged(copy.deepcopy(online), reg, spec, config, a)
        S = sub.S[a:b] if spec.antecedent and sub.S is not None else None
        one = np.asarray(model.predict(sub.X[a:b], S)).reshape(b - a, m)
        sim = free_run(model, sub, spec, a, n_table, limits)
        arx = ARX.fit(reg.X[:a], reg.Y[:a])
        arx_one = arx.predict(reg.X[a:b])
        arx_sim = free_run(arx, sub, spec, a, n_table, limits)
        y = reg.Y[a:b]
        for o in range(m):
            err["ets"][o].append(y[:, o] - one[:, o])
            err["arx"][o].append(y[:, o] - arx_one[:, o])
            err["no-change"][o].append(y[:, o] - persist[a:b, o])
            fits["ets"][o].append(fit_percent(y[:, o], sim[:, o]))
            fits["arx"][o].append(fit_percent(y[:, o], arx_sim[:, o]))
            moving[o].append(float(np.nanstd(y[:, o])))
        blocks.append({"t_start": float(reg.t[a]), "t_end": float(reg.t[b - 1]),
                       "rows": b - a, "rules": model.n_rules,
                       "ets_one_step_rmse": {name: _rmse(y[:, o] - one[:, o])
                                             for o, name in enumerate(spec.outputs)}})

    def pooled(parts: list[np.ndarray]) -> float | None:
        return _rmse(np.concatenate(parts))

    def mean(values: list[float]) -> float | None:
        v = [x for x in values if np.isfinite(x)]
        return float(np.mean(v)) if v else None

    outputs = {}
    for o, y in enumerate(spec.outputs):
        std = float(np.sqrt(np.mean(np.square(moving[o]))))
        outputs[y] = {"one_step_rmse": {k: pooled(err[k][o]) for k in err},
                      "free_run_fit": {k: mean(fits[k][o]) for k in fits},
                      "signal_std": std,
                      "informative": bool(y not in RATES or std >= motion_min)}
    return {"blocks": blocks, "outputs": outputs, "n_blocks": len(blocks),
            "first_block_share": FIRST_BLOCK}


def blocked_line(blocked: dict[str, Any]) -> str:
    """One line: the blocks and each output's pooled one-step RMSE eTS / ARX / no-change."""
    spans = ", ".join(f"{b['t_start']:.1f}–{b['t_end']:.1f}" for b in blocked["blocks"])
    parts = []
    for y, o in blocked["outputs"].items():
        r = o["one_step_rmse"]
        text = " / ".join(f"{r[k]:.4g}" if r[k] is not None else "–"
                          for k in ("ets", "arx", "no-change"))
        parts.append(f"{y} {text}" + ("" if o["informative"] else " (n.i.)"))
    return (f"blocked validation ({blocked['n_blocks']} blocks [{spans} s], each scored by "
            f"the model learnt before it): one-step RMSE eTS / ARX / no-change "
            + "; ".join(parts))


def not_validated_line(tail: dict[str, dict[str, Any]],
                       blocked: dict[str, Any] | None) -> str | None:
    """``not validated: …`` when no body rate moves in the tail nor in any block; None
    when some axis can be judged."""
    if not tail or any(v["informs"] for v in tail.values()):
        return None
    if blocked is not None and any(blocked["outputs"][y]["informative"]
                                   for y in tail if y in blocked["outputs"]):
        return None
    stds = ", ".join(f"{y} {v['std_tail']:.3g} of {v['std_flight']:.3g}"
                     for y, v in tail.items())
    return ("not validated: the flight has no excited segment after the learning part "
            f"(validation std {stds} rad/s, below {100 * STILL_SHARE:.0f} % of the flight's "
            "or the excitation threshold): its validation numbers describe noise")


def still_tail_lines(outputs: dict[str, Any], tail: dict[str, dict[str, Any]],
                     blocked: dict[str, Any] | None) -> tuple[list[str], dict[str, str]]:
    """For each body rate whose tail moves (≥ the excitation threshold) but is still against
    the flight (:func:`tail_informs`): mark its validation blocks in ``outputs`` not
    informative (``reason``), and judge it on the blocks instead — one line each, and the
    better baseline (``ARX``/``no-change``) for axes where eTS is behind there (one-step
    RMSE above ``BEHIND`` × ARX's or above no-change's). Returns (lines, fallbacks)."""
    lines, used = [], {}
    for y, v in tail.items():
        entry = outputs.get(y) or {}
        one = ((entry.get("validation") or {}).get("one_step") or {})
        if v["informs"] or one.get("informative") is False:
            continue
        reason = (f"still against the flight (std {v['std_tail']:.3g} < "
                  f"{100 * STILL_SHARE:.0f} % of the flight's {v['std_flight']:.3g})")
        for block in (*(entry.get("validation") or {}).values(),
                      *(((entry.get("arx") or {}).get("validation") or {}).values())):
            block["informative"], block["reason"] = False, reason
        b = (blocked or {}).get("outputs", {}).get(y)
        if b is None or not b["informative"]:
            lines.append(f"warning: {y}: the validation part is {reason} and no block moves: "
                         f"{y} is not validated")
            continue
        r = b["one_step_rmse"]
        e, a, p = r["ets"], r["arx"], r["no-change"]
        text = f"warning: {y}: the validation part is {reason}; judged on the blocks"
        if e is not None and ((a is not None and e > BEHIND * a) or (p is not None and e > p)):
            used[y] = "ARX" if a is not None and (p is None or a <= p) else "no-change"
            text += (f": eTS {e:.4g} is behind ARX {a:.4g} / no-change {p:.4g}; {y} falls "
                     f"back to {used[y]} (metrics.json outputs.{y}.used)")
        else:
            text += f": eTS {e:.4g}, ARX {a:.4g}, no-change {p:.4g}"
        lines.append(text)
    return lines, used
