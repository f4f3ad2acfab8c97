"""Step 19's pooled readings: the low band's damping shift and the yaw noise ratio count
when both of REAL's parts pass on their own, or when both parts pooled pass a threshold of
their own with the held-out part on the same side (the rules, on readings whose answer is
known by construction; the real pairs are in test_thirdparty_pairs.py)."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.damping import Z_LOW_BAND, Z_POOLED, DampingShift, LowBandReading
from etsid.gap.yaw_noise import QUIET_YAW, QUIET_YAW_POOLED, YawReading


def _shift(z: float, stderr: float = 1.0) -> DampingShift:
    return DampingShift(z * stderr, stderr, {})


def test_two_parts_that_each_pass_name_their_side() -> None:
    assert LowBandReading(_shift(4.0), _shift(4.5)).sign == 1
    assert LowBandReading(_shift(-4.0), _shift(-4.5)).sign == -1


def test_one_strong_part_and_one_weak_one_on_the_same_side_pool() -> None:
    """7.3 and 3.2 SE (set 336's rate damping): the held-out part is under Z_LOW_BAND, the
    pooled shift (7.4 SE at equal errors) beyond Z_POOLED."""
    reading = LowBandReading(_shift(7.3), _shift(3.2))
    assert min(reading.fit.z, reading.hold.z) < Z_LOW_BAND
    assert reading.pooled_z == pytest.approx((7.3 + 3.2) / np.sqrt(2.0))
    assert reading.sign == 1


def test_pooling_weighs_each_part_by_its_precision() -> None:
    """A precise part counts more: 6 ± 1 and 2 ± 3 /s pool to 5.6 /s at 0.95 /s."""
    reading = LowBandReading(DampingShift(6.0, 1.0, {}), DampingShift(2.0, 3.0, {}))
    w = np.array([1.0, 1.0 / 9.0])
    assert reading.pooled_z == pytest.approx((w @ [6.0, 2.0]) / np.sqrt(w.sum()))


def test_a_held_out_part_on_the_other_side_never_pools_into_a_name() -> None:
    """12 SE on the fit part cannot outvote a held-out part that says the opposite."""
    reading = LowBandReading(_shift(12.0), _shift(-0.5))
    assert reading.pooled_z > Z_POOLED[1]
    assert reading.sign == 0


def test_the_lower_side_needs_its_own_larger_pooled_shift() -> None:
    """The no-effect pairs reach further on the lower side (−4.56 against +3.96), so the same
    pooled size names a rate damping but not a timing law."""
    z = (Z_POOLED[1] + Z_POOLED[-1]) / 2.0 * np.sqrt(2.0) / 2.0
    assert LowBandReading(_shift(z + 1.0), _shift(z - 1.0)).sign == 1
    assert LowBandReading(_shift(-(z + 1.0)), _shift(-(z - 1.0))).sign == 0


def test_yaw_quiet_on_both_parts_or_on_their_geometric_mean() -> None:
    """0.11 and 0.6 (set 319's rotor inertia): the held-out part is above QUIET_YAW, the
    geometric mean 0.25 under QUIET_YAW_POOLED; a part at or above 1 (louder than SIM) keeps
    the reading loud whatever the other says."""
    assert YawReading(0.3, 0.4).quiet
    one_loud_part = YawReading(0.11, 0.6)
    assert one_loud_part.hold > QUIET_YAW and one_loud_part.pooled <= QUIET_YAW_POOLED
    assert one_loud_part.quiet
    assert not YawReading(0.1, 1.05).quiet
    assert not YawReading(0.45, 0.5).quiet
