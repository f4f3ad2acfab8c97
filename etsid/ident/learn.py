"""The online learning pass (predict, then learn) over a regression, and its rule history
as the history.parquet and consequents.parquet frames."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pandas as pd

from etsid.ets import ETS
from etsid.ets.merge import merge_rules
from etsid.ident.regressors import Regression
from etsid.progress import progress

CHUNK = 4096
"""Most samples learned per call between progress-bar updates."""
STEPS = 50
"""Progress-bar updates over a pass (so the bar moves in steps of 2 %, not 0 → 68 → 100)."""


def learn_online(model: ETS, reg: Regression, stop_at: int, show: bool,
                 label: str, merge: bool = False, merges: list[dict[str, Any]] | None = None
                 ) -> tuple[np.ndarray, dict[str, Any] | None]:
    """Online pass over ``reg``.

    With ``merge``, statistically indistinguishable neighbouring rules are merged
    (:func:`etsid.ets.merge.merge_rules`, judged on the rows learnt so far) when the model
    is frozen after ``stop_at`` rows and at the end of the pass; each merge is appended to
    ``merges`` with the step and time it happened.

    Returns
    -------
    yhat
        The one-step prediction of every row made before learning from it, shape (N, m).
    frozen
        The model dict as it stood after ``stop_at`` rows (None when ``stop_at`` is not
        inside the data).
    """
    n = len(reg.X)
    yhat = np.full(reg.Y.shape, np.nan)
    frozen: dict[str, Any] | None = None
    chunk = max(64, min(CHUNK, -(-n // STEPS)))
    bounds = sorted({0, n, *range(0, n, chunk), *([stop_at] if 0 < stop_at <= n else [])})
    with progress(n, label, show) as bar:
        for a, b in itertools.pairwise(bounds):
            S = None if reg.S is None else reg.S[a:b]
            yhat[a:b] = np.asarray(model.run(reg.X[a:b], reg.Y[a:b], S)).reshape(b - a, -1)
            if merge and b in (stop_at, n):
                _merge(model, reg, b, merges)
            if b == stop_at:
                frozen = model.to_dict()
            bar.update(b - a)
    return yhat, frozen


def _merge(model: ETS, reg: Regression, upto: int, merges: list[dict[str, Any]] | None
           ) -> None:
    state = model.export_state()
    born = {int(i): int(b) for i, b in zip(state.rule_ids, state.births, strict=True)}
    done = merge_rules(model, reg.X[:upto], reg.Y[:upto],
                       None if reg.S is None else reg.S[:upto])
    if merges is not None:
        last = len(reg.t) - 1
        merges.extend({**m, "after_rows": upto, "t": float(reg.t[upto - 1]),
                       "absorbed_born_t": float(reg.t[min(max(born.get(m["absorbed"], 1) - 1,
                                                              0), last)])}
                      for m in done)


def history_frames(model: ETS, reg: Regression) -> tuple[pd.DataFrame, pd.DataFrame]:
    """history.parquet and consequents.parquet frames of the last ``len(reg)`` learned
    samples (a loaded model continues its step count)."""
    hist = model.history
    frame = hist.to_frame()
    first_step = int(frame["step"].iloc[-len(reg.t)]) - 1 if len(frame) >= len(reg.t) else 0
    frame = frame[frame["step"] > first_step].reset_index(drop=True)
    pos = frame["step"].to_numpy() - first_step - 1
    frame.insert(1, "t", reg.t[pos])
    kinds = {"birth": "births", "replace": "replacements", "removal": "removals",
             "merge": "merges"}
    counts = {col: np.zeros(len(frame), dtype=np.int64) for col in kinds.values()}
    text = [""] * len(frame)
    for event in hist.events:  # counted in arrays: a .loc assignment per event cost 1 ms
        i = int(event["step"]) - first_step - 1
        if 0 <= i < len(frame):
            counts[kinds[event["kind"]]][i] += 1
            text[i] = (text[i] + "; " if text[i] else "") + f"{event['kind']} {event['rule_id']}"
    for col, values in counts.items():
        frame[col] = values
    frame["events"] = text
    if len(frame) and frame["merges"].iloc[-1] > 0:  # merged after the last sample learnt
        frame.loc[len(frame) - 1, "n_rules"] = model.n_rules
    inputs, outputs = model.names()
    cons_frame = _consequents_frame(hist.snapshots, reg.t, first_step, ["1", *inputs],
                                    list(outputs))
    return frame, cons_frame


def _consequents_frame(snapshots: list[dict[str, Any]], t: np.ndarray, first_step: int,
                       terms: list[str], outputs: list[str]) -> pd.DataFrame:
    """consequents.parquet: one row per snapshot, rule, term and output (in that nesting
    order) of the snapshots taken within the last ``len(t)`` samples (``t`` in s)."""
    steps, times, ids, values = [], [], [], []
    for snap in snapshots:
        i = int(snap["step"]) - first_step - 1
        if not 0 <= i < len(t):
            continue
        rids = np.asarray(snap["rule_ids"]).astype(np.int64)
        cons = np.asarray(snap["consequents"], dtype=np.float64)
        cons = cons[:rids.size, :len(terms), :len(outputs)]  # rules × terms × outputs
        n = cons.size
        steps.append(np.full(n, int(snap["step"]), np.int64))
        times.append(np.full(n, float(t[i])))
        ids.append(np.repeat(rids, len(terms) * len(outputs)))
        values.append(cons.ravel())
    columns = ["step", "t", "rule_id", "output", "term", "value"]
    if not values:
        return pd.DataFrame([], columns=columns)
    value = np.concatenate(values)
    per_rule = len(terms) * len(outputs)
    reps = value.size // per_rule if per_rule else 0
    output = np.array(outputs, dtype=object)[np.tile(np.arange(len(outputs)),
                                                     len(terms) * reps)]
    term = np.array(terms, dtype=object)[np.tile(np.repeat(np.arange(len(terms)),
                                                           len(outputs)), reps)]
    return pd.DataFrame({"step": np.concatenate(steps), "t": np.concatenate(times),
                         "rule_id": np.concatenate(ids), "output": output, "term": term,
                         "value": value})


def empty_history() -> tuple[pd.DataFrame, pd.DataFrame]:
    """The history and consequents frames of a run that learned nothing."""
    return (pd.DataFrame(columns=["step", "t", "n_rules", "potential", "focal_max",
                                  "focal_min"]),
            pd.DataFrame(columns=["step", "t", "rule_id", "output", "term", "value"]))
