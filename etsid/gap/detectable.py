"""What the pair could have seen: the smallest size of every vocabulary effect this pair
of flights would show as a mismatch (a power analysis from the floors and the excitation).

For an effect with parameter θ (no effect at ``θ_0``), the nominal model's prediction on
REAL's own motion changes by ``Δ_c(θ)`` in each channel ``c`` the effect acts on. With
REAL as predictable as SIM (its residual at its floor, ``z_0 = 1``) and the change
independent of the residual, the channel's z becomes ``1 + mean(Δ_c²)/σ_c²``; the
verdict's mismatch rule fires at ``z > Z`` (:data:`etsid.gap.verdict.Z_MISMATCH`, the
threshold the no-effect pairs set the false-positive rate with). The detectable size is
the smallest ``|θ − θ_0|`` at which some channel reaches ``mean(Δ_c²) ≥ (Z − 1) σ_c²``, on
all of REAL's evidence or on its held-out part, searched along each parameter in each
direction up to the parameter's search bound. An effect whose detectable size lies beyond
every bound (the plausible range of the vocabulary), or whose signals a log lacks, is
``insufficient``: the pair cannot say whether it is there.

What this does not do: it assumes the effect's change adds to a residual of SIM's size
(a REAL noisier than SIM needs more), reads one parameter at a time (an effect that only
shows in a combination is not covered) and uses the fixed threshold :data:`Z_MISMATCH`
on the floors, not the likelihood criterion, which can name an effect below this size
(such a name is capped, :func:`cap_below_detectable`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from etsid.gap.candidates import BY_NAME, Candidate, Context
from etsid.gap.fitting import Scorer
from etsid.gap.nominal import Mods

FRACTIONS = np.array([0.02, 0.2, 1.0])
"""Steps along a parameter's range (share of the distance from no effect to the bound)
at which the change of the prediction is evaluated; between steps it is interpolated in
log-log (the changes grow as a power of the size), below the first extrapolated with the
first two steps' power."""
OFFSETS = {"gyro_bias", "accel_bias", "torque_offset"}
"""Effects that add their parameter to a channel's prediction: the change is the parameter
itself (``mean(Δ²) = θ²``), no prediction needed."""
SKIP = {("wind", "lift"), ("ground_effect", "exponent")}
"""Parameters that do nothing alone (lift needs a wind; the exponent needs a radius)."""
BELOW_CONFIDENCE = 0.45
"""Highest confidence of an effect named at a size below what the pair can detect at the
mismatch threshold (the criterion can name it; at that size it is a hint, not a finding)."""


def _null(cand: Candidate, j: int, scorer: Scorer) -> float | None:
    p = cand.params[j]
    if p.null is not None:
        return float(p.null)
    if cand.name == "motor_lag":
        return float(scorer.ctx.nominal.tau)
    return None


def _theta(cand: Candidate, j: int, value: float) -> np.ndarray:
    theta = np.array([p.null if p.null is not None else p.x0 for p in cand.params], float)
    theta[j] = value
    return theta


def _excess(scorer: Scorer, mods: Mods, base: dict[str, np.ndarray], chans: tuple[str, ...],
            masks: list[np.ndarray]) -> float:
    """Largest ``mean(Δ_c²)/σ_c²`` over the effect's channels and the evidence masks."""
    pred = scorer.prediction(mods, chans)
    worst = 0.0
    for c in chans:
        if c not in pred or c not in base or c not in scorer.sigma:
            continue
        d = pred[c] - base[c]
        for m in masks:
            if np.any(m):
                worst = max(worst, float(np.mean(d[m] ** 2)) / scorer.sigma[c] ** 2)
    return worst


def _crossing(sizes: np.ndarray, excess: np.ndarray, need: float) -> float | None:
    """Smallest size at which ``excess`` reaches ``need`` (log-log interpolation between
    steps, extrapolation below the first)."""
    above = np.flatnonzero(excess >= need)
    if not above.size:
        return None
    i = max(int(above[0]), 1)
    x0, x1 = np.log(sizes[i - 1]), np.log(sizes[i])
    y0, y1 = np.log(max(excess[i - 1], 1e-300)), np.log(max(excess[i], 1e-300))
    if y1 <= y0:
        return float(sizes[int(above[0])])
    return float(np.exp(x0 + (np.log(need) - y0) * (x1 - x0) / (y1 - y0)))


def _one_parameter(cand: Candidate, j: int, scorer: Scorer, base: dict[str, np.ndarray],
                   masks: list[np.ndarray], need: float) -> dict[str, float | None]:
    """``{"down": size, "up": size}`` for parameter ``j`` (None: not within its bound)."""
    p, null = cand.params[j], _null(cand, j, scorer)
    out: dict[str, float | None] = {}
    assert null is not None
    chans = tuple(c for c in cand.channels if c in base)
    for way, bound in (("down", p.lo), ("up", p.hi)):
        span = bound - null
        if abs(span) < 1e-12:
            continue
        if cand.name in OFFSETS:
            mods = cand.mods(_theta(cand, j, null + np.sign(span)), scorer.ctx)
            sig = [scorer.sigma[c] for c, v in mods.offset.items() if v and c in base
                   and c in scorer.sigma]
            size = float(np.sqrt(need) * min(sig)) if sig else None
            out[way] = size if size is not None and size <= abs(span) else None
            continue
        sizes = np.abs(span) * FRACTIONS
        ex = np.array([_excess(scorer, cand.mods(_theta(cand, j, null + np.sign(span) * s),
                                                 scorer.ctx), base, chans, masks)
                       for s in sizes])
        out[way] = _crossing(sizes, ex, need)
    return out


def detectable_sizes(scorer: Scorer, masks: list[np.ndarray], threshold: float
                     ) -> dict[str, dict[str, Any]]:
    """Vocabulary effect → what this pair could have seen of it.

    Parameters
    ----------
    scorer : Scorer
        REAL's flight, SIM's nominal model and the floors.
    masks : list of ndarray
        REAL's evidence masks the mismatch rule reads (all of it, the held-out part).
    threshold : float
        The mismatch rule's z (:data:`etsid.gap.verdict.Z_MISMATCH`).

    Returns
    -------
    dict
        ``{"status": "detectable" | "insufficient", "size": smallest detectable distance
        from no effect (parameter's unit) or None, "parameter", "unit", "per_parameter":
        {name: {"down": size|None, "up": size|None}}, "reason"}``.
    """
    need = max(threshold - 1.0, 1e-6)
    ctx: Context = scorer.ctx
    base = scorer.prediction()
    out: dict[str, dict[str, Any]] = {}
    for name, cand in BY_NAME.items():
        if not cand.available(ctx):
            missing = [s for s in cand.needs if s not in ctx.flight.have]
            why = (f"the logs lack {', '.join(missing)}" if missing
                   else "the logs lack what it acts through")
            out[name] = {"status": "insufficient", "size": None, "parameter": None,
                         "unit": None, "per_parameter": {}, "reason": why}
            continue
        per: dict[str, dict[str, float | None]] = {}
        best: tuple[float, str, str] | None = None
        for j, p in enumerate(cand.params):
            if (name, p.name) in SKIP or _null(cand, j, scorer) is None:
                continue
            per[p.name] = _one_parameter(cand, j, scorer, base, masks, need)
            for size in per[p.name].values():
                if size is not None and (best is None or size < best[0]):
                    best = (size, p.name, p.unit)
        if best is None:
            out[name] = {"status": "insufficient", "size": None, "parameter": None,
                         "unit": None, "per_parameter": per,
                         "reason": "not even at the edge of its range would it lift a channel "
                                   f"above {np.sqrt(threshold):.0f}× its floor"}
        else:
            out[name] = {"status": "detectable", "size": best[0], "parameter": best[1],
                         "unit": best[2], "per_parameter": per, "reason": ""}
    return out


def below_detectable(effect: dict[str, Any], sizes: dict[str, dict[str, Any]]) -> bool:
    """Whether a named effect's fitted parameters all lie closer to no effect than this pair
    can detect (every parameter with a detectable size in its direction below it)."""
    entry = sizes.get(effect.get("name", ""))
    if not entry or entry["status"] != "detectable":
        return False
    cand = BY_NAME.get(effect["name"])
    if cand is None:
        return False
    nulls = {p.name: p.null for p in cand.params}
    judged = False
    for pname, ways in entry["per_parameter"].items():
        value = effect.get("parameters", {}).get(pname, {}).get("value")
        null = nulls.get(pname)
        if not isinstance(value, (int, float)) or null is None:
            continue
        way = "up" if value >= null else "down"
        size = ways.get(way)
        if size is None:
            continue
        judged = True
        if abs(value - null) >= size:
            return False
    return judged


def cap_below_detectable(effects: list[dict[str, Any]], sizes: dict[str, dict[str, Any]]
                         ) -> None:
    """Cap at :data:`BELOW_CONFIDENCE`, with a caveat, every named effect whose fitted size
    is below what the pair can detect at the mismatch threshold (:func:`below_detectable`)."""
    for e in effects:
        if below_detectable(e, sizes):
            entry = sizes[e["name"]]
            e["confidence"] = min(float(e["confidence"]), BELOW_CONFIDENCE)
            note = (f"fitted below the smallest {e['name'].replace('_', ' ')} this pair can "
                    f"detect ({entry['size']:.3g} {entry['unit'] or ''}".rstrip()
                    + "): a hint, not a finding")
            e["caveat"] = f"{e['caveat']}; {note}" if e.get("caveat") else note


def words(sizes: dict[str, dict[str, Any]], names: list[str] | None = None) -> str:
    """``"time delay below 42 ms, gyro bias below 0.02 rad/s …; at any size within its
    range: ground effect, …"`` (the second part: the effects marked ``insufficient``)."""
    parts, blind = [], []
    for name, e in sizes.items():
        if names is not None and name not in names:
            continue
        label = name.replace("_", " ")
        if e["status"] == "insufficient":
            blind.append(label)
            continue
        size, unit = float(e["size"]), e["unit"] or ""
        if unit == "s":
            parts.append(f"{label} below {1000 * size:.0f} ms")
        elif unit in ("1", ""):
            parts.append(f"{label} within ±{100 * size:.0f} %")
        else:
            parts.append(f"{label} below {size:.2g} {unit}")
    text = ", ".join(parts)
    if blind:
        text += ("; " if text else "") + "at any size within its range: " + ", ".join(blind)
    return text
