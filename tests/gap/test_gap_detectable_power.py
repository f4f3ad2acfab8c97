"""The stated detectable size against what the criterion names (known answers on etsid's
simulator: a quad250 hover against a second flight of it with a time delay), and how the
size is read off the change curve."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.calibration import load_calibration
from etsid.gap.detectable import _crossing, detectable_sizes
from etsid.gap.run import analyse
from etsid.sim import simulate

HOVER = dict(scenario="hover-oge", duration=40.0, alt_wander=0.3, vehicle="quad250")


def _pair(delay: float) -> dict:
    sim = simulate(**HOVER, seed=1).table
    real = simulate(**{**HOVER, "duration": 45.0}, seed=2,
                    settings={"vehicle.time_delay": delay} if delay else None).table
    return analyse(sim, real, "sim", "real").data


def _confidence(data: dict, name: str) -> float:
    return max((e["confidence"] for e in data["effects"] if e["name"] == name), default=0.0)


@pytest.fixture(scope="module")
def stated() -> float:
    """The time delay this quad250 pair could have seen, stated on a pair without one."""
    data = _pair(0.0)
    assert data["verdict"] == "consistent", data["summary"]
    return float(data["detectable"]["time_delay"]["size"])


def test_a_delay_three_times_its_stated_size_is_named(stated: float) -> None:
    data = _pair(3.0 * stated)
    assert _confidence(data, "time_delay") >= 0.9, data["summary"]


def test_a_delay_a_third_of_its_stated_size_is_at_most_a_hint(stated: float) -> None:
    """The criterion can name an effect below the size the mismatch rule states (here a
    delay of a third of it is named); such a name is capped below even odds."""
    data = _pair(stated / 3.0)
    assert _confidence(data, "time_delay") < 0.5, data["summary"]


def test_the_size_is_where_the_variance_ratio_crosses_in_log_log() -> None:
    """Known answer on a synthetic curve growing as size² between the steps."""
    cal = load_calibration()
    need = cal.mismatch_ratio - 1.0
    sizes = [0.01, 0.1, 1.0]
    curve = {"span": 1.0, "sizes": sizes, "excess": [need / 100, need, need * 100]}
    evidence = {"offset_channels": 0,
                "effects": {"time_delay": {"parameters": {"delay": {"unit": "s",
                                                                     "up": curve}}}}}
    assert detectable_sizes(evidence, cal)["time_delay"]["size"] == pytest.approx(0.1)
    curve["excess"] = [need * 4, need * 400, need * 4e4]  # crossing below the first step
    assert detectable_sizes(evidence, cal)["time_delay"]["size"] == pytest.approx(0.005)


def test_a_saturating_change_is_extrapolated_with_at_least_the_second_power() -> None:
    """A change that grows slowly between the first two steps (a delay past the loop's
    bandwidth) does not claim a size far below the first step."""
    size = _crossing(np.array([0.01, 0.1, 1.0]), np.array([10.0, 12.0, 13.0]), 1.0)
    assert size == pytest.approx(0.01 / np.sqrt(10.0), rel=1e-9)
