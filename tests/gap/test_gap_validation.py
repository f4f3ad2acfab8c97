"""The evidence splits of etsid/gap/validation.py."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.validation import blocked_split, time_split


def test_time_split_is_first_share_then_rest() -> None:
    mask = np.ones(100, dtype=bool)
    mask[:10] = False
    fit, score = time_split(mask, 0.6)
    assert fit.sum() == 54 and score.sum() == 36
    assert np.flatnonzero(fit).max() < np.flatnonzero(score).min()


def test_blocked_split_scores_where_the_mismatch_lives() -> None:
    """An effect confined to 10 % of a 60 s flight (one stretch at 5–11 s): the time split
    scores none of it; the blocked split fits and scores about half of it each, with gaps
    between neighbouring blocks and disjoint masks."""
    fs = 100.0
    t = np.arange(6000) / fs
    mask = np.ones(t.size, dtype=bool)
    departure = np.where((t >= 5.0) & (t < 11.0), 50.0, 1.0)
    _, score_t = time_split(mask, 0.6)
    assert departure[score_t].max() == 1.0
    fit, score = blocked_split(mask, fs, departure)
    assert not np.any(fit & score)
    hot = departure > 1.0
    assert 0.3 < (hot & fit).sum() / hot.sum() < 0.6
    assert 0.3 < (hot & score).sum() / hot.sum() < 0.6
    assert (fit | score).sum() == int(0.75 * t.size)  # a 0.5 s gap per 2 s block


class _KnownResponse:
    """A nominal model whose broadband prediction is a fixed series and whose reference is
    SIM's slope (the response statistics read only these two)."""

    def __init__(self, x: np.ndarray, reference: dict[str, tuple[float, float]]) -> None:
        self.x = x
        self.reference = reference

    def predict_broadband(self, flight, mods=None, channels=("p",)) -> dict[str, np.ndarray]:
        return {"p": self.x}


def _flight_responding(gain: float, rng: np.random.Generator, n: int = 20000,
                       fs: float = 100.0):
    """A flight whose roll acceleration is ``gain`` × a known command response plus the
    derivative of white gyro noise; (flight, command response)."""
    from types import SimpleNamespace

    from scipy.signal import butter, sosfiltfilt

    smooth = sosfiltfilt(butter(2, 5.0 / (0.5 * fs), output="sos"), rng.normal(0, 3, n))
    x = np.gradient(smooth, 1.0 / fs)
    rates = np.zeros((n, 3))
    rates[:, 0] = gain * smooth + rng.normal(0.0, 0.02, n)
    return SimpleNamespace(airborne=np.ones(n, dtype=bool), fs=fs, rates=rates), x


def test_response_gain_is_reals_broadband_slope_over_sims() -> None:
    """SIM responds with slope 1 to its prediction, REAL with 0.8, both with gyro noise: the
    slopes come out within 3 of their standard errors, the gain is their ratio, its t is
    (gain - 1) over the ratio's error, and a REAL like SIM gives a gain of 1 within 3 SE."""
    from etsid.gap.floors import broadband_slopes, response_gains

    rng = np.random.default_rng(3)
    sim, x_sim = _flight_responding(1.0, rng)
    ref = broadband_slopes(sim, _KnownResponse(x_sim, {}), ("p",))
    assert abs(ref["p"][0] - 1.0) < 3 * ref["p"][1]
    real, x_real = _flight_responding(0.8, rng)
    slope, se = broadband_slopes(real, _KnownResponse(x_real, {}), ("p",))["p"]
    assert abs(slope - 0.8) < 3 * se
    gain, t = response_gains(real, _KnownResponse(x_real, ref), ("p",))["p"]
    assert gain == pytest.approx(slope / ref["p"][0])
    se_gain = gain * np.hypot(se / slope, ref["p"][1] / ref["p"][0])
    assert t == pytest.approx((gain - 1.0) / se_gain)
    assert t < -10.0
    same, x_same = _flight_responding(1.0, rng)
    g_same, t_same = response_gains(same, _KnownResponse(x_same, ref), ("p",))["p"]
    assert abs(t_same) < 3.0 and g_same == pytest.approx(1.0, abs=0.02)


def test_a_gain_that_changes_with_what_was_flown_carries_its_block_spread() -> None:
    """REAL responds with slope 1.0 in its first half and 0.6 in its second (a response
    that depends on what was flown): the regression's own error is tiny, the slope's
    standard error is its spread over the blocks (std / √4), so the whole-flight slope of
    ≈ 0.8 is not read as known to a few thousandths."""
    from etsid.gap.floors import BLOCKS, broadband_slopes

    rng = np.random.default_rng(5)
    first, x1 = _flight_responding(1.0, rng, n=10000)
    second, x2 = _flight_responding(0.6, rng, n=10000)
    first.rates = np.vstack([first.rates, second.rates])
    first.airborne = np.ones(20000, dtype=bool)
    x = np.concatenate([x1, x2])
    slope, se = broadband_slopes(first, _KnownResponse(x, {}), ("p",))["p"]
    assert slope == pytest.approx(0.8, abs=0.03)
    blocks = [broadband_slopes(first, _KnownResponse(x, {}), ("p",), None,
                               np.isin(np.arange(20000), part))["p"][0]
              for part in np.array_split(np.arange(20000), BLOCKS)]
    assert se == pytest.approx(np.std(blocks, ddof=1) / np.sqrt(BLOCKS), rel=1e-6)
    assert se > 0.1


class _KnownYaw:
    """A nominal model whose broadband yaw prediction is a command response plus SIM's
    own spin-up part (:meth:`broadband_spin`)."""

    def __init__(self, torque: np.ndarray, spin: np.ndarray,
                 reference: dict[str, tuple[float, float]]) -> None:
        self.torque, self.spin, self.reference = torque, spin, reference

    def predict_broadband(self, flight, mods=None, channels=("r",)) -> dict[str, np.ndarray]:
        return {"r": self.torque + self.spin}

    def broadband_spin(self, flight) -> np.ndarray:
        return self.spin


def test_the_yaw_gain_keeps_sims_spin_up_part_apart() -> None:
    """SIM fitted a spin-up coefficient on its motor noise (as a simulation without rotor
    inertia does); REAL's yaw acceleration follows the command response alone. With the
    spin-up part as its own regressor the yaw slope is 1 within 3 standard errors; read as
    one prediction the same data give a slope below 0.7."""
    from etsid.gap.floors import broadband_slopes

    rng = np.random.default_rng(6)
    flight, torque = _flight_responding(1.0, rng)
    flight.rates = flight.rates[:, [1, 2, 0]]  # the response in yaw
    spin = rng.normal(0.0, float(np.std(torque)), torque.size)
    slope, se = broadband_slopes(flight, _KnownYaw(torque, spin, {}), ("r",))["r"]
    assert abs(slope - 1.0) < 3 * se and se < 0.05
    assert _lumped_slope(flight, torque + spin) < 0.7


def _lumped_slope(flight, x: np.ndarray) -> float:
    """Least-squares slope of the yaw gyro's derivative on one lumped prediction ``x``."""
    from etsid.gap.signals import derivative

    acc = derivative(flight.rates, flight.fs)[:, 2]
    xc, yc = x - x.mean(), acc - acc.mean()
    return float(xc @ yc / (xc @ xc))


def test_no_response_gain_without_a_reference_sim_responds_to() -> None:
    """SIM's slope within 10 standard errors of zero (its commands barely drive the axis):
    no gain is given for that axis."""
    from etsid.gap.floors import response_gains

    rng = np.random.default_rng(4)
    real, x = _flight_responding(1.0, rng)
    assert response_gains(real, _KnownResponse(x, {"p": (0.05, 0.01)}), ("p",)) == {}
    assert "p" in response_gains(real, _KnownResponse(x, {"p": (1.0, 0.01)}), ("p",))
