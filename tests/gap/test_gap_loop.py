"""SIM's band-by-band response (etsid.gap.loop): a rate loop that answers its own motor
noise is told from one that follows its references (over such a loop, roll and pitch are
scored as prediction errors).

The loop here is a discrete one-axis rate loop: a P controller on the rate, a first-order
motor lag, and the motor's noise added inside the lag state (as PyFlyt's motors add theirs).
The model's prediction is the true command law, the lag of the command alone, so any
departure of the measured response from it is the loop's answer to the noise.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import butter, lfilter

from etsid.gap.loop import LOOP_TILT, BandResponse, band_response

FS_SIM, FS_LOG = 400, 100


def _fly(noise: float, kp: float, seed: int = 3, duration: float = 60.0,
         reference: float = 0.05, tau: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """(predicted, measured) angular acceleration, rad/s², logged at 100 Hz: the loop
    tracks a 1 Hz random rate reference of ``reference`` rad/s while ``noise`` (throttle
    units per step) enters the motor."""
    rng = np.random.default_rng(seed)
    n, dt = int(duration * FS_SIM), 1.0 / FS_SIM
    b, a = butter(2, 1.0 / (FS_SIM / 2))
    ref = lfilter(b, a, rng.standard_normal(n))
    ref *= reference / ref.std()
    kicks = rng.standard_normal(n) * noise
    rate = motor = commanded = 0.0
    pred, meas = np.zeros(n), np.zeros(n)
    for i in range(n):
        u = kp * (ref[i] - rate)
        motor += dt / tau * (u - motor) + kicks[i]
        commanded += dt / tau * (u - commanded)
        pred[i], meas[i] = commanded, motor
        rate += motor * dt
    step = FS_SIM // FS_LOG
    return pred[::step], meas[::step]


def _response(noise: float, kp: float) -> BandResponse:
    pred, meas = _fly(noise, kp)
    flight = SimpleNamespace(fs=float(FS_LOG), airborne=np.ones(pred.size, bool))
    model = SimpleNamespace(channels=("p",), predict=lambda *_: {"p": pred})
    return band_response(flight, model, {"p": meas})


def test_a_loop_following_its_references_reads_unity() -> None:
    """Without motor noise the measured response is the command law's: gain 1 in both
    bands, not noise-driven."""
    resp = _response(0.0, 30.0)
    assert resp.gains["p"] == pytest.approx((1.0, 1.0), abs=0.01)
    assert not resp.noise_driven


def test_a_loop_answering_its_motor_noise_is_noise_driven() -> None:
    """With noise of 0.3 per step against a 0.05 rad/s reference the commands are mostly the
    loop's answer to the noise: the true law reads low at 1-4 Hz and high at 4-8 Hz (as
    PyFlyt's Crazyflie, 0.7× and 1.5×), a tilt beyond LOOP_TILT even at its lower bound."""
    resp = _response(0.3, 30.0)
    low, high = resp.gains["p"]
    assert low < 0.8 and high > 1.2, resp.gains
    assert resp.tilt_low >= LOOP_TILT and resp.noise_driven


def test_the_same_tilt_read_through_sensor_noise_is_not_enough() -> None:
    """That loop measured through white noise of five times its signal: the gains stay
    unbiased (tilt about 2) but are read so loosely that the tilt's lower bound at the
    stated rate falls short of LOOP_TILT, and nothing is claimed."""
    pred, meas = _fly(0.3, 30.0)
    noisy = meas + 5.0 * meas.std() * np.random.default_rng(7).standard_normal(meas.size)
    flight = SimpleNamespace(fs=float(FS_LOG), airborne=np.ones(pred.size, bool))
    model = SimpleNamespace(channels=("p",), predict=lambda *_: {"p": pred})
    resp = band_response(flight, model, {"p": noisy})
    assert resp.tilt >= LOOP_TILT > resp.tilt_low and not resp.noise_driven


def test_its_look_alike_weak_noise_is_not_noise_driven() -> None:
    """A tenth of that noise leaves the reading within LOOP_TILT of unity."""
    resp = _response(0.03, 30.0)
    assert resp.gains and resp.tilt < LOOP_TILT and not resp.noise_driven


def test_a_band_the_commands_do_not_explain_gives_no_reading() -> None:
    """A measurement the prediction does not explain (independent noise: its coherence
    within chance at the stated rate) and a stretch shorter than three Welch segments give
    no band gain: nothing is claimed."""
    pred, _ = _fly(0.0, 30.0)
    flight = SimpleNamespace(fs=float(FS_LOG), airborne=np.ones(pred.size, bool))
    model = SimpleNamespace(channels=("p",), predict=lambda *_: {"p": pred})
    noise = np.random.default_rng(5).standard_normal(pred.size)
    resp = band_response(flight, model, {"p": noise})
    assert resp.gains == {} and np.isnan(resp.tilt) and not resp.noise_driven
    short = SimpleNamespace(fs=float(FS_LOG), airborne=np.arange(pred.size) < 600)
    assert band_response(short, model, {"p": pred}).gains == {}


def test_the_whitening_filter_of_an_autoregressive_noise_is_its_own() -> None:
    """The noise model of the prediction-error fit: an AR(2) noise e_t = 1.2 e_{t-1} −
    0.5 e_{t-2} + n_t is whitened by [1, −1.2, 0.5, 0, …] (order 6)."""
    from etsid.gap.whiten import AR_ORDER, ar_filter

    n = np.random.default_rng(2).standard_normal(20000)
    e = lfilter([1.0], [1.0, -1.2, 0.5], n)
    filt = ar_filter(e)
    assert filt.size == AR_ORDER + 1
    assert filt[:3] == pytest.approx([1.0, -1.2, 0.5], abs=0.03)
    assert np.all(np.abs(filt[3:]) < 0.03)
