"""The gap summary says which mismatched channel stayed unexplained (issue 43, item 5)."""

from __future__ import annotations

from typing import Any

from etsid.gap.nominal import LABELS
from etsid.gap.summary import summary_sentence


def _mismatch(channels: list[str], effect_channels: list[str]) -> dict[str, Any]:
    """A gap.json body of a mismatch on ``channels`` with one time delay named that acts
    on ``effect_channels``."""
    return {
        "verdict": "mismatch", "sim": {"file": "sim.ulg"}, "real": {"file": "real.ulg"},
        "mismatch": {"channels": channels, "regime": {"variable": "none"}},
        "nominal": {"z_all": {c: 9.0 for c in channels}},
        "effects": [{"name": "time_delay", "channels": effect_channels, "confidence": 0.8,
                     "parameters": {"delay": {"value": 0.04, "unit": "s"}}}],
        "rmse_before": {c: 1.0 for c in channels}, "rmse_after": {c: 0.5 for c in channels},
    }


def test_a_mismatched_channel_no_named_effect_acts_on_is_said_unexplained() -> None:
    text = summary_sentence(_mismatch(["q", "p"], ["p"]))
    assert "40 ms later" in text
    unexplained = text.split("Unexplained: ", 1)[1]
    assert unexplained.split(" — ")[0] == LABELS["q"]


def test_no_unexplained_sentence_when_the_named_effect_acts_on_every_channel() -> None:
    assert "Unexplained" not in summary_sentence(_mismatch(["q", "p"], ["p", "q"]))


def test_the_held_out_rmse_of_every_mismatched_channel_is_said() -> None:
    data = _mismatch(["q", "p"], ["p", "q"])
    data["rmse_after"] = {"q": 0.95, "p": 0.5}
    text = summary_sentence(data)
    assert f"{LABELS['q']} 1 → 0.95 rad/s² (-5 %)" in text
    assert f"{LABELS['p']} 1 → 0.5 rad/s² (-50 %)" in text


def test_a_channel_the_named_effect_barely_moves_is_said_mostly_unexplained() -> None:
    """The README's gap example: pitch is 2.1× its floor, the named ground effect lists
    pitch among its channels but takes its held-out RMSE only 0.806 → 0.763."""
    data = _mismatch(["az", "q"], ["az", "q"])
    data["rmse_before"] = {"az": 1.12, "q": 0.806}
    data["rmse_after"] = {"az": 0.103, "q": 0.763}
    data["noise"] = {"az": 0.089, "q": 0.452}
    text = summary_sentence(data)
    assert text.count("Mostly unexplained: ") == 1
    said = text.split("Mostly unexplained: ", 1)[1]
    assert said.startswith(f"{LABELS['q']} (the named effects remove 12 % of its excess")
    assert LABELS["az"] not in said
    data["rmse_after"]["q"] = 0.55  # 72 % of the excess removed: explained
    assert "Mostly unexplained" not in summary_sentence(data)


def test_a_mostly_yaw_torque_offset_says_a_twisted_rotor_gives_it_too() -> None:
    """In steady hover a yaw offset and rotors twisted on their arms (a yaw ∝ thrust) are
    one: the torque offset's sentence says so when its yaw part is the largest."""
    from etsid.gap.effects import effect

    said = effect("torque_offset").said
    yaw = said({"p_offset": 0.8, "q_offset": 0.4, "r_offset": 4.3}, "sim", "real")
    assert "(torque offset)" in yaw and "twisted on their arms" in yaw
    roll = said({"p_offset": 2.0, "q_offset": -1.0, "r_offset": 0.1}, "sim", "real")
    assert "twisted" not in roll
