"""How ``etsid gap`` decides: the held-out likelihood criterion and the verdict.

The stages after the nominal model and the airframe check: the noise model on SIM
(:mod:`etsid.gap.noise`), the held-out log-likelihood of every candidate on REAL's blocked
folds (:mod:`etsid.gap.criterion`), the calibrated thresholds
(:mod:`etsid.gap.calibration`), the verdict rules kept from :mod:`etsid.gap.verdict`
(a parameter at its bound or a channel made worse is not a finding; a thrust or inertia
beyond one airframe's faults is another vehicle), and gap.json.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from etsid.gap.calibration import Calibration, load_calibration
from etsid.gap.candidates import ground_excess
from etsid.gap.criterion import (
    Criterion,
    Evaluated,
    LikelihoodScorer,
    answer_size,
    block_se,
    effect_weight,
    evaluate,
    make_folds,
    mismatched,
    run_criterion,
    significant,
)
from etsid.gap.detectable import (
    BELOW_CONFIDENCE,
    cap_below_detectable,
    detectable_evidence,
    detectable_sizes,
)
from etsid.gap.effects import REGISTRY
from etsid.gap.fitting import Fit, Scorer, channels_of, fit_candidates
from etsid.gap.floors import sensor_noise
from etsid.gap.locate import locate_channel, scheduling_variables
from etsid.gap.noise import fit_noise
from etsid.gap.nominal import CUTOFF_HZ, LABELS, NominalModel, measured
from etsid.gap.pem import PredictionErrorScorer, with_innovation_channels
from etsid.gap.regime import locate, located_by_driver
from etsid.gap.residual_model import ResidualModel, fit_residual_model
from etsid.gap.scale import scale_mismatched, scale_tests
from etsid.gap.signals import Flight
from etsid.gap.summary import NICE, effect_params, left_words, summary_sentence
from etsid.gap.verdict import at_bound, worsened


def _admissible(scorer: Scorer, ls: LikelihoodScorer) -> Callable[[Evaluated], str]:
    """Verdict rules 3 and 4 on a model's fold fits: why it may not be named, or ""."""
    def check(ev: Evaluated) -> str:
        for fit in ev.fits:
            for cand, theta, cost in fit.split_bounds():
                hits = at_bound(cand, theta, cost)
                if hits:
                    return "at bound: " + hits[0].describe()
        k = 0
        fit = ev.fits[0]
        chans = channels_of(fit.candidates, scorer)
        mask = ls.folds.score[k]
        worse = worsened(scorer.zscores(None, mask, chans), scorer.zscores(fit.mods, mask, chans))
        if worse:
            return "makes worse: " + ", ".join(f"{LABELS[c]} +{v:.1f} floors"
                                               for c, v in worse.items())
        return ""
    return check


def _rmse(res: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, float]:
    return {c: float(np.sqrt(np.mean(v[mask] ** 2))) for c, v in res.items()}


def look_alikes(crit: Criterion, named: Evaluated, cal: Calibration) -> list[Evaluated]:
    """The other single effects the logs cannot tell apart from ``named``: admitted, with a
    held-out gain of their own, and not put behind it by the blocks (its gain over theirs,
    block by block, not :func:`~etsid.gap.criterion.significant` at the calibration's rate
    among the singles tried)."""
    singles = [m for m in crit.models if "+" not in m.name]
    out = []
    for m in singles:
        if m.name == named.name or m.refused or m.weight <= 0 or m.gain <= 0:
            continue
        if m.gain_blocks.size != named.gain_blocks.size:
            continue
        diff = named.gain_blocks - m.gain_blocks
        if not significant(float(diff.sum()), block_se(diff), len(singles),
                           cal.false_positive_rate):
            out.append(m)
    return out


def _entry(cand, theta: np.ndarray, err: np.ndarray, crit: Criterion, chosen: Evaluated,
           res0: dict[str, np.ndarray], res1: dict[str, np.ndarray], hold: np.ndarray,
           cal: Calibration) -> dict[str, Any]:
    chans = [c for c in cand.channels if c in res0]
    params = effect_params(cand, theta, err)
    before = {c: float(np.sqrt(np.mean(res0[c][hold] ** 2))) for c in chans}
    after = {c: float(np.sqrt(np.mean(res1[c][hold] ** 2))) for c in chans}
    weight = effect_weight(crit, cand.name)
    single = next((m for m in crit.models if m.name == cand.name), chosen)
    evidence = (f"{cand.signature[0].upper()}{cand.signature[1:]}; fitted on one half of the "
                f"recording's blocks and scored on the other, it raises the held-out "
                f"log-likelihood by {single.gain:.0f} nats ({single.per_sample:.3f} per "
                f"sample, ±{single.gain_se:.0f} nats over blocks)")
    entry = {"name": cand.name, "channels": chans, "parameters": params,
             "confidence": float(np.clip(weight, 0.0, 1.0)), "evidence": evidence,
             "rmse_before": before, "rmse_after": after}
    rivals = [(m.name, m.weight) for m in look_alikes(crit, single, cal)
              if m.name not in chosen.name.split("+")]
    if rivals:
        entry["caveat"] = ("the logs cannot tell it apart from " + ", ".join(
            f"{NICE.get(n, n)} (weight {w:.2f})" for n, w in rivals)
            + f"; {NICE.get(cand.name, cand.name)} weight {weight:.2f}")
    return entry


AIRFRAME_SCALES = {"thrust_scale": (0.6, 1.6), "inertia_scale": (0.5, 2.2),
                   "mass": (1 / 1.6, 1 / 0.6)}
"""Fault ranges of the airframe-scale effects (physics: a lost 40 % of thrust or more than
doubled inertia is another configuration of the vehicle, not a fault of it). A mass ratio r
gives the vertical dynamics of a thrust scale 1/r, so its range is the thrust scale's
inverted: thrust-to-weight beyond the same factors."""


def _airframe_evidence(name: str, value: float, how: str) -> str | None:
    """Words when ``value`` of airframe-scale effect ``name`` lies beyond one airframe's
    fault range (:data:`AIRFRAME_SCALES`), else None."""
    lo, hi = AIRFRAME_SCALES.get(name, (-np.inf, np.inf))
    if lo <= value <= hi:
        return None
    return f"{name} {value:.3g} {how}, beyond a fault of one airframe ({lo:.3g}–{hi:.3g})"


def _candidate_row(m: Evaluated) -> dict[str, Any]:
    """gap.json ``candidates`` row of one model: its weight (``share``), its held-out gain
    per sample (``score``, nats) and its parameters averaged over the folds (a per-motor
    law's motor as m1 … m8; a pair's prefixed by the effect)."""
    params: dict[str, Any] = {}
    if m.fits:
        theta = np.mean([f.theta for f in m.fits], axis=0)
        k = 0
        for cand in m.candidates:
            prefix = f"{cand.name}." if len(m.candidates) > 1 else ""
            if cand.motor is not None:
                params[f"{prefix}motor"] = f"m{cand.motor + 1}"
            for p in cand.params:
                params[f"{prefix}{p.name}"] = {"value": float(f"{theta[k]:.4g}"), "unit": p.unit}
                k += 1
    return {"name": m.name, "share": round(m.weight, 4), "score": round(m.per_sample, 5),
            "params": params}


def _unexplained_entry(channel: str, weight: float, model: ResidualModel | None,
                       sim_name: str, data: dict[str, Any]) -> dict[str, Any]:
    """gap.json's ``unexplained`` entry for ``channel``: with the eTS residual model and its
    held-out RMSE where one predicts the channel's held-out blocks."""
    before = data["rmse_before"][channel]
    entry = {"name": "unexplained", "channels": [channel], "parameters": {},
             "confidence": float(np.clip(weight, 0.0, 1.0)),
             "evidence": f"{LABELS[channel]} departs from {sim_name}'s model and no named "
                         "effect predicts its held-out blocks",
             "rmse_before": {channel: before}, "rmse_after": {channel: before}}
    if model is not None:
        entry["parameters"] = {"model": {"value": f"eTS, {model.n_rules} rules", "unit": ""},
                               "inputs": {"value": model.variables, "unit": ""}}
        entry["evidence"] = (f"{LABELS[channel]} keeps structure no named effect explains; an "
                             f"eTS model on {', '.join(model.variables)}, learnt on one fold "
                             f"of blocks, takes its RMSE on the other from "
                             f"{model.rmse_before:.3g} to {model.rmse_after:.3g}")
        entry["rmse_before"] = {channel: model.rmse_before}
        entry["rmse_after"] = {channel: model.rmse_after}
    return entry


def cap_unseen(effects: list[dict[str, Any]], hidden: list[Evaluated], cal: Calibration,
               missing: Callable[[str], str]) -> None:
    """Cap at :data:`~etsid.gap.detectable.BELOW_CONFIDENCE`, with a caveat, every named
    effect that shares a channel with a candidate the logs cannot name whole (REAL lacks a
    signal that tells it apart, :meth:`~etsid.gap.candidates.Candidate.partly_seen`) when
    that candidate, fitted on the channels REAL has, explains them beyond chance (its held-out
    gain :func:`~etsid.gap.criterion.significant` at the calibration's rate among the hidden
    ones; whether there is an effect at all was the named one's test): an accelerometer bias
    on a log without velocity acts on the vertical force as a thrust scale or a mass does,
    and what is left between them is the nominal model's own misfit, not evidence
    (identifiability, not a statistical tie)."""
    for h in hidden:
        if h.gain <= 0 or not significant(h.gain, h.gain_se, len(hidden),
                                          cal.false_positive_rate):
            continue
        seen = set(h.by_channel)
        note = (f"look-alike: {h.name.replace('_', ' ')} explains the same channels "
                f"({h.per_sample:.3f} nats per sample) and the logs lack {missing(h.name)} "
                "to tell them apart")
        for e in effects:
            if e["name"] != h.name and seen & set(e["channels"]):
                e["confidence"] = min(float(e["confidence"]), BELOW_CONFIDENCE)
                e["caveat"] = f"{e['caveat']}; {note}" if e.get("caveat") else note


def cap_on_sticks(effects: list[dict[str, Any]], inputs: str) -> None:
    """Cap at :data:`~etsid.gap.detectable.BELOW_CONFIDENCE`, with a caveat, every airframe
    scale (:data:`AIRFRAME_SCALES`) named from stick commands (``inputs`` not
    ``"motors"``): a stick's thrust and moment per unit is the autopilot's mixer and thrust
    model applied to its airframe, so another airframe and the same one scaled change it
    alike, and such logs lack the rotor count that tells them apart (identifiability, as
    :func:`cap_unseen`)."""
    if inputs == "motors":
        return
    note = ("named from stick commands: another airframe changes thrust and moment per unit "
            "stick as this does, and the logs have no motor outputs to tell them apart")
    for e in effects:
        if e["name"] in AIRFRAME_SCALES:
            e["confidence"] = min(float(e["confidence"]), BELOW_CONFIDENCE)
            e["caveat"] = f"{e['caveat']}; {note}" if e.get("caveat") else note


def cap_partial(effects: list[dict[str, Any]], left: dict[str, Any]) -> None:
    """Cap at :data:`~etsid.gap.detectable.BELOW_CONFIDENCE`, with a caveat, every named
    effect when a channel is still mismatched on held-out data after them: the weights are
    those of a candidate set that holds the answer, and a leftover says this one does not
    (a partial explanation, not a finding)."""
    if not left:
        return
    still = "; ".join(left_words(c, v) for c, v in left.items())
    note = f"a partial explanation, still on held-out data: {still}"
    for e in effects:
        e["confidence"] = min(float(e["confidence"]), BELOW_CONFIDENCE)
        e["caveat"] = f"{e['caveat']}; {note}" if e.get("caveat") else note


def explain_by_likelihood(sim: Flight, real: Flight, nominal: NominalModel,
                          sigma: dict[str, float], scorer: Scorer, base: dict[str, Any],
                          notes: list[str], info: dict[str, Any],
                          say: Callable[[str], None], cal: Calibration | None = None,
                          own: dict[str, float] | None = None
                          ) -> tuple[dict[str, Any], dict[str, Any]]:
    """gap.json's content and the report's series, decided by the likelihood criterion
    (``own``: SIM's own held-out error per channel, the noise model's scale-up; default
    the floors ``sigma``)."""
    cal = cal or load_calibration()
    ys = measured(sim)
    pred = nominal.predict(sim, None, scorer_channels(scorer))
    res_sim = {c: ys[c] - v for c, v in pred.items() if c in ys}
    res_real = scorer.residuals(None, tuple(res_sim))
    noise = fit_noise(res_sim, sim.airborne, own or sigma, sim.fs, CUTOFF_HZ, sensor_noise(real),
                      res_real, real.airborne)
    folds = make_folds(real.airborne, real.fs)
    if isinstance(scorer, PredictionErrorScorer):
        noise = with_innovation_channels(noise, scorer)
    ls = LikelihoodScorer(scorer, noise, folds)
    say("gap: what this pair could have seen (detectable size of every effect)")
    seen = detectable_evidence(scorer, [real.airborne], ls.offset_tests())
    base = {"detectable": detectable_sizes(seen, cal), **base}
    # the report's residuals in the channels' own units, not as innovations
    shown = scorer.base if isinstance(scorer, PredictionErrorScorer) else scorer
    library = tuple(c for e in REGISTRY for c in e.forms if c.available(scorer.ctx))
    say(f"gap: {len(library)} candidate effects, each fitted on one half of "
        f"{real.name}'s {folds.n_blocks} blocks and scored on the other")
    crit = run_criterion(ls, library, cal, _admissible(scorer, ls))
    unseen = {c.name: c for e in REGISTRY for c in e.forms if c.partly_seen(scorer.ctx)
              and any(s not in real.have for s in c.needs)}  # a signal missing, not a law
    hidden = [evaluate((c,), ls, cal.gain_per_sample) for c in unseen.values()]
    hold = np.zeros(real.n, dtype=bool)
    for s in folds.score:
        hold |= s
    res0 = shown.residuals()
    scale = scale_tests(sim, real)
    scaled = scale_mismatched(scale, cal)  # no effect acts on it: left after every model
    mismatch = mismatched(crit.ratio, crit.offset, cal)
    mismatch += [c for c in scaled if c not in mismatch]
    chosen = crit.chosen
    final: Fit | None = None
    if chosen is not None:
        x0 = np.mean([f.theta for f in chosen.fits], axis=0)
        final = fit_candidates(chosen.candidates, scorer, real.airborne, x0=x0)
    res1 = shown.residuals(final.mods) if final is not None else res0
    ratio_after = ls.ratio(final.mods) if final is not None else crit.ratio
    offset_after = ls.offsets(final.mods) if final is not None else crit.offset
    left = {c: {"z": ratio_after[c], "rmse": float(np.sqrt(np.mean(res1[c][hold] ** 2))),
                "floor": sigma[c], "ratio": float(np.sqrt(ratio_after[c]))}
            for c in mismatched(ratio_after, offset_after, cal) + scaled}
    for c in scaled:
        left[c].update(scale=scale[c][0], scale_se=scale[c][1])
    effects: list[dict[str, Any]] = []
    airframe: list[str] = []
    radius, ground_law = info.get("radius"), None
    if final is not None:
        for cand, theta, err in final.split():
            effects.append(_entry(cand, theta, err, crit, chosen, res0, res1, hold, cal))
            found = _airframe_evidence(cand.name, float(theta[0]), "fitted")
            if found:
                airframe.append(found)
            if cand.name == "ground_effect":
                exponential = cand.params[0].name == "excess"
                ground_law = ground_excess(theta, exponential)
                if radius is None and not exponential:
                    radius = float(theta[0])
    cap_below_detectable(effects, base.get("detectable") or {})
    cap_partial(effects, left)
    cap_unseen(effects, hidden, cal, lambda name: ", ".join(
        s for s in unseen[name].needs if s not in real.have))
    cap_on_sticks(effects, real.inputs)
    for m in crit.models:
        if m.refused and m.per_sample > cal.gain_per_sample and (
                chosen is None or m.gain > chosen.gain):
            notes.append(f"not kept: {m.name} ({m.refused})")
    at_bounds = [m for m in crit.models
                 if m.refused.startswith("at bound") and m.per_sample > cal.gain_per_sample
                 and (chosen is None or m.gain > chosen.gain)]
    beyond = [m.refused[len("at bound: "):] for m in at_bounds]
    top = max((m.gain for m in crit.models if "+" not in m.name), default=-np.inf)
    for m in at_bounds:  # the single that explains most is a scale held at its bound
        if "+" not in m.name and m.gain >= top:
            theta = float(np.mean([f.theta[0] for f in m.fits]))
            found = _airframe_evidence(m.name, theta, "at its search bound")
            if found:
                airframe.append(found)
    criterion = {"method": "likelihood", "folds": len(folds.score), "blocks": folds.n_blocks,
                 "thresholds": {"mismatch_ratio": cal.mismatch_ratio,
                                "gain_per_sample": cal.gain_per_sample,
                                "pair_gain_per_sample": cal.pair_gain_per_sample},
                 "innovation_ratio": crit.ratio,
                 "detectable_evidence": seen,
                 "offset": {c: [v, k] for c, (v, k) in crit.offset.items()},
                 "scale": {c: list(v) for c, v in scale.items()},
                 **({"after_lead": {"name": crit.after_lead["name"],
                                    "ratio": crit.after_lead["ratio"],
                                    "offset": {c: [v, k] for c, (v, k)
                                               in crit.after_lead["offset"].items()}}}
                    if crit.after_lead else {}),
                 "models": [{"name": m.name, "gain": round(m.gain, 3),
                             "per_sample": round(m.per_sample, 6), "n_scored": m.n_scored,
                             "gain_se": (round(m.gain_se, 3) if np.isfinite(m.gain_se)
                                         else None),
                             **({"extra_se": round(m.extra_se, 3)}
                                if m.extra_se is not None else {}),
                             "by_channel": {c: [round(g, 3), k]
                                            for c, (g, k) in m.by_channel.items()},
                             "weight": round(m.weight, 4),
                             "theta": [round(float(v), 6) for v in np.mean(
                                 [f.theta for f in m.fits], axis=0)],
                             **({"refused": m.refused} if m.refused else {})}
                            for m in sorted(crit.models, key=lambda m: -m.gain)]}
    data = {**base, "effects": effects, "leftover": left, "beyond_range": beyond,
            "notes": notes, "criterion": criterion,
            "rmse_before": _rmse(res0, hold), "rmse_after": _rmse(res1, hold),
            "candidates": [_candidate_row(m) for m in crit.models]}
    data["nominal"] = {**data.get("nominal", {}), "z_all": crit.ratio, "z_held_out": crit.ratio}
    series = {"res_before": res0, "res_after": res1, "fit": folds.score[0],
              "hold": folds.score[-1], "scorer": shown, "z_all": crit.ratio,
              "mods": final.mods if final is not None else None}
    if airframe:
        data.update(verdict="different-vehicle", reason="; ".join(airframe), mismatch=None,
                    effects=[], rmse_after=data["rmse_before"])
        data["summary"] = (f"Different vehicle: {data['reason']}. One airframe with a fault "
                           "does not explain both logs, so no missing physics is named.")
        return data, series
    named = [e["name"] for e in effects]
    if not named and not mismatch:
        data.update(verdict="consistent", mismatch=None, rmse_after=data["rmse_before"],
                    reason=f"no channel of {real.name} departs from {sim.name}'s model beyond "
                           "what no-effect pairs show, and no named effect predicts its "
                           "held-out blocks better than the model unchanged")
        data["summary"] = summary_sentence(data)
        return data, series
    channels = mismatch or sorted({c for e in effects for c in e["channels"]},
                                  key=lambda c: -crit.ratio.get(c, 0.0))
    worst = max(left, key=lambda c: left[c]["ratio"]) if left else (
        None if named else channels[0])
    model = None
    if worst is not None:
        reg = locate_channel(worst, res1[worst], sigma[worst], real, radius)
        names = [reg.variable] if reg.variable != "none" else ["thrust", "command_rate"]
        var = scheduling_variables(real)
        model = fit_residual_model(worst, res1[worst], {n: var[n] for n in names if n in var},
                                   folds.fit[0], folds.score[0])
    if model is not None:
        series["res_after"] = {**res1, worst: res1[worst] - model.correction}
        if worst in left:
            left[worst]["modelled_by_ets"] = True
    if not named or model is not None:
        weight = 1.0 - max((m.weight for m in crit.models if answer_size(m.name) == 1),
                           default=0.0)
        effects.append(_unexplained_entry(worst or channels[0], weight, model, sim.name, data))
    main = channels[0]
    regime = locate(real, main, res0, sigma[main], radius, info.get("radius") is None,
                    ground_law)
    regime.update(located_by_driver(effects, real) or {})
    segs = regime.pop("segments")
    what = "; ".join(left_words(c, left[c] if c in scaled
                                else {"ratio": float(np.sqrt(crit.ratio[c]))})
                     for c in channels) + " (innovations)"
    data.update(verdict="mismatch",
                reason=what + ("" if named else "; no named effect explains it on held-out "
                               "data"),
                mismatch={"channels": channels,
                          "segments": [{"t_start": a, "t_end": b} for a, b in segs],
                          "regime": regime})
    data["summary"] = summary_sentence(data)
    return data, series


def scorer_channels(scorer: Scorer) -> tuple[str, ...]:
    """The channels the scorer compares (those both logs have)."""
    return tuple(c for c in scorer.ctx.nominal.channels if c in scorer.measured)
