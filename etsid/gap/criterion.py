"""The one criterion of ``etsid gap``: held-out log-likelihood gain over the null.

REAL's airborne evidence is cut into blocks of :data:`BLOCK_S` dealt alternately to
:data:`N_FOLDS` folds (blocked cross-validation: neighbouring samples of a low-passed
signal are not independent, whole blocks are). For every candidate model — the null
(SIM's nominal model unchanged), every single effect of the registry and greedy pairs —
the parameters are fitted on all folds but one and the model is scored on the one left
out, fold by fold. The score is the log-likelihood of the held-out *innovations* under
the noise model (:mod:`etsid.gap.noise`): per channel, the residual whitened by SIM's AR
filter, Gaussian with the deviation the model reaches on its own fitting folds, never
below the channel's floor. A model's gain is its summed held-out log-likelihood minus the
null's; only channels a model changes can differ from the null, so the gain sums over them.
On a sensor-consistency channel the null carries the flight's own offset (``β + u``, β
drawn once per flight from the between-flight spread), so a model gains there at most half
REAL's offset statistic ``z²`` over the flight, shared among the folds by their samples
(:meth:`LikelihoodScorer._offset_evidence`).

A model is named when its gain per scored sample exceeds the calibrated threshold
(:mod:`etsid.gap.calibration`), or its per-flight gain on a sensor-consistency channel
exceeds half the offset law's limit there (:func:`named_single`); a second effect is
added only when the pair's gain over the best single passes the same threshold. The
weights of the candidates are pseudo-BMA+ (Yao et al. 2018): softmax of the held-out
log-likelihoods under a Bayesian bootstrap of the blocks, so that two look-alikes whose
predictions the logs cannot separate share their weight.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from etsid.gap.calibration import Calibration
from etsid.gap.candidates import Candidate
from etsid.gap.fitting import Fit, Scorer, SharedMasks, channels_of, fit_candidates
from etsid.gap.noise import NoiseModel, offset_z2
from etsid.gap.signals import true_runs

N_FOLDS = 2
"""Folds of REAL's evidence: each model is fitted twice (on one half, scored on the other);
more folds cost a fit each."""
BLOCK_S = 4.0
"""Block length, s: several times the slowest closed-loop time constants (≤ 1 s) so that
blocks are nearly independent."""
GAP_S = 0.5
"""Samples scored only from this long after a block starts: the 8 Hz low-pass and the AR
filter carry the neighbouring block's samples that long (≪ 0.5 s)."""
BOOTSTRAP = 400
"""Bayesian-bootstrap draws of the pseudo-BMA+ weights (Monte-Carlo error ≈ 1/√400)."""
PAIR_POOL = 4
"""Pairs are built on at most this many singles (the best, those tied with it, then the next
best above the threshold), each with this many next best distinct singles."""
SCREEN_SHARE = 0.5
"""A single whose first-fold gain per sample is below this share of the threshold is not
refitted on the other fold (it cannot be named); its gain is extrapolated from the first."""
BOOTSTRAP_SEED = 20261128


@dataclass
class Folds:
    """Blocked folds of REAL's evidence.

    Attributes
    ----------
    score : list of ndarray
        Per fold, the samples it scores (bool masks).
    fit : list of ndarray
        Per fold, the samples its model is fitted on (every other fold).
    block : ndarray
        Per sample, the index of its block (−1 outside every scored block).
    n_blocks : int
    """

    score: list[np.ndarray]
    fit: list[np.ndarray]
    block: np.ndarray
    n_blocks: int


def make_folds(mask: np.ndarray, fs: float, n_folds: int = N_FOLDS,
               block_s: float = BLOCK_S, gap_s: float = GAP_S) -> Folds:
    """Blocks along REAL's airborne runs, dealt to folds in turn (by time)."""
    n_block = max(round(block_s * fs), 4)
    n_gap = round(gap_s * fs)
    block = np.full(mask.size, -1, dtype=int)
    score = [np.zeros(mask.size, dtype=bool) for _ in range(n_folds)]
    k = 0
    for a, b in true_runs(mask):
        for start in range(a, b, n_block):
            lo, hi = start + n_gap, min(start + n_block, b)
            if hi - lo < max(n_block // 4, 2):
                continue
            score[k % n_folds][lo:hi] = True
            block[lo:hi] = k
            k += 1
    fit = [mask & ~s for s in score]
    return Folds(score, fit, block, k)


def block_se(per_block: np.ndarray) -> float:
    """Standard error of a sum over blocks from the blocks' spread, in its unit (inf with
    fewer than two blocks)."""
    if per_block.size < 2:
        return float(np.inf)
    return float(np.sqrt(per_block.size) * np.std(per_block, ddof=1))


@dataclass
class Evaluated:
    """One candidate model scored by the criterion.

    Attributes
    ----------
    name : str
        ``a`` or ``a+b`` (the null is ``"none"``).
    candidates : tuple of Candidate
    fits : list of Fit
        Per fold, the fit on that fold's fitting samples.
    loglik : ndarray
        (n_blocks,) held-out log-likelihood per block, nats, summed over the channels the
        model changes (the null's over the same channels subtracted: a gain).
    n_scored : int
        Samples scored (all folds).
    extrapolated : bool
        Scored on one fold only (screened out), the rest extrapolated.
    """

    name: str
    candidates: tuple[Candidate, ...]
    fits: list[Fit]
    gain_blocks: np.ndarray
    n_scored: int
    extrapolated: bool = False
    weight: float = 0.0
    refused: str = ""
    extra_se: float | None = None
    """A pair's: standard error of its gain over its first effect, nats (blocks)."""
    by_channel: dict[str, tuple[float, int]] = field(default_factory=dict)
    """Channel → (held-out gain on it, nats; its scored samples): a sensor-consistency
    channel is read at its own, lower rate."""

    @property
    def gain(self) -> float:
        """Held-out log-likelihood gain over the null, nats."""
        return float(np.sum(self.gain_blocks))

    @property
    def per_sample(self) -> float:
        """Gain per scored sample, nats."""
        return self.gain / max(self.n_scored, 1)

    @property
    def gain_se(self) -> float:
        """Standard error of the gain from its block-to-block spread, nats."""
        return block_se(self.gain_blocks)


@dataclass
class Criterion:
    """What the criterion saw: the null's fit to REAL and every model's held-out gain."""

    folds: Folds
    ratio: dict[str, float]
    """Channel → REAL's innovation variance under the null over its floor's (all
    evidence)."""
    offset: dict[str, tuple[float, int]] = field(default_factory=dict)
    """Sensor-consistency channel → (REAL's offset statistic under the null,
    :func:`etsid.gap.noise.offset_z2`, and the draws k of its F(1, k) law)."""
    models: list[Evaluated] = field(default_factory=list)
    after_lead: dict[str, Any] = field(default_factory=dict)
    """The best single's name and REAL's held-out ``ratio`` and ``offset`` under it (as
    :attr:`ratio` and :attr:`offset`): what a second effect could still explain."""
    chosen: Evaluated | None = None
    notes: list[str] = field(default_factory=list)


class LikelihoodScorer:
    """Held-out innovation log-likelihoods of a model on REAL, per block."""

    def __init__(self, scorer: Scorer, noise: NoiseModel, folds: Folds) -> None:
        self.scorer = scorer
        self.noise = noise
        self.folds = folds
        self.channels = tuple(c for c in scorer.measured if c in noise.channels
                              and c in scorer.sigma)
        null = scorer.residuals(None, self.channels)
        self.null_innov = noise.innovations(null)
        self.null_ll = {c: [self._loglik(c, self.null_innov[c], k) for k in range(len(
            folds.score))] for c in self.channels}
        self.offset_evidence = self._offset_evidence()

    def _offset_evidence(self) -> dict[str, tuple[float, np.ndarray]]:
        """Sensor-consistency channel → (½ z², REAL's offset statistic under the null over
        all folds, nats; per fold, its share of the channel's scored innovations).

        On these channels the null is ``β + u`` with the flight's offset β ~ N(0, τ²)
        (:mod:`etsid.gap.noise`). Against that null's marginal likelihood, a model that
        removes REAL's offset entirely gains ``½ z² + ½ ln(1 + m c²τ²/σ²)``; the log term
        is the Occam factor of a parameter fitted by the data (what held-out scoring charges
        a fitted offset), so ``½ z²`` is the most a model can gain there. Without this, a
        fitted offset within the between-flight spread gains ``½ m (cβ)²/σ²``, growing
        with the m samples of the flight."""
        out: dict[str, tuple[float, np.ndarray]] = {}
        mask = self._scored()
        for c in self.channels:
            if self.noise.channels[c].offset_dof <= 0:
                continue
            z2 = offset_z2(self.noise.channels[c], self.null_innov[c], mask)
            ok = np.isfinite(self.null_innov[c])
            counts = np.array([np.sum(s & ok) for s in self.folds.score], dtype=float)
            if np.isfinite(z2) and counts.sum() > 0:
                out[c] = (0.5 * z2, counts / counts.sum())
        return out

    def _capped(self, c: str, per_fold: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
        """A sensor-consistency channel's per-sample gains of the scored folds, scaled down
        so that their sum is at most those folds' share of ``½ z²``
        (:meth:`_offset_evidence`); other channels' unchanged."""
        if c not in self.offset_evidence or not per_fold:
            return per_fold
        half_z2, share = self.offset_evidence[c]
        cap = half_z2 * float(sum(share[k] for k in per_fold))
        total = float(sum(np.nansum(d) for d in per_fold.values()))
        if total <= cap:
            return per_fold
        return {k: d * (cap / total) for k, d in per_fold.items()}

    def _loglik(self, c: str, innov: np.ndarray, k: int) -> np.ndarray:
        """Per-sample log-likelihood of fold ``k``'s samples (NaN elsewhere) with the
        deviation reached on that fold's fitting samples, floored."""
        fit = self.folds.fit[k] & np.isfinite(innov)
        var = float(np.mean(innov[fit] ** 2)) if np.any(fit) else 0.0
        var = max(var, self.noise.channels[c].floor_var)
        out = np.full(innov.size, np.nan)
        s = self.folds.score[k] & np.isfinite(innov)
        out[s] = -0.5 * (np.log(2 * np.pi * var) + innov[s] ** 2 / var)
        return out

    def blocks(self, per_sample: np.ndarray) -> np.ndarray:
        """Sum of a per-sample series over each block."""
        ok = (self.folds.block >= 0) & np.isfinite(per_sample)
        return np.bincount(self.folds.block[ok], weights=per_sample[ok],
                           minlength=self.folds.n_blocks)

    def gain(self, fits: list[Fit | None], base: list[Fit] | None = None
             ) -> tuple[np.ndarray, int, dict[str, tuple[float, int]]]:
        """(per-block gain over the null, samples scored, channel → (gain, its scored
        samples)) of the fold fits ``fits`` (None: that fold not scored)."""
        n = 0
        per_channel: dict[str, dict[int, np.ndarray]] = {}
        for k, fit in enumerate(fits):
            if fit is None:
                continue
            chans = channels_of(fit.candidates + (base[k].candidates if base else ()),
                                self.scorer)
            chans = tuple(c for c in chans if c in self.channels)
            res = self.scorer.residuals(fit.mods, chans)
            innov = self.noise.innovations(res)
            for c in chans:
                per_channel.setdefault(c, {})[k] = (self._loglik(c, innov[c], k)
                                                    - self.null_ll[c][k])
            n += int(np.sum(self.folds.score[k]))
        total = np.zeros(self.folds.n_blocks)
        by_channel: dict[str, tuple[float, int]] = {}
        for c, per_fold in per_channel.items():
            for d in self._capped(c, per_fold).values():
                total += self.blocks(d)
                g0, n0 = by_channel.get(c, (0.0, 0))
                by_channel[c] = (g0 + float(np.nansum(d)), n0 + int(np.sum(np.isfinite(d))))
        return total, n, by_channel

    def _scored(self, n_folds: int | None = None) -> np.ndarray:
        """Samples scored by the first ``n_folds`` folds (all by default)."""
        mask = np.zeros(self.folds.block.size, dtype=bool)
        for s in self.folds.score[:n_folds]:
            mask |= s
        return mask

    def _innovations(self, mods) -> dict[str, np.ndarray]:
        """Innovations of every channel under ``mods`` (None: the null's)."""
        if mods is None:
            return self.null_innov
        return self.noise.innovations(self.scorer.residuals(mods, self.channels))

    def _ratio_of(self, innov: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, float]:
        return {c: float(np.nanmean(innov[c][mask] ** 2) / self.noise.channels[c].floor_var)
                for c in self.channels}

    def _offsets_of(self, innov: dict[str, np.ndarray], mask: np.ndarray
                    ) -> dict[str, tuple[float, int]]:
        return {c: (offset_z2(self.noise.channels[c], innov[c], mask),
                    self.noise.channels[c].offset_dof)
                for c in self.channels if self.noise.channels[c].offset_dof > 0}

    def offset_tests(self) -> dict[str, tuple[float, int]]:
        """Sensor-consistency channel → (the variance the offset statistic divides a squared
        offset by, per unit of the channel: ``τ² + s²/(m (1 − Σa)²)`` with ``s`` the
        channel's innovation floor and ``m`` its scored innovations; the draws k of τ):
        the mismatch rule's test of a constant offset, for the detectable sizes."""
        mask = self._scored()
        out = {}
        for c in self.channels:
            ch = self.noise.channels[c]
            m = int(np.sum(mask & np.isfinite(self.null_innov[c])))
            if ch.offset_dof <= 0 or m < 2:
                continue
            dc2 = max(ch.dc_gain ** 2, 1e-12)
            out[c] = (ch.offset_sd ** 2 + ch.sigma ** 2 / (m * dc2), ch.offset_dof)
        return out

    def ratio(self, mods=None) -> dict[str, float]:
        """Channel → innovation variance over all evidence ÷ floor variance."""
        return self._ratio_of(self._innovations(mods), self._scored())

    def offsets(self, mods=None) -> dict[str, tuple[float, int]]:
        """Sensor-consistency channel → (offset statistic over all evidence, its draws k)."""
        return self._offsets_of(self._innovations(mods), self._scored())

    def held_out(self, ev: Evaluated) -> tuple[dict[str, float], dict[str, tuple[float, int]]]:
        """(:meth:`ratio`, :meth:`offsets`) of REAL under model ``ev``, each fold's samples
        predicted by the fit made without them (held out)."""
        chans = tuple(c for c in channels_of(ev.candidates, self.scorer) if c in self.channels)
        innov = {c: v.copy() for c, v in self.null_innov.items()}
        n_folds = min(len(ev.fits), len(self.folds.score))
        for k in range(n_folds):
            fold = self.noise.innovations(self.scorer.residuals(ev.fits[k].mods, chans))
            s = self.folds.score[k]
            for c in chans:
                innov[c][s] = fold[c][s]
        mask = self._scored(n_folds)
        return self._ratio_of(innov, mask), self._offsets_of(innov, mask)


def offset_limit(dof: int, n_channels: int, rate: float) -> float:
    """Largest offset statistic a no-effect flight reaches at false-positive ``rate`` over
    ``n_channels`` sensor-consistency channels: the F(1, dof) quantile at 1 − rate /
    n_channels (Bonferroni; textbook statistics, no calibrated number but the rate)."""
    return float(stats.f.ppf(1.0 - rate / max(n_channels, 1), 1, max(dof, 1)))


def mismatched(ratio: dict[str, float], offset: dict[str, Any], cal: Calibration
               ) -> list[str]:
    """Channels that depart from SIM's model beyond a no-effect flight, largest first: a
    dynamic channel by its innovation-variance ratio over ``cal.mismatch_ratio``, a
    sensor-consistency channel by its offset statistic over :func:`offset_limit`
    (``offset`` maps channel → (statistic, draws), as in gap.json)."""
    out = []
    for c, v in ratio.items():
        if c in offset:
            z2, dof = offset[c]
            if np.isfinite(z2) and z2 > offset_limit(int(dof), len(offset),
                                                    cal.false_positive_rate):
                out.append((z2 / offset_limit(int(dof), len(offset), cal.false_positive_rate)
                            * cal.mismatch_ratio, c))
        elif v > cal.mismatch_ratio:
            out.append((v, c))
    return [c for _, c in sorted(out, reverse=True)]


def _fold_fits(cands: tuple[Candidate, ...], ls: LikelihoodScorer, folds: Folds,
               folds_to_fit: range, x0: np.ndarray | list[np.ndarray] | None = None,
               shared: SharedMasks | None = None) -> list[Fit | None]:
    """Per fold, the fit on its fitting samples (None for a fold not in ``folds_to_fit``);
    a multi-parameter fit starts from ``x0``; ``shared``: the model's objective values over
    every fold's fitting samples (:class:`~etsid.gap.fitting.SharedMasks`)."""
    fits: list[Fit | None] = [None] * len(folds.score)
    for k in folds_to_fit:
        fits[k] = fit_candidates(cands, ls.scorer, folds.fit[k], x0=x0, shared=shared)
    return fits


def evaluate(cands: tuple[Candidate, ...], ls: LikelihoodScorer, threshold: float,
             x0: np.ndarray | list[np.ndarray] | None = None, screen: bool = True,
             base: Evaluated | None = None) -> Evaluated:
    """One model through the folds (screened after the first fold when far below the
    threshold; with ``base``, when its gain over ``base`` on that fold is)."""
    folds = ls.folds
    shared = SharedMasks(folds.fit)  # one prediction scores every fold's fitting samples
    fits = _fold_fits(cands, ls, folds, range(1), x0=x0, shared=shared)
    g, n, by_channel = ls.gain(fits)
    extrapolated = False
    ref = 0.0
    if base is not None:
        s0 = folds.score[0]
        ref = float(base.gain_blocks[np.unique(folds.block[s0 & (folds.block >= 0)])].sum())
    if screen and (g.sum() - ref) / max(n, 1) < SCREEN_SHARE * threshold:
        # the other folds as this one: the same gain per scored sample
        n_all = int(sum(np.sum(s) for s in folds.score))
        g = g * (n_all / max(n, 1))
        by_channel = {c: (v * n_all / max(n, 1), round(m * n_all / max(n, 1)))
                      for c, (v, m) in by_channel.items()}
        n, extrapolated = n_all, True
    else:
        assert fits[0] is not None
        rest = _fold_fits(cands, ls, folds, range(1, len(folds.score)),
                          x0=fits[0].theta if fits[0].theta.size > 1 else None, shared=shared)
        rest[0] = fits[0]
        g, n, by_channel = ls.gain(rest)
        fits = rest
    name = "+".join(c.name for c in cands)
    extra_se = None
    if base is not None and g.size > 1:
        extra_se = block_se(g - base.gain_blocks)
    return Evaluated(name, cands, [f for f in fits if f is not None], g, n, extrapolated,
                     extra_se=extra_se, by_channel=by_channel)


def pseudo_bma(models: list[Evaluated], seed: int = BOOTSTRAP_SEED) -> np.ndarray:
    """Pseudo-BMA+ weights of ``models`` (the null is implied with gain 0 and is the last
    weight): softmax of each model's block-summed held-out log-likelihood, averaged over
    Bayesian-bootstrap reweightings of the blocks."""
    if not models:
        return np.array([1.0])
    g = np.vstack([m.gain_blocks for m in models] + [np.zeros_like(models[0].gain_blocks)])
    nb = g.shape[1]
    rng = np.random.default_rng(seed)
    alpha = rng.dirichlet(np.ones(nb), size=BOOTSTRAP) * nb
    elpd = alpha @ g.T  # (draws, models)
    elpd -= elpd.max(axis=1, keepdims=True)
    w = np.exp(elpd)
    w /= w.sum(axis=1, keepdims=True)
    return w.mean(axis=0)


def significant(gain: float, se: float | None, n_tested: int, rate: float) -> bool:
    """Whether a held-out gain (nats) is above zero beyond chance: ``gain / se`` over the
    one-sided normal quantile at ``rate`` shared by the ``n_tested`` models tried
    (Bonferroni; ``se`` from the block-to-block spread; None or non-finite: not known, true).
    Textbook statistics, nothing calibrated but the rate."""
    if se is None or not np.isfinite(se) or se <= 0:
        return True
    return gain > float(stats.norm.ppf(1.0 - rate / max(n_tested, 1))) * se


def _get(m: Any, key: str) -> Any:
    """A field of an :class:`Evaluated` or of its gap.json row."""
    return m.get(key, "") if isinstance(m, dict) else getattr(m, key)


def beyond_offset_null(m: Any, offset: dict[str, Any] | None, cal: Calibration) -> bool:
    """Whether a model's held-out gain on some sensor-consistency channel exceeds what a
    no-effect flight reaches there at ``cal``'s rate: ``½`` :func:`offset_limit` (its gain
    on the channel is at most ``½ z²``, z² ~ F(1, k) under no effect; Bonferroni over the
    channels of ``offset``, channel → (statistic, draws k)). The per-flight counterpart of
    the per-sample threshold, which a per-flight offset's evidence does not grow into."""
    if not offset:
        return False
    by_channel = _get(m, "by_channel") or {}
    for c, (_, dof) in offset.items():
        if c in by_channel and float(by_channel[c][0]) > 0.5 * offset_limit(
                int(dof), len(offset), cal.false_positive_rate):
            return True
    return False


def named_single(m: Any, cal: Calibration, offset: dict[str, Any] | None = None,
                 n_singles: int | None = None) -> bool:
    """Whether a single's held-out gain is beyond the no-effect flights': per scored sample
    above ``cal.gain_per_sample`` (and :func:`significant` among the ``n_singles`` tried,
    when given), or on a sensor-consistency channel beyond :func:`beyond_offset_null`."""
    if beyond_offset_null(m, offset, cal):
        return True
    if float(_get(m, "per_sample")) <= cal.gain_per_sample:
        return False
    return n_singles is None or significant(float(_get(m, "gain")),
                                            _get(m, "gain_se") or None, n_singles,
                                            cal.false_positive_rate)


def choose(models: list[Any], cal: Calibration, after_lead: dict[str, Any] | None = None,
           offset: dict[str, Any] | None = None) -> str | None:
    """The name of the model the criterion names, or None.

    The best admissible single when :func:`named_single` (its held-out gain per scored
    sample exceeds ``cal.gain_per_sample`` and is :func:`significant` among the singles
    tried, or its gain on a sensor-consistency channel of ``offset`` is beyond the offset
    law's); joined by a second effect only while REAL, predicted by that single on held-out
    blocks (``after_lead``: its ``ratio`` and ``offset``), still has a mismatched channel,
    and when the pair's gain over the single it was built on exceeds
    ``cal.pair_gain_per_sample`` per scored sample and is significant among the pairs
    tried, and its gain over the best single exceeds the same per-sample threshold (a pair
    built on a weaker single must beat the best one-effect answer by as much as a second
    effect must add). ``models`` are
    :class:`Evaluated` or their gap.json rows (``name``, ``gain``, ``gain_se``,
    ``extra_se``, ``per_sample``, ``n_scored``, ``refused``, ``by_channel``), so that a
    benchmark can decide recorded runs again under another calibration.
    """
    singles = sorted((m for m in models if "+" not in _get(m, "name")
                      and not _get(m, "refused")), key=lambda m: -_get(m, "gain"))
    n_singles = sum("+" not in _get(m, "name") for m in models)
    if not singles or not named_single(singles[0], cal, offset, n_singles):
        return None
    lead = singles[0]
    lead_gain = float(_get(lead, "gain"))
    best, best_gain = str(_get(lead, "name")), lead_gain
    if after_lead and after_lead.get("name") == best and not mismatched(
            after_lead["ratio"], after_lead.get("offset", {}), cal):
        return best
    base_of = {str(_get(m, "name")): m for m in singles}
    pairs = [m for m in models if "+" in str(_get(m, "name"))
             and str(_get(m, "name")).split("+")[0] in base_of and not _get(m, "refused")]
    for m in pairs:  # each pair over the single it was built on, and over the best single
        base = base_of[str(_get(m, "name")).split("+")[0]]
        extra = float(_get(m, "gain")) - float(_get(base, "gain"))
        n = max(_get(m, "n_scored"), 1)
        if (extra / n > cal.pair_gain_per_sample
                and (float(_get(m, "gain")) - lead_gain) / n > cal.pair_gain_per_sample
                and significant(extra, _get(m, "extra_se") or None, len(pairs),
                                cal.false_positive_rate)
                and float(_get(m, "gain")) > best_gain):
            best, best_gain = str(_get(m, "name")), float(_get(m, "gain"))
    return best


def tied_leads(usable: list[Evaluated], cal: Calibration, n_singles: int) -> list[Evaluated]:
    """The singles pairs are built on: the best admissible one, every other the held-out
    blocks cannot put behind it (gain per scored sample above the threshold, and below the
    best's by less than :func:`significant` asks of the paired block differences), then
    the next best above the threshold, :data:`PAIR_POOL` in all. Two look-alike leads (a
    motor lag and a delay) both get their pairs, and so does a single whose look-alike
    took the lead alone (a thrust scale + delay where a motor lag leads)."""
    lead = usable[0]
    out = [lead]
    for m in usable[1:]:
        if m.per_sample <= cal.gain_per_sample or m.gain_blocks.size != lead.gain_blocks.size:
            continue
        diff = lead.gain_blocks - m.gain_blocks
        tied = not significant(float(diff.sum()), block_se(diff), n_singles,
                               cal.false_positive_rate)
        if tied or len(out) < PAIR_POOL:  # then the next best above the threshold
            out.append(m)
    return out


def run_criterion(ls: LikelihoodScorer, library: tuple[Candidate, ...], cal: Calibration,
                  admissible) -> Criterion:
    """Every single, greedy pairs on the best single, the singles tied with it and the next
    best (:func:`tied_leads`), the weights and the chosen model.

    ``admissible(evaluated) -> str`` says why a model may not be named (verdict rules: at
    a bound, a channel made worse), "" when it may.
    """
    crit = Criterion(ls.folds, ls.ratio(), ls.offsets())
    threshold = min(cal.gain_per_sample, cal.pair_gain_per_sample)
    singles = [evaluate((c,), ls, threshold) for c in library]
    for s in singles:
        s.refused = admissible(s)
    # one entry per effect: its best form (a per-motor law: its best motor)
    best_of: dict[str, Evaluated] = {}
    for s in singles:
        if s.name not in best_of or s.gain > best_of[s.name].gain:
            best_of[s.name] = s
    ranked = sorted(best_of.values(), key=lambda m: -m.gain)
    models = list(ranked)
    usable = [m for m in ranked if not m.refused]
    if usable and named_single(usable[0], cal, crit.offset):
        lead = usable[0]
        ratio, offset = ls.held_out(lead)
        crit.after_lead = {"name": lead.name, "ratio": ratio, "offset": offset}
        left = mismatched(ratio, offset, cal)  # nothing left: no second effect to seek
        tried: set[frozenset[str]] = set()
        for base in tied_leads(usable, cal, len(ranked)) if left else ():
            for other in [m for m in usable if m is not base][:PAIR_POOL]:
                key = frozenset((base.name, other.name))
                if key in tried:
                    continue
                tried.add(key)
                # the two single fits together, or the lead's alone with the other at no
                # effect (where two look-alikes' fits together count the change twice)
                lead_theta = base.fits[0].theta
                x0 = [np.concatenate([lead_theta, other.fits[0].theta]),
                      np.concatenate([lead_theta, *(c.null_theta() for c in other.candidates)])]
                pair = evaluate(base.candidates + other.candidates, ls,
                                cal.pair_gain_per_sample, x0=x0, base=base)
                pair.refused = admissible(pair)
                models.append(pair)
    # weights over the models that may be named (one refused by a verdict rule, a
    # parameter at its bound or a channel made worse, is not an explanation of REAL), one
    # size at a time: a pair fits at least as well as its single, so weighed together
    # every single's weight would pass to its pairs and their companions' noise would
    # decide which of two look-alikes keeps it
    for size in (1, 2):
        admitted = [m for m in models if not m.refused and answer_size(m.name) == size]
        w = pseudo_bma(admitted)
        for m, wi in zip(admitted, w[:-1], strict=True):
            m.weight = float(wi)
    crit.models = models
    name = choose(models, cal, crit.after_lead or None, crit.offset)
    crit.chosen = next((m for m in models if m.name == name), None)
    return crit


def answer_size(name: str) -> int:
    """How many effects a model's name (``a`` or ``a+b``) joins."""
    return len(name.split("+"))


def effect_weight(crit: Criterion, name: str) -> float:
    """Total weight of the models that contain effect ``name``, among the models of the
    chosen answer's size (one effect or two; one when nothing is chosen)."""
    size = answer_size(crit.chosen.name) if crit.chosen is not None else 1
    return float(sum(m.weight for m in crit.models
                     if answer_size(m.name) == size and name in m.name.split("+")))
