"""Judge a candidate signal against the other channels: physics that ties columns together
(rule 5 of :mod:`etsid.ingest.mapping`, with :mod:`etsid.ingest.source_check`).

A source can be complete and moving and still be wrong: a gyro topic in deg/s, a height
that is a rangefinder's garbage while the vehicle climbs, a specific force in g or with z
up. Three cheap checks, each on the reference span (``source_check.reference_span``: the
airborne part when the log says), each against a *referee* that is another column's
chosen signal (never the candidate's own column, so there is no circle):

- **body rates** ``p q r`` against the body rates the attitude's derivative implies (ZYX
  Euler kinematics, ``p = φ̇ − ψ̇ sin θ``, ``q = θ̇ cos φ + ψ̇ sin φ cos θ``,
  ``r = −θ̇ sin φ + ψ̇ cos φ cos θ``); referee: the chosen ``roll pitch yaw``;
- **height** ``alt`` (up) against the vertical velocity ``vz`` (NED, down):
  ``d(alt)/dt = −vz``; referee: the chosen ``vz``;
- **specific force** ``az`` (FRD) against gravity: averaged over the flight it is ``−g``
  times the mean cosine of the tilt, so its mean lies in :data:`AZ_MEAN_RANGE`; ``ax``
  and ``ay`` of the same message share its unit and frame and share its verdict.

Rates and height are compared on :data:`BIN_S` bins: a rate's mean in each bin against
the increment of the quantity it is the derivative of over the bin (the gyro's mean
against the attitude's increment; the height's increment against the mean of ``−vz``),
an exact integral whatever either's sample rate;
the least-squares gain ``k`` of candidate on referee is 1 for a sound source. The candidate
is *implausible* when ``k`` is outside :data:`GAIN_RANGE` by more than :data:`Z_SIGMA`
standard errors, or its correlation with the referee is below :data:`MIN_CORRELATION`, on
at least :data:`MIN_BINS` bins where the referee moves at least its excitation floor.
Without a referee, or with one too still, nothing is judged. A body-rate candidate whose
sibling (same topic, another of ``p q r``) is implausibly *scaled* (``k`` above the range:
deg/s read as rad/s) is implausible too, even where its own axis is too still to tell.
Samples beyond the limits of :mod:`etsid.ingest.plausibility` (damage ingest drops later)
take no part.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from etsid.ingest.base import Signal
from etsid.ingest.plausibility import STANDARD_GRAVITY, implausible_mask

BIN_S = 0.5
"""s: bin length; long enough that the lag between an estimator and a sensor (tens of ms)
and the noise of a 10 Hz attitude average out, short enough to follow a manoeuvre."""

MIN_BINS = 20
"""Least number of judged bins (10 s of flight): fewer say nothing about a unit."""

GAIN_RANGE = (0.5, 2.0)
"""Plausible gain of candidate on referee: filtering, lag and bias move a sound source's
gain by tens of percent; a unit or sign error moves it by ×57.3 (deg/s read as rad/s),
×0.0175 (the reverse), ×100 (cm) or ×−1 (frame), far outside a factor of two."""

Z_SIGMA = 3.0
"""Standard errors by which ``k`` must miss :data:`GAIN_RANGE` (a 0.1 % chance, one-sided,
for a sound source with independent bin errors)."""

MIN_CORRELATION = 0.3
"""Least correlation of a sound candidate with its referee (without centring): below it
the referee explains under 9 % of the candidate's motion — noise or another quantity, not
the same one filtered (filtering, lag and sparse sampling leave r well above 0.5)."""

MIN_RATE_RMS = 0.05
"""rad/s: the referee body rate must move at least this much (RMS over the bins), the level
below which identify calls an axis not informative; below it a gain is noise."""

MIN_CLIMB_RMS = 0.2
"""m/s: the referee −vz must move at least this much (RMS over the bins): well above an
estimator's vertical-velocity noise (≈0.05 m/s), so its errors do not shrink ``k``."""

OUTLIER_MADS = 5.0
"""A bin whose residual is beyond this many robust standard deviations (1.4826 × MAD) of
the first fit is dropped before the second: an aerobatic flip or a glitch the 10 Hz
attitude cannot follow, not a unit (a unit error scales every bin alike)."""

MAX_EULER_PITCH = 1.2
"""rad: bins whose pitch exceeds this (≈70°) are skipped; near ±90° the Euler yaw and roll
jump by π and their derivative says nothing about the body rates."""

SAMPLE_HZ = 50.0
"""Hz: a quantity whose increments are taken (attitude, height) and that is sampled faster
is thinned to between this and twice this rate first: 25 samples per bin place its edges
well, and an angle moves less than π between two of them below 157 rad/s, far beyond the
35 rad/s of a gyro's range (unwrapping holds)."""

MAX_BINS = 100_000
"""Most bins judged (14 h at :data:`BIN_S`, beyond any battery flight): a longer span is a
damaged clock, and nothing is judged on it."""

AZ_MEAN_RANGE = (-1.5 * STANDARD_GRAVITY, -0.5 * STANDARD_GRAVITY)
"""m/s²: plausible mean ``az`` over the flight. Mean acceleration over a flight is zero, so
the mean specific force is −g·cos(tilt) in FRD: −0.5 g needs a mean tilt of 60°, −1.5 g a
sustained 1.5 g pull; a source in g (≈ −1) or with z up (≈ +9.8) is far outside."""

MIN_AZ_SAMPLES = 10
"""Least samples of ``az`` in the span for its mean to be judged."""

RATE_COLUMNS = ("p", "q", "r")
FORCE_COLUMNS = ("ax", "ay", "az")
REFEREE_COLUMNS = ("roll", "pitch", "yaw", "vz")
"""Columns whose chosen signal referees others; they are chosen before the columns they
judge (:func:`etsid.ingest.mapping.choose_signals`)."""

AXIS_WORDS = {"p": "roll rate", "q": "pitch rate", "r": "yaw rate"}


def _edges(t0: float, t1: float) -> np.ndarray | None:
    """Bin edges over ``[t0, t1]``; None when the span is too short, too long or not
    finite."""
    if not (np.isfinite(t0) and np.isfinite(t1)) or not BIN_S <= t1 - t0 <= MAX_BINS * BIN_S:
        return None
    n = int((t1 - t0) // BIN_S)
    return t0 + BIN_S * np.arange(n + 1)


def _bin_index(t: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of each time in ``t`` (all inside ``[edges[0], edges[-1])``), by arithmetic on
    the uniform edges: O(n), no search."""
    idx = ((t - edges[0]) * (1.0 / BIN_S)).astype(np.intp)  # ≥ 0: truncation is floor
    return np.minimum(idx, edges.size - 2)


def _usable(sig: Signal) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, values, ok)``: ok where both are finite and the value is within the limits of
    :mod:`etsid.ingest.plausibility` (damaged samples ingest drops later must not judge a
    source)."""
    t = np.asarray(sig.t, dtype=float)
    v = np.asarray(sig.values, dtype=float)
    return t, v, np.isfinite(t) & np.isfinite(v) & ~implausible_mask(sig.column, v)


BIN_KERNEL_MIN = 1000
"""Fewest samples that :func:`bin_means` bins in one compiled pass once numba is loaded
(:mod:`etsid.ingest.bin_kernels`: no masked copies, no index array)."""


def bin_means(sig: Signal, edges: np.ndarray) -> np.ndarray:
    """Mean of ``sig``'s usable samples in each bin ``[edges[i], edges[i+1])``; NaN in a bin
    without samples."""
    t, v, ok = _usable(sig)
    n = edges.size - 1
    if "numba" in sys.modules and t.size > BIN_KERNEL_MIN and n > 0 and all(
            a.dtype == np.float64 and a.flags.c_contiguous for a in (t, v, edges)):
        from etsid.ingest.bin_kernels import bin_sums

        counts, sums = np.zeros(n, np.intp), np.zeros(n)
        bin_sums(t, v, ok, float(edges[0]), float(edges[-1]), 1.0 / BIN_S, counts, sums)
    else:
        ok &= (t >= edges[0]) & (t < edges[-1])
        idx = _bin_index(t[ok], edges)
        counts = np.bincount(idx, minlength=n)[:n]
        sums = np.bincount(idx, weights=v[ok], minlength=n)[:n]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def _samples(sig: Signal, unwrap: bool) -> tuple[np.ndarray, np.ndarray]:
    """Usable samples of ``sig`` in time order, thinned to about :data:`SAMPLE_HZ`
    (angles unwrapped when ``unwrap``)."""
    t, v, ok = _usable(sig)
    step = max(1, int(sig.rate_hz // SAMPLE_HZ))
    t, v = t[::step][ok[::step]], v[::step][ok[::step]]
    if t.size > 1 and np.any(t[1:] < t[:-1]):
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
    if unwrap and v.size > 1:
        turns = np.round(np.diff(v) * (0.5 / np.pi))
        v = v - 2.0 * np.pi * np.concatenate(([0.0], np.cumsum(turns)))
    return t, v


def bin_increments(sig: Signal, edges: np.ndarray, unwrap: bool = False
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``(increment over each bin, value at each bin's middle)`` of ``sig`` interpolated
    linearly (angles unwrapped when ``unwrap``); NaN in a bin without a sample of its own."""
    t, v = _samples(sig, unwrap)
    n = edges.size - 1
    if t.size < 2:
        return np.full(n, np.nan), np.full(n, np.nan)
    at = np.interp(edges, t, v)
    mid = np.interp(0.5 * (edges[:-1] + edges[1:]), t, v)
    counts = np.bincount(_bin_index(t[(t >= edges[0]) & (t < edges[-1])], edges),
                         minlength=n)[:n]
    inc = np.where(counts > 0, np.diff(at), np.nan)
    return inc, np.where(counts > 0, mid, np.nan)


class Fit(NamedTuple):
    """Least-squares fit ``candidate ≈ k·referee`` over the judged bins."""

    k: float
    """Gain (1 for a sound source)."""
    se: float
    """Standard error of ``k``."""
    r: float
    """Correlation without centring (the model has no offset): the share of the
    candidate's motion the referee explains is ``r²``."""
    bins: int


def gain(candidate: np.ndarray, referee: np.ndarray, floor: float) -> Fit | None:
    """The :class:`Fit` on the bins where both are finite, after dropping the bins beyond
    :data:`OUTLIER_MADS` of the first fit; None when fewer than :data:`MIN_BINS` or the
    referee's RMS is below ``floor``."""
    ok = np.isfinite(candidate) & np.isfinite(referee)
    c, a = candidate[ok], referee[ok]
    if c.size < MIN_BINS:
        return None
    saa = float(np.dot(a, a))
    if saa <= 0.0 or np.sqrt(saa / a.size) < floor:
        return None
    k = float(np.dot(c, a) / saa)
    resid = c - k * a
    spread = OUTLIER_MADS * 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    keep = np.abs(resid) <= spread if spread > 0 else np.ones(c.size, dtype=bool)
    if MIN_BINS <= int(keep.sum()) < c.size:
        c, a = c[keep], a[keep]
        saa = float(np.dot(a, a))
        k = float(np.dot(c, a) / saa)
        resid = c - k * a
    se = float(np.sqrt(np.dot(resid, resid) / (c.size - 1) / saa))
    scc = float(np.dot(c, c))
    r = float(np.dot(c, a) / np.sqrt(scc * saa)) if scc > 0 else 0.0
    return Fit(k, se, r, int(c.size))


def misfit(fit: Fit | None) -> str | None:
    """``"scale"`` when ``k`` is significantly above :data:`GAIN_RANGE`, ``"gain"`` when
    below it (a sign or axis error, or a signal that does not follow), ``"follow"`` when
    ``r`` is below :data:`MIN_CORRELATION`; None for a sound (or unjudged) candidate."""
    if fit is None:
        return None
    lo, hi = GAIN_RANGE
    if fit.k - Z_SIGMA * fit.se > hi:
        return "scale"
    if fit.k + Z_SIGMA * fit.se < lo:
        return "gain"
    if fit.r < MIN_CORRELATION:
        return "follow"
    return None


def describe(fit: Fit, kind: str, referee: str) -> str:
    """The note's words for a misfit of ``kind``: ``referee`` names what it was held to."""
    lo, hi = GAIN_RANGE
    if kind == "follow":
        return (f"follows {referee} with r = {fit.r:.2f} (a sound source: r ≥ "
                f"{MIN_CORRELATION:g}; it does not follow it)")
    why = ("a unit error" if kind == "scale" else "a sign or axis error" if fit.k < 0
           else "a unit error, or it does not follow it")
    return f"is {fit.k:.3g} × {referee} (plausible {lo:g}…{hi:g}: {why})"


class Referee:
    """The other channels a candidate is judged against, binned once per column.

    Parameters
    ----------
    chosen
        Column → chosen signal so far (at least the :data:`REFEREE_COLUMNS` present).
    candidates
        Column → every candidate (for the siblings of a body rate or a specific force).
    span
        ``(t0, t1, what)`` of :func:`etsid.ingest.source_check.reference_span`.
    """

    def __init__(self, chosen: dict[str, Signal], candidates: dict[str, list[Signal]],
                 span: tuple[float, float, str]) -> None:
        self.chosen = chosen
        self.candidates = candidates
        self.t0, self.t1, self.what = span
        self._edges = _edges(self.t0, self.t1)
        self._rates: dict[str, np.ndarray] | None = None
        self._climb: np.ndarray | None = None
        self._own: dict[int, tuple[Fit, str] | None] = {}

    def judge(self, column: str, sig: Signal) -> str | None:
        """Why ``sig`` is implausible for ``column`` against the other channels, or None
        (also when there is no referee or too little motion to tell)."""
        if column in RATE_COLUMNS:
            return self._judge_rate(column, sig)
        if column == "alt":
            return self._judge_alt(sig)
        if column in FORCE_COLUMNS:
            return self._judge_force(column, sig)
        return None

    # body rates -----------------------------------------------------------------------
    def _attitude_rates(self) -> dict[str, np.ndarray]:
        if self._rates is not None:
            return self._rates
        self._rates = {}
        angles = [self.chosen.get(c) for c in ("roll", "pitch", "yaw")]
        if self._edges is None or any(a is None for a in angles):
            return self._rates
        (d_phi, phi), (d_theta, theta), (d_psi, _) = (
            bin_increments(a, self._edges, unwrap=c != "pitch")  # type: ignore[arg-type]
            for a, c in zip(angles, ("roll", "pitch", "yaw"), strict=True))
        t, v = _samples(angles[1], unwrap=False)  # type: ignore[arg-type]
        tilt = np.abs(np.interp(self._edges, t, v)) if t.size else np.zeros(self._edges.size)
        with np.errstate(invalid="ignore"):
            bad = ~(np.maximum(np.abs(theta), np.maximum(tilt[:-1], tilt[1:]))
                    <= MAX_EULER_PITCH)
        rd, pd, yd = (x / BIN_S for x in (d_phi, d_theta, d_psi))
        out = {"p": rd - yd * np.sin(theta),
               "q": pd * np.cos(phi) + yd * np.sin(phi) * np.cos(theta),
               "r": -pd * np.sin(phi) + yd * np.cos(phi) * np.cos(theta)}
        self._rates = {c: np.where(bad, np.nan, v) for c, v in out.items()}
        return self._rates

    def _rate_fit(self, column: str, sig: Signal) -> tuple[Fit, str] | None:
        """``(fit, kind)`` of an implausible body-rate candidate on its own axis, or
        None."""
        key = id(sig)
        if key not in self._own:
            self._own[key] = None
            ref = self._attitude_rates().get(column)
            if ref is not None and self._edges is not None:
                fit = gain(bin_means(sig, self._edges), ref, MIN_RATE_RMS)
                kind = misfit(fit)
                if fit is not None and kind is not None:
                    self._own[key] = (fit, kind)
        return self._own[key]

    def _judge_rate(self, column: str, sig: Signal) -> str | None:
        own = self._rate_fit(column, sig)
        if own is not None:
            return describe(own[0], own[1], f"the {AXIS_WORDS[column]} the attitude's "
                            f"derivative implies over {self.what}")
        for other in RATE_COLUMNS:
            if other == column:
                continue
            for sib in self.candidates.get(other, []):
                if sib.topic != sig.topic:
                    continue
                got = self._rate_fit(other, sib)
                if got is not None and got[1] == "scale":
                    return (f"shares its message (unit) with {sib.source}, which is "
                            f"{got[0].k:.3g} × the {AXIS_WORDS[other]} the attitude's "
                            "derivative implies")
        return None

    # height ---------------------------------------------------------------------------
    def _judge_alt(self, sig: Signal) -> str | None:
        vz = self.chosen.get("vz")
        if vz is None or self._edges is None:
            return None
        if self._climb is None:
            self._climb = -bin_means(vz, self._edges)
        rise, _ = bin_increments(sig, self._edges)
        fit = gain(rise / BIN_S, self._climb, MIN_CLIMB_RMS)
        kind = misfit(fit)
        if fit is None or kind is None:
            return None
        return "has a climb rate that " + describe(fit, kind, f"−{vz.source} over {self.what}")

    # specific force -------------------------------------------------------------------
    def _az_mean(self, sig: Signal) -> float | None:
        t, v, ok = _usable(sig)
        v = v[ok & (t >= self.t0) & (t <= self.t1)]
        return float(np.mean(v)) if v.size >= MIN_AZ_SAMPLES else None

    def _judge_force(self, column: str, sig: Signal) -> str | None:
        if column == "az":
            az = sig
        else:
            az = next((s for s in self.candidates.get("az", []) if s.topic == sig.topic),
                      None)
            if az is None:
                return None
        mean = self._az_mean(az)
        lo, hi = AZ_MEAN_RANGE
        if mean is None or lo <= mean <= hi:
            return None
        if az is not sig:
            return (f"shares its message (unit and frame) with {az.source}, whose mean is "
                    f"{mean:+.3g} m/s²")
        return (f"averages {mean:+.3g} m/s² over {self.what} (FRD: −g·cos tilt, plausible "
                f"{lo:.3g}…{hi:.3g}; a unit or sign error)")


Judge = Callable[[str, Signal], str | None]
"""``judge(column, candidate)`` → why the candidate is implausible, or None."""
