"""What the likelihood criterion may claim: an explanation that leaves a channel mismatched
is a partial one (capped confidence), and a scale beyond one airframe's faults — fitted, or
held at its search bound while it explains more than the named model — is another
airframe."""

from __future__ import annotations

import pytest

from etsid.gap.detectable import BELOW_CONFIDENCE
from etsid.gap.likelihood import AIRFRAME_SCALES, _airframe_evidence, cap_partial
from etsid.gap.run import analyse
from etsid.sim import load_vehicle, simulate


def test_a_leftover_caps_every_named_effect_and_says_why():
    effects = [{"name": "mass", "confidence": 1.0},
               {"name": "rotor_inertia", "confidence": 0.98, "caveat": "look-alike"}]
    cap_partial(effects, {"q": {"ratio": 1.5}})
    assert [e["confidence"] for e in effects] == [BELOW_CONFIDENCE, BELOW_CONFIDENCE]
    assert "partial explanation" in effects[0]["caveat"] and "1.5×" in effects[0]["caveat"]
    assert effects[1]["caveat"].startswith("look-alike; a partial explanation")


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
    data = analyse(sim, real, "sim", "real", method="likelihood").data
    assert data["verdict"] == "different-vehicle"
    assert "inertia_scale" in data["reason"] and "search bound" in data["reason"]
