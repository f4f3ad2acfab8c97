"""The gyro's scale against the attitude: a sensor fault no effect of the vocabulary acts on.

A gyro that reads ``k ω`` drives the rate loop with its error, so on the dynamic channels it
looks like an inertia scale of ``1/k`` (the angular acceleration per unit of torque is read
``k`` times larger). What tells it apart is the gyro-vs-attitude channel: an aided attitude
estimator is pulled towards the true rotation below its correction bandwidth, so there the
gyro minus the body rate implied by the attitude is ``(k − 1) ω``, a residual proportional
to the rate. Its slope on the rate, per axis,

    gyro − ω_att = c ω_att + b + e,

is the estimator's own answer to the rate in SIM (a lag or a scaling of its own), and the
same plus the scale error's share in REAL; REAL's slope minus SIM's, ``Δ``, is the evidence.
Its standard error comes from the criterion's blocks of
:data:`~etsid.gap.criterion.BLOCK_S` (the residual is low-passed and
autocorrelated: whole blocks are independent, samples are not), summed about their mean
with ``G/(G − 1)`` for G blocks (the usual small-sample factor, CR1). With a few tens of
blocks that error is itself uncertain, and more so when the rate is concentrated in a few
of them (a take-off, one manoeuvre): then a few blocks' scores make the whole estimate. So
``Δ / SE`` is read against Student's t with the blocks' *effective* number: block g's share
``a_g`` of the rate's sum of squares gives ``(Σ a_g)² / Σ a_g²`` blocks (the Satterthwaite
degrees of freedom of a sum of block scores whose variances are proportional to their
shares; Carter, Schnepel and Steigerwald's "effective number of clusters", 2017, measures
the same heterogeneity), times ``(G − 1)/G`` so that G equal blocks keep the G − 1 of a
cluster-robust error; the two flights' errors are combined by Welch–Satterthwaite. On 48
of etsid's no-effect pairs (``gap_concealed.make_pair``, seeds 300–347), whose rate is
carried by two to four of eight to ten blocks, the plain G − 1 called 10 % of the pairs
significant at a 5 % rate (over the three axes); the effective number, 2 %.

A channel's scale is mismatched when ``|Δ|`` exceeds the calibrated tolerance
(:attr:`etsid.gap.calibration.Calibration.scale_tolerance`: the largest no-effect pair's,
so the between-flight spread of the estimator's own slope is in it) and is significant at
the calibration's false-positive rate over the three axes. No effect of the vocabulary
changes the slope, so a mismatched scale is a leftover of every model: it makes the verdict
a ``mismatch`` and caps a named effect's confidence (a partial explanation).

What it does not do: the estimator's correction bandwidth sets how much of ``k − 1`` shows
(a filter that follows the gyro above 0.2 Hz shows the share of the rate below it), so
``Δ`` is evidence of a scale error, not its size; a scale on the accelerometer is not
tested.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from scipy import stats

from etsid.gap.calibration import Calibration
from etsid.gap.criterion import BLOCK_S
from etsid.gap.nominal import GYRO_CHANNELS, kinematic_rates, measured
from etsid.gap.signals import Flight


def slopes(flight: Flight) -> dict[str, tuple[float, float, float]]:
    """Gyro channel → (slope ``c`` of gyro − attitude rate on the attitude rate, its block
    standard error, that error's degrees of freedom) over the airborne samples; empty
    without attitude or gyro channels."""
    out: dict[str, tuple[float, float, float]] = {}
    for c, x, r, idx, block in channel_samples(flight):
        if idx.size < 3 * block:
            continue
        fitted = block_slope(x[idx], r[idx], idx, block)
        if fitted is not None:
            out[c] = fitted
    return out


def channel_samples(flight: Flight
                    ) -> Iterator[tuple[str, np.ndarray, np.ndarray, np.ndarray, int]]:
    """Per gyro channel: (channel, attitude rate x, gyro − x, indices of the airborne
    samples where both are finite, block length in samples); nothing without attitude or
    gyro channels."""
    ys = measured(flight)
    if not all(c in ys for c in GYRO_CHANNELS):
        return
    kin = kinematic_rates(flight)
    block = max(round(BLOCK_S * flight.fs), 1)
    for j, c in enumerate(GYRO_CHANNELS):
        x = kin[:, j]
        r = ys[c] - x
        yield c, x, r, np.flatnonzero(flight.airborne & np.isfinite(r) & np.isfinite(x)), block


def block_slope(x: np.ndarray, r: np.ndarray, idx: np.ndarray, block: int
                ) -> tuple[float, float, float] | None:
    """Least-squares slope of ``r`` on ``x`` (with an intercept), its cluster-robust
    standard error over the blocks of ``block`` samples that the sample indices ``idx``
    fall in, and that error's effective degrees of freedom; None when ``x`` does not vary
    or falls in one block. The blocks' scores are summed about their mean (0 for least
    squares) with ``G/(G − 1)`` (CR1); the degrees of freedom are
    :func:`effective_blocks` less one block's share."""
    xc = x - np.mean(x)
    sxx = float(xc @ xc)
    if sxx <= 0.0:
        return None
    slope = float(xc @ r) / sxx
    e = r - np.mean(r) - slope * xc
    label = (idx - idx[0]) // block
    filled = np.bincount(label) > 0  # blocks with samples
    per_block = np.bincount(label, weights=xc * e)[filled]
    share = np.bincount(label, weights=xc * xc)[filled]
    g = per_block.size
    if g < 2:
        return None
    se = float(np.sqrt(np.sum(per_block ** 2) * g / (g - 1))) / sxx
    return slope, se, effective_blocks(share) * (g - 1) / g


def effective_blocks(share: np.ndarray) -> float:
    """``(Σ a)² / Σ a²`` for the blocks' shares ``a`` of the regressor's sum of squares:
    G for equal blocks, 1 when one block holds it all (the Satterthwaite degrees of freedom
    of a sum of G scores whose variances are proportional to ``a``)."""
    total = float(np.sum(share))
    return total * total / float(np.sum(share * share))


def scale_tests(sim: Flight, real: Flight) -> dict[str, tuple[float, float, float]]:
    """Gyro channel → (REAL's slope minus SIM's, its standard error, its Welch–Satterthwaite
    degrees of freedom) where both have one."""
    a, b = slopes(sim), slopes(real)
    out: dict[str, tuple[float, float, float]] = {}
    for c in GYRO_CHANNELS:
        if c in a and c in b:
            out[c] = (b[c][0] - a[c][0], float(np.hypot(a[c][1], b[c][1])),
                      welch_dof(a[c][1], a[c][2], b[c][1], b[c][2]))
    return out


def welch_dof(se_a: float, dof_a: float, se_b: float, dof_b: float) -> float:
    """Welch–Satterthwaite degrees of freedom of the difference of two independent estimates
    with standard errors ``se_a``, ``se_b`` on ``dof_a``, ``dof_b`` degrees of freedom."""
    va, vb = se_a * se_a, se_b * se_b
    if va + vb <= 0.0:
        return float(min(dof_a, dof_b))
    return float((va + vb) ** 2 / (va * va / dof_a + vb * vb / dof_b))


def significant_delta(delta: float, se: float, dof: float, n_channels: int, rate: float
                      ) -> bool:
    """``|delta|`` beyond its standard error at false-positive ``rate`` over ``n_channels``
    (two-sided, Bonferroni; Student's t with ``dof`` degrees of freedom)."""
    t = float(stats.t.ppf(1.0 - rate / (2.0 * max(n_channels, 1)), max(float(dof), 1.0)))
    return abs(delta) > t * se


def scale_mismatched(tests: dict[str, tuple[float, float, float]] | dict[str, list[float]],
                     cal: Calibration) -> list[str]:
    """Gyro channels whose scale departs from SIM's: ``|Δ|`` over the calibrated tolerance
    and significant (``tests`` as :func:`scale_tests` or gap.json's ``scale``), largest
    first."""
    out = [(abs(float(d)), c) for c, (d, se, dof) in tests.items()
           if abs(float(d)) > cal.scale_tolerance
           and significant_delta(float(d), float(se), float(dof), len(tests),
                                 cal.false_positive_rate)]
    return [c for _, c in sorted(out, reverse=True)]
