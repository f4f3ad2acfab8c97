"""Findings of the science review (eTS formulas, simulator physics), one test per bug."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.sim import load_vehicle
from etsid.sim.ground import CHEESEMAN_BENNETT, SANCHEZ_CUEVAS, ground_ratio


def _tarot_ground_args() -> tuple[float, np.ndarray, float, float, float, float]:
    veh = load_vehicle("tarot680")
    pos = veh.rotor_positions
    dists = np.sqrt(np.sum((pos[:, None, :2] - pos[None, :, :2]) ** 2, axis=-1))[0]
    g = veh["ground"]
    b = float(np.hypot(pos[0, 0], pos[0, 1]))
    return veh["rotor"]["radius"], dists, b, g["k_body"], g["min_height_ratio"], g["max_ratio"]


@pytest.mark.parametrize("model", [CHEESEMAN_BENNETT, SANCHEZ_CUEVAS])
def test_ground_effect_ratio_is_continuous_in_height(model: int) -> None:
    """No thrust step when a hub crosses any height (it did at 5 R: 3.3 % for the Tarot's
    multirotor model, crossed every period by the sine-altitude flight)."""
    r, dists, b, kb, minh, maxr = _tarot_ground_args()
    z = np.concatenate([np.linspace(0.6 * r, 40.0 * r, 2001), r * np.array([3.0, 5.0, 6.0])])
    z.sort()
    ratio = np.array([ground_ratio(zi, r, model, dists, b, kb, minh, maxr) for zi in z])
    below = np.array([ground_ratio(zi * (1 - 1e-9), r, model, dists, b, kb, minh, maxr)
                      for zi in z])
    assert np.max(np.abs(ratio - below)) < 1e-6  # no step anywhere
    assert np.all(np.diff(ratio) <= 0.0)  # falls monotonically towards 1
    assert ratio[-1] == pytest.approx(1.0, abs=1e-3)
    assert np.all(ratio >= 1.0)
