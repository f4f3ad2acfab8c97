"""The nominal model's horizontal drag law: dissipative, and its structure (one law for
both body axes or one per axis, linear or with speed-squared terms) chosen on the
simulation's own held-out samples (:func:`etsid.gap.nominal._drag_law`).

Synthetic flights with a known drag law: the answers are the laws they were made with.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, filtfilt

from etsid.gap.nominal import DRAG_TERMS, _drag_law

FS = 100.0
"""Hz."""
N = 6000
NOISE = 0.05
"""m/s² of accelerometer noise on each axis, before the analysis low-pass (8 Hz)."""
PER_SAMPLE = 2 * 8.0 / FS
"""Independent samples per sample of signals low-passed at 8 Hz."""


def _velocity(rng: np.random.Generator, top: float) -> np.ndarray:
    """A smooth body velocity (m/s) wandering within about ±``top``."""
    b, a = butter(2, 0.3 / (FS / 2))
    v = filtfilt(b, a, rng.standard_normal(N + 400))[200:-200]
    return top * v / np.max(np.abs(v))


def _noise(rng: np.random.Generator) -> np.ndarray:
    """White noise of σ :data:`NOISE` low-passed at 8 Hz, as the analysis filters it, m/s²."""
    b, a = butter(4, 8.0 / (FS / 2))
    return filtfilt(b, a, NOISE * rng.standard_normal(N))


def _columns(vx: np.ndarray, vy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The drag regressors of both axes: ``Ω̄ v``, ``|v_j| v_j``, 1, ``|v| v_j`` (Ω̄ = 1)."""
    speed = np.hypot(vx, vy)
    return tuple(np.column_stack([v, np.abs(v) * v, np.ones_like(v), speed * v])
                 for v in (vx, vy))


def test_a_symmetric_quadratic_drag_flown_mostly_forward_is_one_quadratic_law() -> None:
    """A Crazyflie-like body drag, ``−0.027 |v_j| v_j`` on both axes, flown at up to 1.9 m/s
    forward but only 0.8 m/s sideways: one law for both axes with the speed-squared term,
    so the lateral force at 4 m/s (a wind) is predicted within 20 %, not left at zero."""
    rng = np.random.default_rng(3)
    vx, vy = _velocity(rng, 1.9), _velocity(rng, 0.8)
    xs = _columns(vx, vy)
    ys = tuple(-0.027 * np.abs(v) * v + 0.01 + _noise(rng)
               for v in (vx, vy))
    (cx, cy), law, _ = _drag_law(xs, ys, PER_SAMPLE)
    assert law == "one linear + quadratic law for x and y"
    assert np.allclose(np.delete(cx, 2), np.delete(cy, 2))
    assert all(cx[j] <= 0.0 for j in DRAG_TERMS), cx
    at_4 = _columns(np.zeros(1), np.full(1, 4.0))[1] @ cy - cy[2]
    assert at_4[0] == pytest.approx(-0.027 * 16.0, rel=0.2), cy


def test_its_look_alike_an_asymmetric_drag_flown_both_ways_keeps_a_law_per_axis() -> None:
    """A body three times as draggy sideways (``−0.1 v_x``, ``−0.3 v_y``), flown at up to
    2 m/s both ways: one shared law predicts SIM's held-out samples worse, so each axis
    keeps its own, each near its truth."""
    rng = np.random.default_rng(4)
    vx, vy = _velocity(rng, 2.0), _velocity(rng, 2.0)
    xs = _columns(vx, vy)
    ys = (-0.1 * vx + _noise(rng), -0.3 * vy + _noise(rng))
    (cx, cy), law, _ = _drag_law(xs, ys, PER_SAMPLE)
    assert "per axis" in law
    slope = [np.polyfit(v, x @ c, 1)[0] for v, x, c in ((vx, xs[0], cx), (vy, xs[1], cy))]
    assert slope == pytest.approx([-0.1, -0.3], rel=0.1)


def test_a_drag_the_noise_cannot_fix_never_pushes_the_body_along() -> None:
    """No drag at all, only noise and a slow drift of the offset that correlates with the
    velocity by chance: every drag coefficient stays ≤ 0 (an anti-dissipative term would
    extrapolate into a force that speeds the body up under a wind)."""
    rng = np.random.default_rng(5)
    vx, vy = _velocity(rng, 1.5), _velocity(rng, 0.6)
    xs = _columns(vx, vy)
    ys = (0.02 * vx + 0.01 * np.abs(vx) * vx + _noise(rng),
          0.03 * vy + _noise(rng))
    (cx, cy), _, _ = _drag_law(xs, ys, PER_SAMPLE)
    assert all(c[j] <= 0.0 for c in (cx, cy) for j in DRAG_TERMS), (cx, cy)
