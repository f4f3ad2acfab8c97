"""The rate loop's laws fitted as prediction errors, for a SIM whose loop answers noise.

Where SIM's rate loop mostly answers noise its log does not hold (:mod:`etsid.gap.loop`),
the least-squares command law is biased and the 8 Hz residuals cannot tell a delay, a
motor lag, an inertia or a rate-damping change apart. Here the roll and pitch laws are
refitted on SIM with a noise model: each channel's residual is whitened by an
autoregressive filter fitted to it (generalised least squares, iterated), and SIM's
command delay and motor lag are searched on that whitened error. Each loop law is then
fitted to REAL's whitened error (the innovations under SIM's noise model) on the fit part
and scored on the held-out part. The direct prediction-error method is consistent in a
closed loop when its noise model is right (Ljung, *System Identification*, 2nd ed., 1999,
ch. 13); an autoregressive filter of order :data:`AR_ORDER` at the log's rate is that
model here.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from etsid.gap.candidates import BY_NAME
from etsid.gap.fitting import Fit, Scorer
from etsid.gap.nominal import Mods, NominalModel, features
from etsid.gap.select import Selection, score_fit
from etsid.gap.signals import Flight, derivative, lowpass
from etsid.gap.verdict import at_bound

AR_ORDER = 6
"""Order of each channel's whitening filter (samples at the log's rate)."""
CUTOFF_HZ = 20.0
"""Low-pass of both the measured and the predicted angular accelerations, Hz: above the
8 Hz band, where a loop's answer to its noise lives, below the derivative's noise."""
GLS_ITERATIONS = 3
"""Whitening filter and law coefficients refitted in turn this many times."""
SIM_DELAYS_S = (0.0, 0.005, 0.01)
SIM_TAUS_S = (0.004, 0.007, 0.012)
"""SIM's command delay and motor lag searched on the whitened error, s."""
CHANNELS = ("p", "q")
"""Roll and pitch: yaw's laws (torque scale, rotor inertia) stay with the response tier."""
LAWS = {"time_delay": "delay", "motor_lag": "tau", "inertia_scale": "inertia",
        "rate_damping": "damping"}
"""Law → the :class:`Mods` field its first parameter sets, searched within that
parameter's bounds in :data:`etsid.gap.candidates.LIBRARY` (a rate damping here in roll
and pitch only: its yaw factor stays 0)."""
GRID = 16
"""Grid points per law before the bounded refinement (geometric for a positive range)."""


@dataclass
class WhitenedModel:
    """SIM's roll/pitch laws refitted on whitened errors, with each channel's noise model."""

    nominal: NominalModel
    """The nominal model with the refitted roll/pitch coefficients, delay and lag."""
    filters: dict[str, np.ndarray]
    """Channel → whitening filter (``[1, -a_1, …, -a_p]``)."""
    innovation: dict[str, float]
    """Channel → SIM's whitened mean square error, (rad/s²)²."""


def _ar_filter(e: np.ndarray) -> np.ndarray:
    """Least-squares autoregressive whitening filter of ``e``."""
    p = AR_ORDER
    x = np.column_stack([e[p - k - 1:e.size - k - 1] for k in range(p)])
    a, *_ = np.linalg.lstsq(x, e[p:], rcond=None)
    return np.concatenate([[1.0], -a])


def _whiten(filt: np.ndarray, x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``x`` (n,) or (n, k) through ``filt``, kept over ``mask``."""
    return lfilter(filt, [1.0], x, axis=0)[mask]


def _measured(flight: Flight) -> dict[str, np.ndarray]:
    acc = derivative(lowpass(flight.rates, flight.fs, CUTOFF_HZ), flight.fs)
    return {c: acc[:, j] for j, c in enumerate(("p", "q", "r")) if c in CHANNELS}


def fit_whitened(sim: Flight, nominal: NominalModel) -> WhitenedModel:
    """SIM's roll/pitch laws by generalised least squares on its airborne samples, for each
    command delay and motor lag of :data:`SIM_DELAYS_S` × :data:`SIM_TAUS_S`; the pair
    with the smallest whitened error is kept."""
    y = _measured(sim)
    mask = sim.airborne
    best: tuple[float, float, float, dict] | None = None
    for delay in SIM_DELAYS_S:
        for tau in SIM_TAUS_S:
            feats = features(sim, nominal.k, tau, Mods(), CHANNELS, delay)
            fits = {}
            for c in CHANNELS:
                x = lowpass(feats[c], sim.fs, CUTOFF_HZ)
                filt = np.array([1.0])
                for _ in range(GLS_ITERATIONS):
                    coef, *_ = np.linalg.lstsq(_whiten(filt, x, mask), _whiten(filt, y[c], mask),
                                               rcond=None)
                    filt = _ar_filter((y[c] - x @ coef)[mask])
                w = _whiten(filt, y[c] - x @ coef, mask)[AR_ORDER:]
                fits[c] = (coef, filt, float(np.var(w)))
            total = sum(v[2] for v in fits.values())
            if best is None or total < best[0]:
                best = (total, delay, tau, fits)
    assert best is not None
    _, delay, tau, fits = best
    model = copy.copy(nominal)
    model.coef = {**nominal.coef, **{c: fits[c][0] for c in CHANNELS}}
    model.delay, model.tau = delay, tau
    return WhitenedModel(model, {c: fits[c][1] for c in CHANNELS},
                         {c: fits[c][2] for c in CHANNELS})


def innovation_ratio(model: WhitenedModel, flight: Flight, mods: Mods, mask: np.ndarray,
                     y: dict[str, np.ndarray] | None = None) -> float:
    """Mean over roll and pitch of ``flight``'s whitened error variance under ``mods`` over
    ``mask``, each over SIM's own (1 for a flight like SIM's). The error's mean over
    ``mask`` is taken out first: a constant angular acceleration (a torque offset, a weak
    motor's trim) is no loop law."""
    y = y or _measured(flight)
    raw = model.nominal.predict_unfiltered(flight, mods, CHANNELS)
    ratios = []
    for c in CHANNELS:
        res = y[c] - lowpass(raw[c], flight.fs, CUTOFF_HZ)
        w = _whiten(model.filters[c], res - np.mean(res[mask]), mask)
        ratios.append(float(np.var(w)) / model.innovation[c])
    return float(np.mean(ratios))


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
    y = _measured(real)
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
TIMING_LOOK_ALIKE = 0.75
"""A timing law named with the other as its undecided look-alike when the other removes at
least this share of what it removes. On the seen sets the right one led by 0.51-0.70 of its
drop where it was right, and was led by 0.82-0.96 where it was not (7 pairs: a rule read
off few pairs, said as such in docs/gap.md)."""


def _theta(law: LoopLaw) -> np.ndarray:
    """The candidate's parameters for ``law`` (a rate damping's yaw factor 0)."""
    return np.array([law.value, 0.0] if law.name == "rate_damping" else [law.value])


def innovation_shift(model: WhitenedModel, real: Flight, hold: np.ndarray) -> float | None:
    """REAL's held-out innovation ratio under SIM's noise model when it is beyond
    :data:`LOOP_RATIO` either way, else None."""
    ratio = innovation_ratio(model, real, Mods(), hold)
    return ratio if ratio >= LOOP_RATIO or ratio <= 1.0 / LOOP_RATIO else None


def choose_loop_law(sel: Selection, sim: Flight, nominal: NominalModel, scorer: Scorer,
                    focus: tuple[str, ...], fit: np.ndarray, hold: np.ndarray,
                    model: WhitenedModel | None = None) -> Selection:
    """Where SIM's loop answers noise and roll or pitch is mismatched (``focus``) with only
    laws of :data:`LAWS`, or nothing, named by the 8 Hz fit: the law the prediction-error fit
    prefers, if it removes at least :data:`MIN_LOOP_DROP` of REAL's held-out innovation ratio
    and sits at no bound; ``sel`` is changed in place (its confidence source becomes the
    laws' held-out drops, :attr:`~etsid.gap.select.Selection.response`) and returned."""
    if sel.chosen is not None and any(part not in LAWS
                                      for part in sel.chosen.fit.name.split("+")):
        return loop_companion(sel, sim, nominal, scorer, focus, fit, hold)
    if not set(focus) & set(CHANNELS):
        return sel
    model = model or fit_whitened(sim, nominal)
    result = fit_loop_laws(model, scorer.ctx.flight, fit, hold)
    usable = [law for law in result.laws if not at_bound(BY_NAME[law.name], _theta(law))]
    said = ", ".join(f"{law.name} {law.value:.3g} removes {result.drop(law):.0%}"
                     for law in result.laws)
    if not usable or result.drop(usable[0]) < MIN_LOOP_DROP:
        sel.notes.append(f"loop laws as prediction errors: none removes {MIN_LOOP_DROP:.1%} "
                         f"of the held-out innovation ratio ({said})")
        return sel
    best = usable[0]
    cand, theta = BY_NAME[best.name], _theta(best)
    chosen = Fit((cand,), theta, np.full(theta.size, np.nan), cand.build(theta, scorer.ctx))
    sel.chosen = score_fit(chosen, scorer, hold, sel.z_before, sel.excess, focus)
    sel.look_alike, sel.companion_share = None, None
    _timing_twin(sel, result, usable)
    sel.response = {law.name: result.drop(law) for law in usable}
    sel.loop = LoopChoice(result, model, best)
    sel.notes.append(f"loop laws as prediction errors ({model.nominal.delay * 1e3:.0f} ms "
                     f"delay, {model.nominal.tau * 1e3:.0f} ms lag on SIM): {said} of the "
                     "held-out innovation ratio")
    return sel


def loop_companion(sel: Selection, sim: Flight, nominal: NominalModel, scorer: Scorer,
                   focus: tuple[str, ...], fit: np.ndarray, hold: np.ndarray) -> Selection:
    """A timing law beside one other effect the 8 Hz fit named: when REAL's held-out
    innovation ratio under that effect is still beyond :data:`LOOP_RATIO`, the delay or lag
    removing the most of it (≥ :data:`MIN_LOOP_DROP`, at no bound) joins as its companion
    (PyFlyt's thrust scale + delay pairs: the thrust scale is named from the vertical force,
    the delay's roll and pitch stay within their floors)."""
    first = sel.chosen
    if first is None or len(first.fit.candidates) != 1:
        return sel
    model = fit_whitened(sim, nominal)
    result = fit_loop_laws(model, scorer.ctx.flight, fit, hold, first.fit.mods)
    if 1.0 / LOOP_RATIO < result.base_hold < LOOP_RATIO:
        return sel
    # only a timing law: beside a thrust-type effect (a thrust scale, a payload's higher hover
    # throttle, a sagging pack) the loop's gain moves as under an inertia or a damping change
    usable = [law for law in result.laws
              if law.name in TIMING and not at_bound(BY_NAME[law.name], _theta(law))]
    if not usable or result.drop(usable[0]) < MIN_LOOP_DROP:
        return sel
    best = usable[0]
    cand, theta = BY_NAME[best.name], _theta(best)
    field = LAWS[best.name]
    joint = Fit((*first.fit.candidates, cand), np.concatenate([first.fit.theta, theta]),
                np.concatenate([first.fit.stderr, np.full(theta.size, np.nan)]),
                _mods(field, best.value, first.fit.mods))
    sel.chosen = score_fit(joint, scorer, hold, sel.z_before, sel.excess, focus)
    sel.companion_share = result.drop(best)
    sel.loop = LoopChoice(result, model, best)
    _timing_twin(sel, result, usable)
    return sel


def _timing_twin(sel: Selection, result: LoopFit, usable: list[LoopLaw]) -> None:
    """Say the other timing law as the named one's look-alike when it removes at least
    :data:`TIMING_LOOK_ALIKE` of what the named one does."""
    best = usable[0]
    twin = next((law for law in usable[1:] if {law.name, best.name} == set(TIMING)), None)
    if (twin is not None and result.drop(twin) >= TIMING_LOOK_ALIKE * result.drop(best)
            and sel.look_alike is None):  # a first effect's own look-alike is said instead
        sel.look_alike = (best.name, twin.name)


@dataclass
class LoopChoice:
    """A loop law named from the prediction-error fit."""

    fit: LoopFit
    model: WhitenedModel
    law: LoopLaw

    def evidence(self, sim_name: str, real_name: str) -> str:
        """The named effect's evidence sentence."""
        signature = BY_NAME[self.law.name].signature
        return (f"{signature[0].upper()}{signature[1:]}; {sim_name}'s loop answers noise its "
                f"log does not hold, so the law was fitted to {real_name}'s prediction errors "
                f"under {sim_name}'s noise model (roll/pitch laws refitted on whitened errors): "
                f"it removes {self.fit.drop(self.law):.0%} of {real_name}'s held-out "
                f"innovation ratio ({self.fit.base_hold:.2f} → {self.law.hold_ratio:.2f} of "
                f"{sim_name}'s); the 8 Hz band cannot judge it there")

    def as_dict(self) -> dict[str, Any]:
        """gap.json's ``loop_fit``."""
        return {"sim_delay_s": self.model.nominal.delay, "sim_tau_s": self.model.nominal.tau,
                "innovation_ratio_before": self.fit.base_hold,
                "innovation_ratio_after": self.law.hold_ratio,
                "laws": [{"name": law.name, "value": law.value, "drop": self.fit.drop(law)}
                         for law in self.fit.laws]}
