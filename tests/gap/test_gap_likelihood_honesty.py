"""What the likelihood criterion may claim: an explanation that leaves a channel mismatched
is a partial one (capped confidence), and a scale beyond one airframe's faults — fitted, or
held at its search bound while it explains more than the named model — is another
airframe."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.detectable import BELOW_CONFIDENCE
from etsid.gap.likelihood import AIRFRAME_SCALES, _airframe_evidence, cap_on_sticks, cap_partial
from etsid.gap.run import analyse
from etsid.sim import load_vehicle, simulate


def test_a_leftover_caps_every_named_effect_and_says_why():
    effects = [{"name": "mass", "confidence": 1.0},
               {"name": "rotor_inertia", "confidence": 0.98, "caveat": "look-alike"}]
    cap_partial(effects, {"q": {"ratio": 1.5}})
    assert [e["confidence"] for e in effects] == [BELOW_CONFIDENCE, BELOW_CONFIDENCE]
    assert "partial explanation" in effects[0]["caveat"] and "1.5×" in effects[0]["caveat"]
    assert effects[1]["caveat"].startswith("look-alike; a partial explanation")


@pytest.mark.parametrize("inputs", ["sticks", "motors"])
def test_an_airframe_scale_named_from_sticks_alone_is_capped(inputs):
    """On stick commands another airframe and the same one scaled look alike: mass, thrust
    and inertia scales are capped with the reason; other effects, and any effect named
    from motor outputs, keep their weight."""
    effects = [{"name": "mass", "confidence": 1.0}, {"name": "inertia_scale", "confidence": 0.63},
               {"name": "ground_effect", "confidence": 1.0}]
    cap_on_sticks(effects, inputs)
    capped = inputs != "motors"
    assert effects[0]["confidence"] == (BELOW_CONFIDENCE if capped else 1.0)
    assert effects[1]["confidence"] == (BELOW_CONFIDENCE if capped else 0.63)
    assert effects[2]["confidence"] == 1.0 and "caveat" not in effects[2]
    assert ("stick commands" in effects[0].get("caveat", "")) is capped


def test_a_complete_explanation_keeps_its_weight():
    effects = [{"name": "thrust_scale", "confidence": 0.97}]
    cap_partial(effects, {})
    assert effects[0]["confidence"] == 0.97 and "caveat" not in effects[0]


@pytest.mark.parametrize(("name", "value", "beyond"), [
    ("mass", 0.5, True), ("mass", 1.8, True), ("mass", 0.8, False), ("mass", 1.5, False),
    ("thrust_scale", 0.55, True), ("inertia_scale", 3.0, True), ("inertia_scale", 2.0, False),
    ("rotor_inertia", 0.2, False),
])
def test_airframe_scales_beyond_one_airframe(name: str, value: float, beyond: bool):
    assert (_airframe_evidence(name, value, "fitted") is not None) is beyond


def test_mass_range_is_the_thrust_scale_range_inverted():
    lo, hi = AIRFRAME_SCALES["thrust_scale"]
    assert AIRFRAME_SCALES["mass"] == pytest.approx((1 / hi, 1 / lo))


def test_another_quad_whose_inertia_scale_sits_at_its_bound_is_another_vehicle():
    """quad250 against an S500 with a gimbal (1.5 kg, 2.7× its inertia): the inertia scale
    that explains most sits at its search bound 3, beyond one airframe's 2.2; before, the
    criterion named a motor lag and a mass at 0.98–1.00 instead."""
    quad = load_vehicle("quad250")
    s500 = quad.with_settings({
        "mass": 1.5, "inertia.ixx": 0.03, "inertia.iyy": 0.032, "inertia.izz": 0.05,
        "frame.arm_length": 0.25, "rotor.radius": 0.1, "rotor.chord": 0.014,
        "rotor.inertia": 2.0e-5, "motor.omega_max": 1700.0, "motor.time_constant": 0.04})
    hover = dict(scenario="hover-oge", duration=40.0, alt_wander=0.3)
    sim = simulate(**hover, vehicle=quad, seed=1).table
    real = simulate(**hover, vehicle=s500, seed=2).table
    data = analyse(sim, real, "sim", "real").data
    assert data["verdict"] == "different-vehicle"
    assert "inertia_scale" in data["reason"] and "search bound" in data["reason"]


def test_a_look_alike_the_logs_cannot_name_caps_what_shares_its_channels():
    """Logs without velocity and a +1.2 m/s² z accelerometer bias on REAL: the vertical
    force alone cannot tell the bias from a thrust scale or a mass (the channel that would,
    accelerometer against velocity, is missing), so nothing is named at ≥ 0.5 and the
    caveat names the accelerometer bias and the missing signal."""
    hover = dict(scenario="hover-oge", duration=40.0, alt_wander=0.3)
    sim = simulate(**hover, seed=1).table.drop(columns=["vx", "vy", "vz"])
    real = simulate(**hover, seed=2, settings={"vehicle.accel_bias": [0.0, 0.0, 1.2]}
                    ).table.drop(columns=["vx", "vy", "vz"])
    data = analyse(sim, real, "sim", "real").data
    assert data["verdict"] == "mismatch", data["summary"]
    az_named = [e for e in data["effects"] if "az" in e["channels"]]
    assert az_named, data["summary"]
    for e in az_named:
        assert e["confidence"] <= BELOW_CONFIDENCE, e
        assert "look-alike: accel bias" in e["caveat"] and "vel" in e["caveat"], e["caveat"]


def test_an_unseen_look_alike_within_chance_caps_nothing():
    """The hidden candidate caps a name on its channels when its held-out gain is beyond
    chance (block by block), whatever its size per sample: the named effect has already
    shown there is an effect, the question is only whether the look-alike explains it."""
    from etsid.gap.calibration import Calibration
    from etsid.gap.criterion import Evaluated
    from etsid.gap.likelihood import cap_unseen

    def hidden(blocks: list[float]) -> Evaluated:
        return Evaluated("accel_bias", (), [], np.array(blocks), 1000, False,
                         by_channel={"az": (float(sum(blocks)), 1000)})

    cal = Calibration(2.0, 0.05, 0.05, 0.01, {})
    effects = [{"name": "mass", "channels": ["az"], "confidence": 1.0},
               {"name": "inertia_scale", "channels": ["p", "q", "r"], "confidence": 1.0}]
    noise = [3.0, -2.0, 4.0, -3.0, 2.0, -1.0, 3.0, -4.0, 1.0, -2.0]  # 1 nat over 10 blocks
    cap_unseen(effects, [hidden(noise)], cal, lambda n: "vel")
    assert [e["confidence"] for e in effects] == [1.0, 1.0]
    # small per sample (0.012 nats) but in every block: beyond chance
    cap_unseen(effects, [hidden([1.2 + 0.1 * (i % 3) for i in range(10)])], cal,
               lambda n: "vel")
    assert [e["confidence"] for e in effects] == [BELOW_CONFIDENCE, 1.0]
    assert "lack vel" in effects[0]["caveat"] and "caveat" not in effects[1]
