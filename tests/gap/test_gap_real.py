"""`etsid gap` on real recordings (issue 39): identical copies are consistent, every verdict
says what the pair could have seen, one airframe on two packs is one airframe, and known
changes injected into a real flight (benchmarks/gap_real.py) are named or said unseeable.

The shared real logs live outside the repository (``shared/data/logs``); the tests skip
where they are absent."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.gap.calibration import load_calibration
from etsid.gap.criterion import offset_limit
from etsid.gap.detectable import below_detectable
from etsid.gap.result import clean, validate
from etsid.gap.run import analyse

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gap_real

SHARED = next((p / "shared" / "data" / "logs" for p in Path(__file__).resolve().parents
               if (p / "shared" / "data" / "logs").is_dir()), Path("shared/data/logs"))
_CACHE: dict[str, pd.DataFrame] = {}


def _real(name: str) -> pd.DataFrame:
    if not (SHARED / name).exists():
        pytest.skip(f"{name} not here (the shared real logs are not shipped)")
    if name not in _CACHE:
        _CACHE[name] = gap_real.load(name, SHARED)
    return _CACHE[name]


def _worst(data: dict) -> float:
    """REAL's largest held-out innovation variance over its floor's on a dynamic channel
    (the mismatch rule's statistic; the sensor-consistency channels are judged by offset)."""
    crit = data["criterion"]
    return max(v for c, v in crit["innovation_ratio"].items() if c not in crit["offset"])


@pytest.mark.parametrize("name", gap_real.LOGS)
def test_a_real_flight_against_its_table_copy_is_consistent(name: str, tmp_path: Path) -> None:
    """Each shared real flight against itself re-encoded through a Parquet table: the copy is
    the same data (checked), and the verdict is consistent with every channel's held-out
    innovations within the calibrated mismatch ratio, and says what the pair could not have
    seen. (A copy's ratio is not 1: REAL's whole flight is scored against the noise model
    scaled to SIM's held-out error.)"""
    table = _real(name)
    copy = gap_real.reencode(table, tmp_path)
    pd.testing.assert_frame_equal(copy, table, check_freq=False)
    data = analyse(table, copy, "sim.ulg", "real.ulg").data
    assert data["verdict"] == "consistent", data["summary"]
    limit = data["criterion"]["thresholds"]["mismatch_ratio"]
    assert _worst(data) <= limit, data["criterion"]["innovation_ratio"]
    assert set(data["detectable"]) >= {"gyro_bias", "time_delay", "thrust_scale"}
    assert "could not have seen" in data["summary"]
    validate(clean(data))


def test_the_coax_octocopter_on_two_packs_is_one_airframe() -> None:
    """Stabilized flight on a 4S pack, manual flight on a 3S pack: a pack is a condition."""
    a = _real("px4_coaxocto_stabilized_real.ulg")
    b = _real("px4_coaxocto_manual_real.ulg")
    data = analyse(a, b, "stabilized.ulg", "manual.ulg").data
    assert data["verdict"] != "different-vehicle", data["summary"]
    assert data["vehicle_check"]["ratios"]["pack voltage"] < 0.75  # two packs indeed


@pytest.mark.parametrize("delay", [0.02, 0.04])
def test_a_late_response_is_never_another_airframe(delay: float) -> None:
    table = _real("ardupilot_copter403_hexa_loiter_real.bin")
    late = gap_real.BY_NAME["delay"].make(table, delay)
    data = analyse(table, late, "sim.bin", "real.bin").data
    assert data["verdict"] != "different-vehicle", data["summary"]
    ratios = data["vehicle_check"]["ratios"]
    assert 0.7 < ratios["roll effectiveness"] < 1.4, ratios


@pytest.mark.parametrize(("change", "size"), [("gyro_bias", 0.1), ("weak_motor", 0.7)])
def test_an_injected_change_above_its_detectable_size_is_named(change: str, size: float
                                                               ) -> None:
    table = _real("ardupilot_copter403_hexa_loiter_real.bin")
    ch = gap_real.BY_NAME[change]
    data = analyse(table, ch.make(table, size), "sim.bin", "real.bin").data
    case = gap_real.Case("hexa", change, size, data["verdict"],
                         [(e["name"], e["confidence"]) for e in data["effects"]],
                         data["detectable"])
    case.caveats = [e["caveat"] for e in data["effects"] if e.get("caveat")]
    assert case.below() is False, data["detectable"][ch.effect]
    assert case.outcome() in ("right", "look-alike"), data["summary"]


def test_a_gyro_bias_below_its_detectable_size_is_not_a_finding() -> None:
    table = _real("ardupilot_copter403_hexa_loiter_real.bin")
    data = analyse(table, gap_real.BY_NAME["gyro_bias"].make(table, 0.003), "s", "r").data
    entry = data["detectable"]["gyro_bias"]
    assert entry["status"] == "detectable" and entry["per_parameter"]["by"]["up"] > 0.003
    assert not [e for e in data["effects"] if e["name"] == "gyro_bias"
                and e["confidence"] >= 0.5], data["summary"]


def test_a_sensor_offset_is_detectable_where_the_mismatch_rule_fires() -> None:
    """Known answer: an offset adds itself to its channel, so the detectable size is where
    the mismatch rule's test of that channel fires: on a sensor-consistency channel
    ``√(limit · var)`` with the F(1, k) limit at the calibration's rate and the variance of
    its offset test; on a dynamic one ``√(mismatch_ratio − 1)`` floors."""
    table = _real("ardupilot_copter403_hexa_loiter_real.bin")
    data = analyse(table, table.copy(), "s", "r").data
    cal = load_calibration()
    evidence = data["criterion"]["detectable_evidence"]
    tests = evidence["effects"]["gyro_bias"]["parameters"]["by"]["up"]["channels"]
    want = min(np.sqrt((offset_limit(int(k), evidence["offset_channels"],
                                     cal.false_positive_rate) if k > 0
                        else cal.mismatch_ratio - 1.0) * var) for var, k in tests)
    size = data["detectable"]["gyro_bias"]["per_parameter"]["by"]["up"]
    assert size == pytest.approx(want, rel=1e-9)
    assert any(k > 0 for _, k in tests)  # the gyro's own channel is judged by its offset
    fake = {"name": "gyro_bias", "parameters": {"bx": {"value": 0.0}, "by": {"value": size / 2},
                                               "bz": {"value": 0.0}}}
    assert below_detectable(fake, data["detectable"])
    fake["parameters"]["by"]["value"] = 2 * size
    assert not below_detectable(fake, data["detectable"])


def test_a_drifting_velocity_estimate_is_dropped_with_a_note() -> None:
    """The PX4 v6C hover's velocity estimate drifts to 18 m/s while the vehicle hovers within
    6° of level: no drag shows in the specific force, so the velocity is not used. (The log
    flags that estimate invalid, ``v_xy_valid`` 0 throughout, and ingest leaves it out; the
    drift is put back here as a log without validity flags would carry it: 0 → 18.5 m/s
    north, 0 → 6.3 m/s east over the flight, the log's own extremes.)"""
    table = _real("px4_v6c_quad_lowhover_real.ulg")
    assert "vx" not in table.columns  # the log's own validity flag, read by ingest
    table["vx"] = np.linspace(0.0, 18.5, len(table))
    table["vy"] = np.linspace(0.0, 6.3, len(table))
    data = analyse(table, table.copy(), "s", "r").data
    assert any("shows no drag" in n for n in data["notes"]), data["notes"]
    assert "kin_x" not in data["noise"] and "ax" not in data["noise"]
    assert data["detectable"]["accel_bias"]["status"] == "insufficient"


def test_rate_setpoints_are_the_command_when_the_log_has_no_motors_or_sticks() -> None:
    table = _real("px4_v6c_quad_lowhover_real.ulg")
    bare = table.drop(columns=[c for c in table.columns if c[0] == "m" and c[1:].isdigit()]
                      + ["u_roll", "u_pitch", "u_yaw"])
    bare.attrs = dict(table.attrs)
    data = analyse(bare, bare.copy(), "s", "r").data
    assert data["sim"]["command_source"] == "rate setpoints"
    assert any(n.startswith("command: the rate setpoints") for n in data["notes"])
    assert data["verdict"] == "consistent", data["summary"]


def test_the_truth_named_alone_below_its_stated_size_is_right_not_wrong() -> None:
    """Below the stated size a confident name is wrong unless it is the truth alone (the
    criterion can see more than the mismatch rule states); nothing confident is honest."""
    sizes = {"thrust_scale": {"status": "detectable", "size": 0.16,
                              "per_parameter": {"scale": {"down": 0.16}}}}
    case = gap_real.Case("hexa", "thrust_scale", 0.85, "mismatch", [("thrust_scale", 0.89)],
                         sizes)
    assert case.below() and case.outcome() == "right"
    case.named = [("thrust_scale", 0.89), ("mass", 0.7)]
    assert case.outcome() == "wrong"
    case.named = [("thrust_scale", 0.45)]
    assert case.outcome() == "honest"
    case.named = [("accel_bias", 0.9)]
    assert case.outcome() == "wrong"
