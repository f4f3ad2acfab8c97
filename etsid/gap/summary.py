"""Words for gap.json: a named effect's parameters and the summary sentence."""

from __future__ import annotations

from typing import Any

import numpy as np

from etsid.gap.candidates import BY_NAME, Candidate
from etsid.gap.detectable import words
from etsid.gap.effects import REGISTRY, effect
from etsid.gap.nominal import LABELS, UNITS

NICE = {**{e.name: e.words for e in REGISTRY},
        "unexplained": "unexplained structure (eTS residual model)"}
"""Name → the words a flight engineer uses (the effect registry's)."""


def effect_params(cand: Candidate, theta: np.ndarray, err: np.ndarray) -> dict[str, Any]:
    """gap.json ``parameters`` of a fitted effect: each value with its unit and standard
    error (None where not finite), and the motor (numbered from 1) of a per-motor effect."""
    params: dict[str, Any] = {p.name: {"value": float(v), "unit": p.unit,
                                       "stderr": float(e) if np.isfinite(e) else None}
                              for p, v, e in zip(cand.params, theta, err, strict=True)}
    if cand.motor is not None:
        params["motor"] = {"value": cand.motor + 1, "unit": ""}
    return params


def _words(entry: dict[str, Any], sim: str, real: str) -> str:
    """A named effect in its own terms (a delay as a later response, a scale as a factor):
    its registry sentence (:attr:`etsid.gap.effects.Effect.said`)."""
    p = {k: v["value"] for k, v in entry["parameters"].items()}
    try:
        return effect(entry["name"]).said(p, sim, real)
    except KeyError:
        return NICE.get(entry["name"], entry["name"])


def _size(data: dict[str, Any], channel: str) -> float:
    nominal = data.get("nominal") or {}
    z = max((nominal.get("z_all") or {}).get(channel, 0.0),
            (nominal.get("z_held_out") or {}).get(channel, 0.0))
    return float(np.sqrt(z))


def summary_sentence(data: dict[str, Any]) -> str:
    """The short summary printed on stdout: the verdict, where, what (in each effect's own
    terms, with its confidence), what is left, and the held-out proof."""
    if data["verdict"] != "mismatch":
        return (f"{data['verdict'].capitalize()}: {data['reason']}." + _blind_spots(data)
                + _twin(data))
    sim, real = data["sim"]["file"], data["real"]["file"]
    mis = data["mismatch"]
    regime = mis["regime"]
    left = data.get("leftover") or {}
    sizes = "; ".join(left_words(c, left[c] if "scale" in left.get(c, {})
                                 else {"ratio": _size(data, c)}) for c in mis["channels"])
    parts = [f"Mismatch: {sizes}."]
    if regime["variable"] != "none":
        parts.append(f"Where: {regime['description']}.")
    names = [e for e in data["effects"] if e["name"] != "unexplained"]
    if names:
        parts.append("Missing physics: " + "; ".join(
            f"{_words(e, sim, real)}, confidence {e['confidence']:.2f}"
            + (f" ({e['caveat']})" if e.get("caveat") else "") for e in names) + ".")
    else:
        parts.append("No named effect explains it on held-out data.")
    for text in data.get("beyond_range", []):
        parts.append(f"Not a finding: {text} — the difference exceeds the vocabulary's range "
                     "(another airframe, or a larger effect than modelled).")
    if left:
        bits = [left_words(c, v) + (" (an eTS residual model predicts part of it)"
                                    if v.get("modelled_by_ets") else "")
                for c, v in left.items()]
        lead = "Still mismatched on held-out data" + (" after that" if names else "")
        parts.append(f"{lead}: {'; '.join(bits)}.")
    covered = {c for e in names for c in e.get("channels", [])} | set(left)
    alone = [LABELS[c] for c in mis["channels"] if c not in covered]
    if names and alone:  # a mismatched channel no named effect acts on
        parts.append(f"Unexplained: {', '.join(alone)} — no named effect acts on "
                     f"{'it' if len(alone) == 1 else 'them'}.")
    main = mis["channels"][0]
    b, a = data["rmse_before"].get(main), data["rmse_after"].get(main)
    if names and b and a is not None:  # every mismatched channel: what became of it
        moved = [f"{LABELS[c]} {data['rmse_before'][c]:.3g} → {data['rmse_after'][c]:.3g} "
                 f"{UNITS[c]} ({100 * (data['rmse_after'][c] / data['rmse_before'][c] - 1):+.0f} %)"
                 for c in mis["channels"]
                 if data["rmse_before"].get(c) and data["rmse_after"].get(c) is not None]
        parts.append(f"Held-out RMSE of {', '.join(moved)}.")
        parts.extend(_barely_moved(data, mis["channels"], set(left)))
    return " ".join(parts) + _blind_spots(data, brief=True) + _twin(data)


def left_words(channel: str, entry: dict[str, Any]) -> str:
    """A mismatched channel in words: its innovations over their floor, or for a gyro whose
    scale departs from SIM's (:mod:`etsid.gap.scale`, ``entry["scale"]``) the share of the
    rate it reads beyond the attitude's."""
    if "scale" in entry:
        return (f"{LABELS[channel]} reads {100 * entry['scale']:+.1f} % of the rate against "
                "SIM's (a gyro scale factor, or an estimator SIM does not have)")
    return f"{LABELS[channel]} {entry['ratio']:.1f}× its floor"


def _barely_moved(data: dict[str, Any], channels: list[str], listed: set[str]) -> list[str]:
    """A sentence for the mismatched channels the named effects leave mostly as they were:
    less than half of the held-out RMSE's excess over the channel's floor removed (the
    ones :func:`leftover` lists are said already)."""
    bits = []
    for c in channels:
        before, after = data["rmse_before"].get(c), data["rmse_after"].get(c)
        floor = (data.get("noise") or {}).get(c)
        if c in listed or not before or after is None or not floor or before <= floor:
            continue
        removed = (before - after) / (before - floor)
        if removed < 0.5:
            bits.append(f"{LABELS[c]} (the named effects remove {100 * max(removed, 0.0):.0f} "
                        f"% of its excess over its {floor:.3g} {UNITS[c]} floor)")
    if not bits:
        return []
    return [f"Mostly unexplained: {'; '.join(bits)}."]


SOURCE_WORDS = {"sim": "SIM's own model error", "real noise": "REAL's sensor noise",
                "bias floor": "the flight-to-flight bias floor"}


def _blind_spots(data: dict[str, Any], brief: bool = False) -> str:
    """What the pair could not have seen (gap.json's ``detectable``), and the floors that
    decided it: every effect's detectable size after a consistent verdict, only the effects
    the pair is blind to after a mismatch (``brief``)."""
    seen = data.get("detectable") or {}
    if not seen:
        return ""
    named = {e["name"] for e in data.get("effects", [])}
    keep = [n for n, e in seen.items() if n not in named
            and (not brief or e["status"] == "insufficient")]
    text = words(seen, keep)
    if not text:
        return ""
    noise, source, units = data.get("noise", {}), data.get("noise_source", {}), data["units"]
    chans = sorted({c for n in keep if seen[n]["status"] == "detectable"
                    for c in BY_NAME[n].channels if c in noise}) if not brief else []
    floors = "; ".join(f"{LABELS[c]} {noise[c]:.3g} {units.get(c, UNITS[c])} "
                       f"({SOURCE_WORDS.get(source.get(c, ''), source.get(c, ''))})"
                       for c in chans)
    return (f" This pair could not have seen {text}"
            + (f" (the floors that decide it: {floors})" if floors else "") + ".")


def _twin(data: dict[str, Any]) -> str:
    """The twin's divergence time, from the notes, as a sentence of the summary."""
    for n in data.get("notes", []):
        if "replayed twin that leaves its recording" in n:
            return f" {n[0].upper()}{n[1:]}."
    return ""
