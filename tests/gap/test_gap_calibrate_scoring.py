"""The leave-one-generator-out scoring of benchmarks/gap_calibrate.py counts a missed effect
as honest only when the pair's own ``detectable`` says it could not have seen the true
size, and nothing wrong was named (issue 38's rule)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gap_calibrate
import numpy as np
import pytest

from etsid.gap.calibration import Calibration
from etsid.gap.criterion import offset_limit

CAL = Calibration(2.0, 0.05, 0.1, 0.01, {})

DAMPING = {"rate_damping": {"status": "detectable", "size": 11.9, "parameter": "yaw",
                            "per_parameter": {"damping": {"down": None, "up": None},
                                              "yaw": {"down": None, "up": 11.9}}}}


def _row(truth: dict, expected: str, detectable: dict) -> dict:
    return {"truth_sizes": gap_calibrate.truth_sizes(expected, truth),
            "detectable": detectable}


def test_truth_sizes_map_generator_truth_to_detectable_parameters():
    sizes = gap_calibrate.truth_sizes("thrust_scale+time_delay",
                                      {"scale": 0.85, "delay": 0.0125})
    assert sizes["thrust_scale"] == [["scale", "down", 0.15000000000000002]]
    assert sizes["time_delay"] == [["delay", "up", 0.0125]]
    bias = gap_calibrate.truth_sizes("gyro_bias", {"bias_frd": [-0.05, 0.02, 0.0]})
    assert bias["gyro_bias"] == [["bx", "down", 0.05], ["by", "up", 0.02]]
    assert gap_calibrate.truth_sizes("wind", {"wind_enu": [1.0, 2.0, 0.0]}) == {}


def test_below_detectable_reads_every_parameter_in_its_direction():
    small = _row({"rate_damping": 6.5}, "rate_damping", DAMPING)
    large = _row({"rate_damping": 13.0}, "rate_damping", DAMPING)
    assert gap_calibrate.below_detectable("rate_damping", small, CAL)
    assert not gap_calibrate.below_detectable("rate_damping", large, CAL)
    unmapped = _row({"wind_enu": [3.0, 0.0, 0.0]}, "wind",
                    {"wind": {"status": "detectable", "per_parameter": {}}})
    assert not gap_calibrate.below_detectable("wind", unmapped, CAL)
    unseeable = _row({}, "wind", {"wind": {"status": "insufficient", "per_parameter": {}}})
    assert gap_calibrate.below_detectable("wind", unseeable, CAL)


def test_honest_miss_needs_no_wrong_name_and_a_size_below_detectable():
    row = _row({"rate_damping": 6.5}, "rate_damping", DAMPING)
    quiet = {"answer": "consistent", "verdict": "consistent"}
    wrong = {"answer": "inertia_scale", "verdict": "mismatch"}
    other = {"answer": "different-vehicle", "verdict": "different-vehicle"}
    assert gap_calibrate.honest_miss("rate_damping", quiet, row, CAL)
    assert not gap_calibrate.honest_miss("rate_damping", wrong, row, CAL)
    assert not gap_calibrate.honest_miss("rate_damping", other, row, CAL)
    seen = _row({"rate_damping": 13.0}, "rate_damping", DAMPING)
    assert not gap_calibrate.honest_miss("rate_damping", quiet, seen, CAL)


def _evidence() -> dict:
    """A time delay whose change of the prediction grows as the square of its size, and a
    gyro bias read by a sensor channel (variance 1e-5 (rad/s)², 3 draws) and by a dynamic
    channel (variance 4e-4)."""
    sizes = [0.001, 0.01, 0.05]
    return {"offset_channels": 3, "effects": {
        "time_delay": {"parameters": {"delay": {"unit": "s", "up": {
            "span": 0.05, "sizes": sizes, "excess": [(s / 0.01) ** 2 for s in sizes]}}}},
        "gyro_bias": {"parameters": {"bx": {"unit": "rad/s", "up": {
            "span": 0.1, "channels": [[1e-5, 3], [4e-4, 0]]}}}},
        "wind": {"reason": "the logs lack vel"}}}


def test_detectable_sizes_are_stated_again_under_each_calibration():
    """Known answers: a dynamic channel fires where the change reaches (ratio − 1) floors²,
    a sensor channel's offset where θ² reaches the F(1, k) limit times its variance."""
    row = {"criterion": {"detectable_evidence": _evidence()}}
    for ratio in (2.0, 5.0):
        cal = Calibration(ratio, 0.05, 0.1, 0.01, {})
        sizes = gap_calibrate.stated_sizes(row, cal)
        assert sizes["time_delay"]["size"] == pytest.approx(0.01 * np.sqrt(ratio - 1))
        bias = sizes["gyro_bias"]["per_parameter"]["bx"]["up"]
        sensor = np.sqrt(offset_limit(3, 3, 0.01) * 1e-5)
        dynamic = np.sqrt((ratio - 1) * 4e-4)
        assert bias == pytest.approx(min(sensor, dynamic))
        assert sizes["wind"]["status"] == "insufficient"
    loose = gap_calibrate.stated_sizes(row, Calibration(2.0, 0.05, 0.1, 0.2, {}))
    assert loose["gyro_bias"]["size"] < gap_calibrate.stated_sizes(row, CAL)["gyro_bias"]["size"]


@pytest.mark.parametrize("delay, capped", [(0.006, True), (0.02, False)])
def test_a_recorded_name_fitted_below_its_detectable_size_is_a_hint(delay: float,
                                                                     capped: bool) -> None:
    """The scoring decides a record as the package answers (likelihood.py): a delay fitted
    at 6 ms where the pair can only detect 10 ms is named at 0.45 at most (a hint), one at
    20 ms keeps its weight."""
    model = {"name": "time_delay", "gain": 500.0, "per_sample": 0.5, "n_scored": 1000,
             "gain_se": 10.0, "weight": 1.0, "theta": [delay], "by_channel": {}}
    crit = {"innovation_ratio": {"p": 4.0}, "offset": {}, "models": [model],
            "after_lead": {"name": "time_delay", "ratio": {"p": 1.0}, "offset": {}}}
    sizes = {"time_delay": {"status": "detectable", "size": 0.01, "parameter": "delay",
                            "unit": "s", "per_parameter": {"delay": {"up": 0.01}}}}
    decided = gap_calibrate.decide({"verdict": "mismatch", "criterion": crit,
                                    "detectable": sizes}, CAL)
    assert decided["answer"] == "time_delay"
    assert (decided["confidence"]["time_delay"] <= 0.45) == capped, decided


def test_a_confident_name_is_right_when_it_is_one_expected_effect_or_its_equivalent():
    """The reliability count reads each confident name against each expected effect with the
    scoring's own equivalences (mass ≡ thrust scale from accelerations alone)."""
    assert gap_calibrate.named_in("thrust_scale+time_delay", "mass")
    assert gap_calibrate.named_in("thrust_scale+time_delay", "time_delay")
    assert gap_calibrate.named_in("mass", "thrust_scale")
    assert not gap_calibrate.named_in("thrust_scale+time_delay", "yaw_torque_scale")
    assert not gap_calibrate.named_in("consistent", "mass")
