"""The leave-one-generator-out scoring of benchmarks/gap_calibrate.py counts a missed effect
as honest only when the pair's own ``detectable`` says it could not have seen the true
size, and nothing wrong was named (issue 38's rule)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gap_calibrate

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
    assert gap_calibrate.below_detectable("rate_damping", small)
    assert not gap_calibrate.below_detectable("rate_damping", large)
    unmapped = _row({"wind_enu": [3.0, 0.0, 0.0]}, "wind",
                    {"wind": {"status": "detectable", "per_parameter": {}}})
    assert not gap_calibrate.below_detectable("wind", unmapped)
    unseeable = _row({}, "wind", {"wind": {"status": "insufficient", "per_parameter": {}}})
    assert gap_calibrate.below_detectable("wind", unseeable)


def test_honest_miss_needs_no_wrong_name_and_a_size_below_detectable():
    row = _row({"rate_damping": 6.5}, "rate_damping", DAMPING)
    quiet = {"answer": "consistent", "verdict": "consistent"}
    wrong = {"answer": "inertia_scale", "verdict": "mismatch"}
    other = {"answer": "different-vehicle", "verdict": "different-vehicle"}
    assert gap_calibrate.honest_miss("rate_damping", quiet, row)
    assert not gap_calibrate.honest_miss("rate_damping", wrong, row)
    assert not gap_calibrate.honest_miss("rate_damping", other, row)
    seen = _row({"rate_damping": 13.0}, "rate_damping", DAMPING)
    assert not gap_calibrate.honest_miss("rate_damping", quiet, seen)
