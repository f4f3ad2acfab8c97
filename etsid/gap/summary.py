"""Words for gap.json: one entry per named effect and the summary sentence."""

from __future__ import annotations

from typing import Any

import numpy as np

from etsid.gap.candidates import Candidate
from etsid.gap.fitting import Scorer
from etsid.gap.nominal import LABELS, UNITS

NICE = {"ground_effect": "ground effect", "rotor_drag": "rotor drag",
        "motor_lag": "motor lag", "time_delay": "time delay", "battery_sag": "battery sag",
        "thrust_scale": "thrust scale", "inertia_scale": "inertia scale",
        "torque_offset": "torque offset", "gyro_bias": "gyro bias",
        "unexplained": "unexplained structure (eTS residual model)"}
LAW = {"ground_effect": "generalised Cheeseman–Bennett"}


def _confidence(name: str, sel: Any) -> float:
    chosen = sel.chosen
    alts = [s for s in sel.ranked if name not in s.fit.name.split("+")]
    best_alt = max((s.score for s in alts), default=0.0)
    own = next((s.score for s in sel.ranked if s.fit.name == name), chosen.score)
    if own <= 0:
        return 0.0
    return float(np.clip((own - max(best_alt, 0.0)) / own + 0.5 * min(own, 1.0), 0.0, 1.0))


def effect_entry(cand: Candidate, theta: np.ndarray, err: np.ndarray, single: Any, sel: Any,
                 scorer: Scorer, hold: np.ndarray, res0: dict[str, np.ndarray]
                 ) -> dict[str, Any]:
    """gap.json entry of one selected effect."""
    chans = [c for c in cand.channels if c in res0]
    params = {p.name: {"value": float(v), "unit": p.unit,
                       "stderr": float(e) if np.isfinite(e) else None}
              for p, v, e in zip(cand.params, theta, err, strict=True)}
    mods = single.fit.mods if single is not None else sel.chosen.fit.mods
    res1 = scorer.residuals(mods)
    before = {c: float(np.sqrt(np.mean(res0[c][hold] ** 2))) for c in chans}
    after = {c: float(np.sqrt(np.mean(res1[c][hold] ** 2))) for c in chans}
    gains = {c: 1 - after[c] / before[c] for c in chans if before[c] > 0}
    top = max(gains, key=gains.get) if gains else chans[0]
    share = single.share if single is not None else sel.chosen.share
    evidence = (f"{cand.signature[0].upper()}{cand.signature[1:]}; fitted on the first part "
                f"of the recording it explains {100 * min(share, 1):.0f} % of the excess "
                f"error on the held-out part ({LABELS[top]} RMSE {before[top]:.3g} → "
                f"{after[top]:.3g} {UNITS[top]})")
    return {"name": cand.name, "channels": chans, "parameters": params,
            "confidence": _confidence(cand.name, sel), "evidence": evidence,
            "rmse_before": before, "rmse_after": after}


def _params_text(effect: dict[str, Any]) -> str:
    if effect["name"] == "unexplained":
        return ""
    bits = []
    for name, p in effect["parameters"].items():
        v = p["value"]
        bits.append(f"{name} = {v:.3g}{' ' + p['unit'] if p['unit'] not in ('', '1') else ''}")
    law = LAW.get(effect["name"])
    return f" ({law + ', ' if law else ''}fitted {', '.join(bits)})"


def summary_sentence(data: dict[str, Any]) -> str:
    """The short summary printed on stdout."""
    if data["verdict"] != "mismatch":
        return f"{data['verdict'].capitalize()}: {data['reason']}."
    mis = data["mismatch"]
    desc = mis["regime"]["description"]
    names = [e for e in data["effects"] if e["name"] != "unexplained"]
    parts = [f"Mismatch: {desc}."]
    if names:
        parts.append("Missing physics: " + "; ".join(
            f"{NICE[e['name']]}{_params_text(e)}" for e in names) + ".")
    if any(e["name"] == "unexplained" for e in data["effects"]):
        parts.append("Unexplained structure left, modelled by an eTS residual model.")
    main = mis["channels"][0]
    b, a = data["rmse_before"].get(main), data["rmse_after"].get(main)
    if b and a is not None:
        parts.append(f"Held-out RMSE of {LABELS[main]} {b:.3g} → {a:.3g} {UNITS[main]} "
                     f"({100 * (a - b) / b:+.0f} %).")
    return " ".join(parts)
