"""A gyro scale against the attitude (etsid/gap/scale.py): known answers on a real flight
whose roll gyro is made to read high, the mismatch and confidence rules it feeds, and the
calibration script's threshold for it."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from etsid.gap.calibration import Calibration, calibration_dict, from_dict, load_calibration
from etsid.gap.run import analyse, prepare_pair
from etsid.gap.scale import block_slope, scale_mismatched, scale_tests

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gap_calibrate
import gap_real

SHARED = next((p / "shared" / "data" / "logs" for p in Path(__file__).resolve().parents
               if (p / "shared" / "data" / "logs").is_dir()), Path("shared/data/logs"))
HEXA = "ardupilot_copter403_hexa_loiter_real.bin"


@pytest.fixture(scope="module")
def hexa():
    if not (SHARED / HEXA).exists():
        pytest.skip(f"{HEXA} not here (the shared real logs are not shipped)")
    return gap_real.load(HEXA, SHARED)


@pytest.mark.parametrize("size", [0.05, 0.15])
def test_a_roll_gyro_read_high_is_its_scale_on_roll_alone(hexa, size: float) -> None:
    """Known answer: the copy's roll gyro reads (1 + s) × the original against the same
    attitude, so REAL's slope on the roll rate is SIM's plus s (to the part of the gyro the
    attitude rate does not explain), and pitch and yaw are untouched."""
    sim, real = prepare_pair(hexa, gap_real.BY_NAME["gyro_scale"].make(hexa, size), "s", "r")
    tests = scale_tests(sim, real)
    delta = tests["gyro_p"][0]
    assert abs(delta - size) < 0.1 * size, tests
    assert abs(tests["gyro_q"][0]) < 1e-9 and abs(tests["gyro_r"][0]) < 1e-9, tests


def test_the_rule_needs_the_tolerance_and_the_standard_error() -> None:
    cal = Calibration(2.0, 0.05, 0.1, 0.01, {}, scale_tolerance=0.02)
    tests = {"gyro_p": (0.05, 0.005, 20), "gyro_q": (0.05, 0.02, 20),
             "gyro_r": (0.01, 0.001, 20)}
    # p: beyond both; q: beyond the tolerance but 2.5 standard errors; r: within tolerance
    assert scale_mismatched(tests, cal) == ["gyro_p"]
    # one channel at 3.2 standard errors: beyond t's 2.85 (1 %, 20 dof), not its 5.8 (3 dof)
    few = {"gyro_p": (0.032, 0.01, 20)}
    assert scale_mismatched(few, cal) == ["gyro_p"]
    assert scale_mismatched({"gyro_p": (0.032, 0.01, 3)}, cal) == []
    assert scale_mismatched(tests, replace(cal, scale_tolerance=float("inf"))) == []


def test_the_tolerance_is_written_and_read_and_absent_means_untested() -> None:
    cal = Calibration(2.0, 0.05, 0.1, 0.01, {}, scale_tolerance=0.013)
    assert from_dict(calibration_dict(cal), "x").scale_tolerance == 0.013
    old = calibration_dict(replace(cal, scale_tolerance=float("inf")))
    assert "scale_tolerance" not in old["thresholds"]
    assert from_dict(old, "x").scale_tolerance == float("inf")


def test_calibration_takes_the_largest_significant_no_effect_difference(tmp_path) -> None:
    """``gap_calibrate fit``: the tolerance is the largest |Δ| among the no-effect pairs'
    significant differences; an insignificant one (a short flight) does not set it."""
    def row(pid: str, scale: dict) -> dict:
        return {"id": pid, "generator": "g", "label": "none", "expected": "consistent",
                "criterion": {"innovation_ratio": {"p": 1.0}, "offset": {}, "models": [],
                              "scale": scale}}
    rows = [row("a", {"gyro_p": [0.004, 0.001, 20], "gyro_q": [0.001, 0.001, 20]}),
            row("b", {"gyro_p": [0.009, 0.002, 20], "gyro_q": [-0.011, 0.002, 20]}),
            row("c", {"gyro_p": [0.03, 0.02, 20], "gyro_q": [0.0, 0.001, 20]})]
    out = tmp_path / "cal.json"
    args = type("A", (), {"records": [], "generators": "g", "fpr": 0.01, "out": str(out)})
    gap_calibrate.fit(args, rows)
    assert load_calibration(str(out)).scale_tolerance == pytest.approx(0.011)


def test_the_tolerance_is_never_below_a_healthy_gyros_datasheet_tolerance(tmp_path) -> None:
    """No no-effect pair significant (or only smaller ones): the tolerance is a healthy
    gyro's ±1 % sensitivity error, not 0, so a 0.5 % difference is no fault."""
    def row(pid: str, scale: dict) -> dict:
        return {"id": pid, "generator": "g", "label": "none", "expected": "consistent",
                "criterion": {"innovation_ratio": {"p": 1.0}, "offset": {}, "models": [],
                              "scale": scale}}
    out = tmp_path / "cal.json"
    args = type("A", (), {"records": [], "generators": "g", "fpr": 0.01, "out": str(out)})
    for scale in ({"gyro_p": [0.004, 0.01, 20]}, {"gyro_p": [0.006, 0.001, 20]}):
        gap_calibrate.fit(args, [row("a", scale)])
        cal = load_calibration(str(out))
        assert cal.scale_tolerance == gap_calibrate.GYRO_SCALE_FACTOR_TOLERANCE == 0.01
        assert scale_mismatched({"gyro_r": (-0.0052, 0.0011, 10)}, cal) == []
        assert scale_mismatched({"gyro_r": (-0.025, 0.004, 10)}, cal) == ["gyro_r"]


def test_a_recorded_pair_with_a_scale_left_is_a_mismatch_and_capped() -> None:
    cal = Calibration(2.0, 0.05, 0.1, 0.01, {}, scale_tolerance=0.02)
    model = {"name": "inertia_scale", "gain": 500.0, "per_sample": 0.5, "n_scored": 1000,
             "gain_se": 10.0, "weight": 1.0, "theta": [0.9], "by_channel": {}}
    crit = {"innovation_ratio": {"p": 4.0}, "offset": {}, "models": [model],
            "after_lead": {"name": "inertia_scale", "ratio": {"p": 1.0}, "offset": {}},
            "scale": {"gyro_p": [0.06, 0.003, 20]}}
    decided = gap_calibrate.decide({"verdict": "mismatch", "criterion": crit}, cal)
    assert decided["answer"] == "inertia_scale"
    assert decided["confidence"]["inertia_scale"] < 0.5
    crit["scale"] = {"gyro_p": [0.005, 0.003, 20]}
    assert gap_calibrate.decide({"verdict": "mismatch", "criterion": crit},
                                cal)["confidence"]["inertia_scale"] == 1.0
    alone = {**crit, "models": [{**model, "gain": 1.0, "per_sample": 0.001}],
             "scale": {"gyro_p": [0.06, 0.003, 20]}}
    assert gap_calibrate.decide({"verdict": "mismatch", "criterion": alone},
                                cal)["answer"] == "mismatch"


def test_a_gyro_read_high_is_never_named_confidently(hexa) -> None:
    """The package's calibration on the real hexacopter with its roll gyro 15 % high: a
    mismatch whose leftover says the scale, and no effect named at confidence ≥ 0.5."""
    cal = load_calibration()
    assert cal.scale_tolerance < 0.15
    data = analyse(hexa, gap_real.BY_NAME["gyro_scale"].make(hexa, 0.15), "s", "r").data
    assert data["verdict"] == "mismatch", data["summary"]
    assert "scale" in data["leftover"]["gyro_p"], data["leftover"]
    assert all(e["confidence"] < 0.5 for e in data["effects"]
               if e["name"] != "unexplained"), data["summary"]


@pytest.mark.parametrize("loud", [1.0, 4.0])
def test_the_slope_test_holds_its_rate_with_few_blocks(loud: float) -> None:
    """Known answer: with no scale (the residual independent of the rate), |slope| / SE over
    eight blocks exceeds Student's t 5 % quantile at the returned degrees of freedom on 5 %
    of flights when the rate is spread evenly (``loud`` 1), and on 4–5 % when two blocks
    carry it four times louder (a take-off, one manoeuvre; Satterthwaite's approximation is
    a little conservative there). There the plain G − 1 = 7 calls over 10 %: a few blocks'
    scores make the whole error, and it is read too strongly."""
    rng = np.random.default_rng(7)
    g, block, flights = 8, 40, 20000
    idx = np.arange(g * block)
    amplitude = np.ones(g * block)
    amplitude[:2 * block] = loud
    hits = plain = 0
    for _ in range(flights):
        x, r = rng.standard_normal(g * block) * amplitude, rng.standard_normal(g * block)
        slope, se, dof = block_slope(x, r, idx, block)
        hits += abs(slope) > float(stats.t.ppf(0.975, dof)) * se
        plain += abs(slope) > float(stats.t.ppf(0.975, g - 1)) * se
    assert 0.035 < hits / flights < 0.056, hits / flights
    if loud > 1.0:
        assert dof < 4.0 and plain / flights > 0.10, (dof, plain / flights)
    else:
        assert dof > 5.5 and abs(plain / flights - 0.05) < 0.006, (dof, plain / flights)


def test_two_flights_combine_their_degrees_of_freedom_by_welch_satterthwaite() -> None:
    """Known answer: equal errors on equal blocks add their degrees of freedom; a flight
    whose error dominates keeps about its own."""
    from etsid.gap.scale import welch_dof
    assert welch_dof(0.01, 6.0, 0.01, 6.0) == pytest.approx(12.0)
    assert welch_dof(0.01, 3.0, 0.001, 9.0) == pytest.approx(3.06, abs=0.01)
