"""What the pair could have seen: the smallest size of every vocabulary effect at which the
mismatch rule would fire on this pair (a power analysis from the floors, the noise model
and REAL's own motion).

For an effect with parameter θ (no effect at ``θ_0``), the nominal model's prediction on
REAL's own motion changes by ``Δ_c(θ)`` in each channel ``c`` the effect acts on. With
REAL as predictable as SIM (its residual at its floor) and the change independent of the
residual, a dynamic channel's variance ratio becomes ``1 + mean(Δ_c²)/σ_c²``; the mismatch
rule fires above the calibrated ``mismatch_ratio``. A sensor-consistency channel is judged
by its offset against the flights' between-flight spread τ, an F(1, k) law at the
calibration's false-positive rate. The detectable size is the smallest ``|θ − θ_0|`` at
which some channel fires, on all of REAL's evidence or on its held-out part, searched along
each parameter in each direction up to its search bound. An effect whose detectable size
lies beyond every bound (the plausible range of the vocabulary), or whose signals a log
lacks, is ``insufficient``: the pair cannot say whether it is there.

The evidence (:func:`detectable_evidence`) carries no threshold; the sizes
(:func:`detectable_sizes`) are stated under a calibration, so a benchmark states them again
under each leave-one-generator-out calibration.

What this does not do: it assumes the effect's change adds to a residual of SIM's size
(a REAL noisier than SIM needs more), ignores what the whitening filter does to a dynamic
channel's change, reads one parameter at a time (an effect that only shows in a combination
is not covered) and reads the mismatch rule, not the likelihood criterion, which can name
an effect below this size (such a name is capped, :func:`cap_below_detectable`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from etsid.gap.calibration import Calibration
from etsid.gap.candidates import BY_NAME, Candidate, Context
from etsid.gap.criterion import offset_limit
from etsid.gap.fitting import Scorer
from etsid.gap.nominal import Mods

FRACTIONS = np.array([0.02, 0.2, 1.0])
"""Steps along a parameter's range (share of the distance from no effect to the bound)
at which the change of the prediction is evaluated; between steps it is interpolated in
log-log (the changes grow as a power of the size), below the first extrapolated
(:func:`_crossing`)."""
LEAST_POWER = 2.0
"""Least power of a size in the change of a variance below the first step: the prediction's
change is at least first order in the distance from no effect."""
OFFSETS = {"gyro_bias", "accel_bias", "torque_offset"}
"""Effects that add their parameter to a channel's prediction: the change is the parameter
itself (``mean(Δ²) = θ²``), no prediction needed."""
SKIP = {("wind", "lift"), ("ground_effect", "exponent")}
"""Parameters that do nothing alone (lift needs a wind; the exponent needs a radius)."""
BELOW_CONFIDENCE = 0.45
"""Highest confidence of an effect named at a size below what the pair can detect at the
mismatch rule (the criterion can name it; at that size it is a hint, not a finding): below
even odds."""


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
    """Smallest size at which ``excess`` reaches ``need``: log-log interpolation between
    steps; below the first, extrapolated with the first two steps' power but never less
    than :data:`LEAST_POWER` (a change first order in the size changes a variance as its
    square; a saturating curve's flatter power would claim sizes far below any step)."""
    above = np.flatnonzero(excess >= need)
    if not above.size:
        return None
    i = max(int(above[0]), 1)
    x0, x1 = np.log(sizes[i - 1]), np.log(sizes[i])
    y0, y1 = np.log(max(excess[i - 1], 1e-300)), np.log(max(excess[i], 1e-300))
    if above[0] == 0:  # below the first step
        power = max((y1 - y0) / (x1 - x0), LEAST_POWER)
        return float(np.exp(x0 + (np.log(need) - y0) / power))
    if y1 <= y0:
        return float(sizes[int(above[0])])
    return float(np.exp(x0 + (np.log(need) - y0) * (x1 - x0) / (y1 - y0)))


def _one_parameter(cand: Candidate, j: int, scorer: Scorer, base: dict[str, np.ndarray],
                   masks: list[np.ndarray], offsets: dict[str, tuple[float, int]]
                   ) -> dict[str, Any]:
    """``{"down": curve, "up": curve}`` for parameter ``j``: how far it can go (``span``)
    and either the change of the prediction at steps along it (``sizes``, ``excess``) or,
    for an offset, the variance and draws of each channel's offset test (``channels``)."""
    p, null = cand.params[j], _null(cand, j, scorer)
    out: dict[str, Any] = {}
    assert null is not None
    chans = tuple(c for c in cand.channels if c in base)
    for way, bound in (("down", p.lo), ("up", p.hi)):
        span = bound - null
        if abs(span) < 1e-12:
            continue
        if cand.name in OFFSETS:
            mods = cand.mods(_theta(cand, j, null + np.sign(span)), scorer.ctx)
            tests = [list(offsets.get(c, (scorer.sigma[c] ** 2, 0))) for c, v
                     in mods.offset.items() if v and c in base and c in scorer.sigma]
            out[way] = {"span": float(abs(span)), "channels": tests}
            continue
        sizes = np.abs(span) * FRACTIONS
        ex = np.array([_excess(scorer, cand.mods(_theta(cand, j, null + np.sign(span) * s),
                                                 scorer.ctx), base, chans, masks)
                       for s in sizes])
        out[way] = {"span": float(abs(span)), "sizes": sizes.tolist(), "excess": ex.tolist()}
    return out


def detectable_evidence(scorer: Scorer, masks: list[np.ndarray],
                        offsets: dict[str, tuple[float, int]]) -> dict[str, Any]:
    """What decides every vocabulary effect's detectable size, free of any threshold (so that
    a benchmark can state the sizes again under another calibration).

    Parameters
    ----------
    scorer : Scorer
        REAL's flight, SIM's nominal model and the floors.
    masks : list of ndarray
        REAL's evidence masks (all of it, the held-out part).
    offsets : dict
        Sensor-consistency channel → (variance of its offset statistic's denominator per
        unit of the channel, ``τ² + s²/(m (1 − Σa)²)``; the draws k of its F(1, k) law), as
        the mismatch rule reads the channel (:func:`etsid.gap.noise.offset_z2`).

    Returns
    -------
    dict
        ``{"offset_channels": n, "effects": {name: {"reason": why} (insufficient) or
        {"parameters": {param: {"unit", "down", "up"}}}}}``.
    """
    ctx: Context = scorer.ctx
    base = scorer.prediction()
    effects: dict[str, Any] = {}
    for name, cand in BY_NAME.items():
        if not cand.available(ctx):
            missing = [s for s in cand.needs if s not in ctx.flight.have]
            effects[name] = {"reason": (f"the logs lack {', '.join(missing)}" if missing
                                        else "the logs lack what it acts through")}
            continue
        params = {}
        for j, p in enumerate(cand.params):
            if (name, p.name) in SKIP or _null(cand, j, scorer) is None:
                continue
            params[p.name] = {"unit": p.unit,
                              **_one_parameter(cand, j, scorer, base, masks, offsets)}
        effects[name] = {"parameters": params}
    return {"offset_channels": len(offsets), "effects": effects}


def _size(curve: dict[str, Any] | None, need: float, limit) -> float | None:
    """Smallest detectable distance from no effect along one direction (None: not within
    the parameter's range)."""
    if not curve:
        return None
    if "channels" in curve:
        found = [float(np.sqrt((limit(int(k)) if k > 0 else need) * var))
                 for var, k in curve["channels"]]
        size = min(found) if found else None
    else:
        size = _crossing(np.asarray(curve["sizes"]), np.asarray(curve["excess"]), need)
    return size if size is not None and size <= curve["span"] else None


def detectable_sizes(evidence: dict[str, Any], cal: Calibration) -> dict[str, dict[str, Any]]:
    """Vocabulary effect → what this pair could have seen of it under calibration ``cal``:
    where the mismatch rule would fire. A dynamic channel fires when its innovation
    variance passes ``cal.mismatch_ratio`` times its floor's, so the change must reach
    ``mean(Δ²) ≥ (mismatch_ratio − 1) σ²``; a sensor-consistency channel when its offset
    statistic passes the F(1, k) limit at the calibration's rate
    (:func:`etsid.gap.criterion.offset_limit`), so an offset θ must reach
    ``θ² ≥ limit · (τ² + s²/(m (1 − Σa)²))``.

    Returns
    -------
    dict
        ``{"status": "detectable" | "insufficient", "size": smallest detectable distance
        from no effect (parameter's unit) or None, "parameter", "unit", "per_parameter":
        {name: {"down": size|None, "up": size|None}}, "reason"}``.
    """
    need = max(cal.mismatch_ratio - 1.0, 1e-6)
    n_off = int(evidence.get("offset_channels", 0))

    def limit(k: int) -> float:
        return offset_limit(k, n_off, cal.false_positive_rate)

    out: dict[str, dict[str, Any]] = {}
    for name, e in evidence["effects"].items():
        if "reason" in e:
            out[name] = {"status": "insufficient", "size": None, "parameter": None,
                         "unit": None, "per_parameter": {}, "reason": e["reason"]}
            continue
        per: dict[str, dict[str, float | None]] = {}
        best: tuple[float, str, str] | None = None
        for pname, ways in e["parameters"].items():
            per[pname] = {w: _size(ways[w], need, limit) for w in ("down", "up") if w in ways}
            for size in per[pname].values():
                if size is not None and (best is None or size < best[0]):
                    best = (size, pname, ways["unit"])
        if best is None:
            out[name] = {"status": "insufficient", "size": None, "parameter": None,
                         "unit": None, "per_parameter": per,
                         "reason": "not even at the edge of its range would it pass the "
                                   "mismatch threshold"}
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
    is below what the pair can detect at the mismatch rule (:func:`below_detectable`), or
    that the pair cannot detect at any size in its range (``insufficient``)."""
    for e in effects:
        entry = sizes.get(e.get("name", ""))
        label = e.get("name", "").replace("_", " ")
        if entry and entry["status"] == "insufficient":
            # the pair's power analysis finds no size in range the mismatch rule would see:
            # a name found anyway is held to what a size below the detectable one gets
            note = (f"this pair cannot detect a {label} of any size in its range "
                    f"({entry.get('reason') or 'by the mismatch rule'}): a hint, not a finding")
        elif below_detectable(e, sizes):
            note = (f"fitted below the smallest {label} this pair can detect "
                    f"({entry['size']:.3g} {entry['unit'] or ''}".rstrip()
                    + "): a hint, not a finding")
        else:
            continue
        e["confidence"] = min(float(e["confidence"]), BELOW_CONFIDENCE)
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
