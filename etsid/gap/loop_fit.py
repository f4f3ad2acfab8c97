"""The rate loop's laws fitted as prediction errors, for a SIM whose loop answers noise.

Where SIM's rate loop mostly answers noise its log does not hold (:mod:`etsid.gap.loop`),
the least-squares command law is biased and the 8 Hz residuals cannot tell a delay, a
motor lag, an inertia or a rate-damping change apart. Each loop law is fitted to REAL's
whitened error (the innovations under SIM's noise model, :mod:`etsid.gap.whiten`) on the
fit part and scored on the held-out part.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from etsid.gap.candidates import BY_NAME
from etsid.gap.damping import LOW_BAND_HZ, LowBandReading, low_band_reading
from etsid.gap.fitting import Fit, Scorer
from etsid.gap.nominal import Mods
from etsid.gap.select import Scored, Selection, score_fit
from etsid.gap.signals import Flight
from etsid.gap.verdict import at_bound
from etsid.gap.whiten import CHANNELS, WhitenedModel, band_power, innovation_ratio, measured_rates

LAWS = {"time_delay": "delay", "motor_lag": "tau", "inertia_scale": "inertia",
        "rate_damping": "damping"}
"""Law → the :class:`Mods` field its first parameter sets, searched within that
parameter's bounds in :data:`etsid.gap.candidates.LIBRARY` (a rate damping here in roll
and pitch only: its yaw factor stays 0)."""
GRID = 16
"""Grid points per law before the bounded refinement (geometric for a positive range)."""



@dataclass
class LoopLaw:
    """One loop law fitted to REAL's innovations."""

    name: str
    value: float
    """Its parameter (s, s, ratio or 1/s)."""
    fit_ratio: float
    hold_ratio: float
    """Innovation ratio on the held-out part with the law."""


@dataclass
class LoopFit:
    """Every loop law fitted to REAL, best first, and REAL's innovation ratio without."""

    laws: list[LoopLaw]
    base_hold: float

    def drop(self, law: LoopLaw) -> float:
        """Share of REAL's held-out innovation ratio the law removes."""
        return (self.base_hold - law.hold_ratio) / self.base_hold


def _bounds(name: str) -> tuple[float, float]:
    param = BY_NAME[name].params[0]
    return float(param.lo), float(param.hi)


def _mods(field: str, value: float, base: Mods | None = None) -> Mods:
    return replace(base or Mods(), **{field: value})


def fit_loop_laws(model: WhitenedModel, real: Flight, fit: np.ndarray, hold: np.ndarray,
                  base: Mods | None = None) -> LoopFit:
    """Each law of :data:`LAWS` fitted to REAL's innovation ratio on ``fit`` (a grid of
    :data:`GRID` points, then a bounded search around the best) and scored on ``hold``, on
    top of ``base`` (an effect already named)."""
    y = measured_rates(real)
    laws = []
    for name, field in LAWS.items():
        lo, hi = _bounds(name)
        grid = np.geomspace(lo, hi, GRID) if lo > 0 else np.linspace(lo, hi, GRID)
        vals = [innovation_ratio(model, real, _mods(field, v, base), fit, y) for v in grid]
        k = int(np.argmin(vals))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, GRID - 1)]
        res = minimize_scalar(lambda v, f=field: innovation_ratio(
            model, real, _mods(f, v, base), fit, y), bounds=(a, b), method="bounded",
            options={"xatol": 1e-4})
        value = float(res.x) if res.fun < vals[k] else float(grid[k])
        laws.append(LoopLaw(name, value, float(min(res.fun, vals[k])),
                            innovation_ratio(model, real, _mods(field, value, base), hold, y)))
    laws.sort(key=lambda law: law.hold_ratio)
    return LoopFit(laws, innovation_ratio(model, real, base or Mods(), hold, y))


LOOP_RATIO = 1.47
"""Innovation tier: with every channel within its floor, REAL's held-out innovation ratio at
or beyond this (or at or below its inverse) is offered to the loop laws. Rule: 1.5× the
largest |log| ratio of the 27 seen no-effect PyFlyt pairs (0.88-1.29)."""
MIN_LOOP_DROP = 0.035
"""Least share of REAL's held-out innovation ratio a loop law must remove to be named from
the prediction-error fit: 1.5× the largest any law removed on the 30 seen no-effect PyFlyt
pairs (0.022; docs/gap.md, step 14)."""


TIMING = ("time_delay", "motor_lag")
"""The two timing laws: under a noise-driven loop each takes up much of the other's error."""
LAG_BAND_HZ = (0.25, 4.0)
"""Band in which a slower motor shows: noise that enters before the motor's lag (PyFlyt's
throttle noise; a real rotor's speed fluctuations) is integrated longer by a slower motor,
and REAL's whitened errors gain power below the loop's answer to it. A command delay leaves
that band alone and moves the loop's answer near its crossover (4-14 Hz) instead."""
LAG_EXCESS = 3.3
"""REAL's whitened roll/pitch error power in :data:`LAG_BAND_HZ` over SIM's from which the
timing law is the motor lag, below which the delay. Rule: the geometric mean of the largest
ratio of the 42 seen delay pairs (2.15, a thrust scale + delay) and the smallest of the 21
seen lag pairs (5.05); no seen pair fell between, and a ratio there is said undecided
(:data:`LAG_UNDECIDED`)."""
LAG_UNDECIDED = (2.15, 5.05)
"""Ratios within which the other timing law is said as the named one's look-alike."""


def _theta(law: LoopLaw) -> np.ndarray:
    """The candidate's parameters for ``law`` (a rate damping's yaw factor 0)."""
    return np.array([law.value, 0.0] if law.name == "rate_damping" else [law.value])


def innovation_shift(model: WhitenedModel, real: Flight, hold: np.ndarray) -> float | None:
    """REAL's held-out innovation ratio under SIM's noise model when it is beyond
    :data:`LOOP_RATIO` either way, else None."""
    ratio = innovation_ratio(model, real, Mods(), hold)
    return ratio if ratio >= LOOP_RATIO or ratio <= 1.0 / LOOP_RATIO else None


def choose_loop_law(sel: Selection, sim: Flight, scorer: Scorer, focus: tuple[str, ...],
                    fit: np.ndarray, hold: np.ndarray, model: WhitenedModel,
                    low: LowBandReading | None = None) -> Selection:
    """Where SIM's loop answers noise and roll or pitch is mismatched (``focus``) with only
    laws of :data:`LAWS`, or nothing, named by the 8 Hz fit: the law the prediction-error fit
    prefers, if it removes at least :data:`MIN_LOOP_DROP` of REAL's held-out innovation ratio
    and sits at no bound; ``sel`` is changed in place (its confidence source becomes the
    laws' held-out drops, :attr:`~etsid.gap.select.Selection.response`) and returned.

    The low band (``low``, :mod:`etsid.gap.damping`) decides first when it reads a shift: a
    higher damping names a rate damping at the low band's value; a lower one (the loop
    answering more noise, as behind a slower motor or a later command) names the timing law
    the prediction-error fit prefers, whatever its drop."""
    if sel.chosen is not None and any(part not in LAWS
                                      for part in sel.chosen.fit.name.split("+")):
        return loop_companion(sel, sim, scorer, focus, fit, hold, model)
    if not set(focus) & set(CHANNELS):
        return sel
    result = fit_loop_laws(model, scorer.ctx.flight, fit, hold)
    usable = [law for law in result.laws if not at_bound(BY_NAME[law.name], _theta(law))]
    said = ", ".join(f"{law.name} {law.value:.3g} removes {result.drop(law):.0%}"
                     for law in result.laws)
    sign = low.sign if low is not None else 0
    if sign > 0:
        return _low_band_damping(sel, scorer, fit, hold, focus, low, result, model)
    if sign < 0:
        usable = [law for law in usable if law.name in TIMING]
    if not usable or (not sign and result.drop(usable[0]) < MIN_LOOP_DROP):
        sel.notes.append(f"loop laws as prediction errors: none removes {MIN_LOOP_DROP:.1%} "
                         f"of the held-out innovation ratio ({said})")
        return sel
    best, twin, lag_ratio = usable[0], None, None
    if best.name in TIMING:
        best, twin, lag_ratio = _timing_by_spectrum(usable, model, sim, scorer.ctx.flight, hold)
    cand, theta = BY_NAME[best.name], _theta(best)
    chosen = Fit((cand,), theta, np.full(theta.size, np.nan), cand.build(theta, scorer.ctx))
    sel.chosen = score_fit(chosen, scorer, hold, sel.z_before, sel.excess, focus)
    sel.look_alike = (best.name, twin.name) if twin is not None else None
    sel.companion_share = None
    sel.response = {law.name: max(result.drop(law), 0.0) for law in usable}
    if sign:  # the low band found the shift
        sel.response = {name: 0.5 + share for name, share in sel.response.items()}
    if lag_ratio is not None:  # the spectrum, not the drops, tells the timing laws apart
        sel.response[best.name] = max(sel.response.values()) + 0.5
    sel.loop = LoopChoice(result, model, best, low if sign else None, lag_ratio)
    sel.notes.append(f"loop laws as prediction errors ({model.nominal.delay * 1e3:.0f} ms "
                     f"delay, {model.nominal.tau * 1e3:.0f} ms lag on SIM): {said} of the "
                     "held-out innovation ratio")
    return sel


def _low_band_damping(sel: Selection, scorer: Scorer, fit: np.ndarray, hold: np.ndarray,
                      focus: tuple[str, ...], low: LowBandReading, result: LoopFit,
                      model: WhitenedModel) -> Selection:
    """A rate damping named at the low band's value on REAL's fit part."""
    cand = BY_NAME["rate_damping"]
    theta = np.array([low.fit.value, 0.0])
    chosen = Fit((cand,), theta, np.array([low.fit.stderr, np.nan]),
                 cand.build(theta, scorer.ctx))
    sel.chosen = score_fit(chosen, scorer, hold, sel.z_before, sel.excess, focus)
    sel.look_alike, sel.companion_share = None, None
    sel.response = {"rate_damping": 1.0}
    real, mods = scorer.ctx.flight, _mods("damping", low.fit.value)
    law = LoopLaw("rate_damping", low.fit.value, innovation_ratio(model, real, mods, fit),
                  innovation_ratio(model, real, mods, hold))
    sel.loop = LoopChoice(result, model, law, low)
    return sel


def loop_companion(sel: Selection, sim: Flight, scorer: Scorer, focus: tuple[str, ...],
                   fit: np.ndarray, hold: np.ndarray, model: WhitenedModel) -> Selection:
    """A timing law beside one other effect the 8 Hz fit named: when REAL's held-out
    innovation ratio under that effect is still beyond :data:`LOOP_RATIO`, or the low band
    under it reads a lower damping (:mod:`etsid.gap.damping`), the delay or lag removing the
    most of it (≥ :data:`MIN_LOOP_DROP`, at no bound) joins as its companion (PyFlyt's
    thrust scale + delay pairs: the thrust scale is named from the vertical force, the
    delay's roll and pitch stay within their floors). A pair of the 8 Hz fit with one loop
    law is first taken back to its other effect (:func:`_without_loop_part`)."""
    first = sel.chosen
    if first is not None and len(first.fit.candidates) == 2:
        alone = _without_loop_part(sel)
        if alone is None:
            return sel
        sel.notes.append(f"{first.fit.name} from the 8 Hz fit: its loop part is left to the "
                         "loop's own readings over a loop that answers its noise")
        sel.chosen = first = alone
        sel.companion_share = None
        if sel.look_alike is not None and sel.look_alike[0] != alone.fit.name:
            sel.look_alike = None
    if first is None or len(first.fit.candidates) != 1:
        return sel
    real = scorer.ctx.flight
    result = fit_loop_laws(model, real, fit, hold, first.fit.mods)
    low = low_band_reading(model, sim, real, fit, hold, first.fit.mods)
    slower = low.sign < 0
    if 1.0 / LOOP_RATIO < result.base_hold < LOOP_RATIO and not slower:
        return sel
    # only a timing law: beside a thrust-type effect (a thrust scale, a payload's higher hover
    # throttle, a sagging pack) the loop's gain moves as under an inertia or a damping change
    usable = [law for law in result.laws
              if law.name in TIMING and not at_bound(BY_NAME[law.name], _theta(law))]
    if not usable or (result.drop(usable[0]) < MIN_LOOP_DROP and not slower):
        return sel
    best, twin, lag_ratio = _timing_by_spectrum(usable, model, sim, real, hold, first.fit.mods)
    cand, theta = BY_NAME[best.name], _theta(best)
    field = LAWS[best.name]
    joint = Fit((*first.fit.candidates, cand), np.concatenate([first.fit.theta, theta]),
                np.concatenate([first.fit.stderr, np.full(theta.size, np.nan)]),
                _mods(field, best.value, first.fit.mods))
    sel.chosen = score_fit(joint, scorer, hold, sel.z_before, sel.excess, focus)
    sel.companion_share = max(result.drop(best), 0.5 if slower else 0.0)
    sel.loop = LoopChoice(result, model, best, low if slower else None, lag_ratio)
    if twin is not None and sel.look_alike is None:  # a first effect's own is said instead
        sel.look_alike = (best.name, twin.name)
    return sel


def _without_loop_part(sel: Selection) -> Scored | None:
    """The other effect of a pair the 8 Hz fit named with one law of :data:`LAWS`, as it was
    fitted alone (None for any other pair). Over a loop that answers its noise the 8 Hz fit
    reads that loop law off the loop's answer (330-11: a thrust scale + delay came out mass
    + an inertia ×0.61), so the loop part is left to the loop's own readings."""
    parts = [c.name for c in sel.chosen.fit.candidates] if sel.chosen else []
    rest = [name for name in parts if name not in LAWS]
    if len(parts) != 2 or len(rest) != 1:
        return None
    return next((s for s in sel.ranked if s.fit.name == rest[0]), None)


def _timing_by_spectrum(usable: list[LoopLaw], model: WhitenedModel, sim: Flight,
                        real: Flight, hold: np.ndarray, mods: Mods | None = None
                        ) -> tuple[LoopLaw, LoopLaw | None, float]:
    """(timing law, its undecided look-alike or None, REAL's low-band power ratio): the motor
    lag when REAL's whitened errors (under ``mods``, held-out part) carry
    :data:`LAG_EXCESS` × SIM's power in :data:`LAG_BAND_HZ`, else the delay. ``usable`` holds
    the fitted timing laws; the chosen one must be among them."""
    ratio = band_power(model, real, mods or Mods(), hold, LAG_BAND_HZ) / band_power(
        model, sim, Mods(), sim.airborne, LAG_BAND_HZ)
    by_name = {law.name: law for law in usable if law.name in TIMING}
    wanted = "motor_lag" if ratio >= LAG_EXCESS else "time_delay"
    law = by_name.get(wanted) or next(iter(by_name.values()))
    other = next((x for name, x in by_name.items() if name != law.name), None)
    undecided = LAG_UNDECIDED[0] <= ratio <= LAG_UNDECIDED[1] or law.name != wanted
    return law, other if undecided else None, ratio


@dataclass
class LoopChoice:
    """A loop law named from the prediction-error fit."""

    fit: LoopFit
    model: WhitenedModel
    law: LoopLaw
    low: LowBandReading | None = None
    """The low-band reading that found the shift, when it did."""
    lag_ratio: float | None = None
    """REAL's whitened error power in :data:`LAG_BAND_HZ` over SIM's, for a timing law."""

    def evidence(self, sim_name: str, real_name: str) -> str:
        """The named effect's evidence sentence."""
        signature = BY_NAME[self.law.name].signature
        lead = f"{signature[0].upper()}{signature[1:]}; {sim_name}'s loop answers noise its " \
               "log does not hold"
        drop = (f"{self.fit.drop(self.law):.0%} of {real_name}'s held-out innovation ratio "
                f"({self.fit.base_hold:.2f} → {self.law.hold_ratio:.2f} of {sim_name}'s)")
        if self.low is None:
            return (f"{lead}, so the law was fitted to {real_name}'s prediction errors under "
                    f"{sim_name}'s noise model (roll/pitch laws refitted on whitened errors)"
                    f"{self._timing()}: it removes {drop}; the 8 Hz band cannot judge it there")
        shift = self.low.hold
        read = (f"below {LOW_BAND_HZ:g} Hz, where the rates follow the setpoints, "
                f"{real_name}'s prediction errors under {sim_name}'s noise model fall with the "
                f"rates by {shift.value:+.2g} ± {shift.stderr:.1g} /s against {sim_name}'s "
                f"({self.low.fit.z:+.1f} SE on the fit part, {shift.z:+.1f} held out, "
                f"{self.low.pooled_z:+.1f} pooled)")
        if self.law.name == "rate_damping":
            return f"{lead}, so the damping was read in the low band: {read}; it removes {drop}"
        return (f"{lead}; {read}: the loop answers more noise there, as behind a slower motor "
                f"or a later command{self._timing()}; it removes {drop}")

    def _timing(self) -> str:
        """Why this timing law and not the other."""
        if self.lag_ratio is None:
            return ""
        if self.law.name == "motor_lag":
            return (f"; its whitened errors carry {self.lag_ratio:.1f}× the simulation's "
                    f"power below {LAG_BAND_HZ[1]:g} Hz, where a slower motor lets through more "
                    "of the noise that enters before its lag (a delay does not)")
        return (f"; its whitened errors carry {self.lag_ratio:.1f}× the simulation's power "
                f"below {LAG_BAND_HZ[1]:g} Hz, less than a slower motor's noise would add "
                f"({LAG_EXCESS:g}×), so a delay")

    def as_dict(self) -> dict[str, Any]:
        """gap.json's ``loop_fit``."""
        return {"sim_delay_s": self.model.nominal.delay, "sim_tau_s": self.model.nominal.tau,
                "innovation_ratio_before": self.fit.base_hold,
                "innovation_ratio_after": self.law.hold_ratio,
                "laws": [{"name": law.name, "value": law.value, "drop": self.fit.drop(law)}
                         for law in self.fit.laws],
                "named_from_low_band": self.low is not None,
                "lag_band_power_ratio": self.lag_ratio}
