"""The fast paths of the gap analysis give numpy's and scipy's own answers bit for bit: the
low-pass through the kernel, row sums as column additions, and what is kept per flight."""

from __future__ import annotations

import numpy as np
import pytest

import etsid.gap.nominal as nominal_module
from etsid.gap.candidates import LIBRARY, Context
from etsid.gap.fitting import Scorer, SharedMasks, fit_candidates
from etsid.gap.nominal import (
    Mods,
    _features,
    _row_mean,
    _row_sum,
    features,
    fit_nominal,
    measured,
)
from etsid.gap.signals import _lowpass_public, _lowpass_sos, lowpass, lowpass_series, prepare
from etsid.sim import simulate


@pytest.fixture(scope="module")
def table():
    return simulate("hover-oge", "quad250", duration=20.0, seed=3, alt_wander=0.3,
                    amplitude=0.4).table


@pytest.fixture(scope="module")
def flight(table):
    return prepare(table, "SIM")


@pytest.mark.parametrize("k", range(1, 13))
def test_row_sums_are_numpys_bit_for_bit(k):
    rng = np.random.default_rng(k)
    a = rng.normal(size=(3000, k)) * rng.uniform(0.01, 100.0, size=(3000, k))
    for arr in (a, np.asfortranarray(a), np.column_stack([a, a])[:, ::2]):
        assert np.array_equal(_row_sum(arr), arr.sum(axis=1))
        assert np.array_equal(_row_mean(arr), arr.mean(axis=1, keepdims=True))


@pytest.mark.parametrize("shape", [(4000,), (4000, 3), (40, 2), (500, 2, 3)])
@pytest.mark.parametrize("fs, cutoff", [(100.0, 8.0), (100.0, 0.5), (250.0, 40.0)])
def test_lowpass_kernel_path_is_sosfilt_bit_for_bit(shape, fs, cutoff):
    x = np.random.default_rng(7).normal(size=shape).cumsum(axis=0)
    sos, zi, edge = _lowpass_sos(min(cutoff / (0.5 * fs), 0.95))
    y = lowpass(x, fs, cutoff)
    assert y.shape == x.shape
    assert np.array_equal(y, _lowpass_public(x, sos, zi, edge))
    if x.ndim == 2:
        series = lowpass_series(list(x.T), fs, cutoff)
        assert all(np.array_equal(s, y[:, j]) for j, s in enumerate(series))


def test_measured_outputs_are_kept_read_only_until_a_signal_changes(table):
    flight = prepare(table, "SIM")
    first, again = measured(flight), measured(flight)
    assert all(first[c] is again[c] for c in first)
    with pytest.raises(ValueError):
        first["az"][0] = 0.0
    flight.rates = flight.rates.copy()
    flight.rates[:, 0] += 1.0  # a new array: computed again, the roll rate now differs
    changed = measured(flight)
    assert changed["p"] is not first["p"]
    assert changed["az"] is not first["az"]


def test_kept_regressors_equal_fresh_ones_and_serve_post_regression_changes(flight):
    nominal = fit_nominal(flight)
    chans = ("az", "p", "q", "r", "ax", "ay")
    for mods in (Mods(), Mods(thrust_gain=0.9), Mods(tau=0.05, delay=0.01),
                 Mods(wind=(1.0, -2.0))):
        kept = features(flight, nominal.k, nominal.tau, mods, chans, nominal.delay,
                        nominal.v_ref)
        fresh = _features(flight, nominal.k, nominal.tau, mods, chans, nominal.delay,
                          nominal.v_ref)
        assert set(kept) == set(fresh)
        assert all(np.array_equal(kept[c], fresh[c]) for c in fresh)
    # an inertia or an offset acts after the regressors: the same matrices are served
    a = features(flight, nominal.k, nominal.tau, Mods(inertia=1.3), chans, nominal.delay,
                 nominal.v_ref)
    b = features(flight, nominal.k, nominal.tau, Mods(offset={"p": 0.2}), chans,
                 nominal.delay, nominal.v_ref)
    assert all(a[c] is b[c] for c in chans)
    # a per-sample gain is never served from what is kept
    per_sample = Mods(thrust_gain=np.full(flight.n, 0.9))
    c = features(flight, nominal.k, nominal.tau, per_sample, chans, nominal.delay,
                 nominal.v_ref)
    assert c["az"].flags.writeable
    assert np.array_equal(c["az"], features(flight, nominal.k, nominal.tau,
                                            Mods(thrust_gain=0.9), chans, nominal.delay,
                                            nominal.v_ref)["az"])


@pytest.mark.parametrize("n_keys", [1, 2])
def test_kept_regressors_are_bounded(flight, n_keys, monkeypatch):
    monkeypatch.setattr(nominal_module, "FEATURES_KEYS", n_keys)
    nominal = fit_nominal(flight)
    for tau in np.linspace(0.02, 0.1, 6):
        features(flight, nominal.k, float(tau), Mods(), ("p", "q"), nominal.delay,
                 nominal.v_ref)
    kept = {key for key, _ in flight.__dict__["_features"]}
    assert len(kept) == n_keys


def test_a_fit_evaluates_each_parameter_point_once(flight):
    nominal = fit_nominal(flight)
    ctx = Context(flight, nominal, None, None)
    ys = measured(flight)
    sigma = {c: float(np.std(ys[c])) or 1.0 for c in ys}
    points: list[bytes] = []

    class Counting(Scorer):
        def objectives(self, mods, masks, channels):
            points.append(np.array([mods.inertia, mods.damping, mods.yaw_damping]).tobytes())
            return super().objectives(mods, masks, channels)

    scorer = Counting(ctx, ys, sigma)
    for name in ("inertia_scale", "rate_damping"):
        cand = next(c for c in LIBRARY if c.name == name)
        points.clear()
        fit_candidates((cand,), scorer, flight.airborne)
        assert points and len(points) == len(set(points))


def test_folds_share_one_prediction_and_get_their_own_answers(flight):
    """With shared masks each fold's fit equals its fit alone, and the second fold's
    coarse grid costs no new prediction."""
    nominal = fit_nominal(flight)
    ctx = Context(flight, nominal, None, None)
    ys = measured(flight)
    scorer = Scorer(ctx, ys, {c: float(np.std(ys[c])) or 1.0 for c in ys})
    idx = np.arange(flight.n)
    masks = [flight.airborne & (idx % 800 < 400), flight.airborne & (idx % 800 >= 400)]
    cand = next(c for c in LIBRARY if c.name == "thrust_scale")
    shared = SharedMasks(masks)
    together = [fit_candidates((cand,), scorer, m, shared=shared) for m in masks]
    alone = [fit_candidates((cand,), scorer, m) for m in masks]
    for a, b in zip(together, alone, strict=True):
        assert np.array_equal(a.theta, b.theta) and np.array_equal(a.stderr, b.stderr)
    assert not np.array_equal(together[0].theta, together[1].theta)
    first = SharedMasks(masks)
    fit_candidates((cand,), scorer, masks[0], shared=first)
    n_first = len(first.values)
    fit_candidates((cand,), scorer, masks[1], shared=first)
    own = SharedMasks([masks[1]])
    fit_candidates((cand,), scorer, masks[1], shared=own)
    assert len(first.values) - n_first <= len(own.values) - 13  # the 13-point grid reused


def _gain_cases(n: int, m: int) -> list[Mods]:
    rng = np.random.default_rng(5)
    return [Mods(thrust_gain=0.9), Mods(torque_gain=1.3, spin_gain=0.8, spinup=1.2),
            Mods(thrust_gain=rng.uniform(0.8, 1.2, n), torque_gain=rng.uniform(0.8, 1.2, n),
                 spin_gain=rng.uniform(0.9, 1.1, n)),
            Mods(thrust_gain=np.array([[1.0, 0.8] + [1.0] * (m - 2)]),
                 torque_gain=np.array([[1.0, 0.8] + [1.0] * (m - 2)])),
            Mods(thrust_gain=rng.uniform(0.8, 1.2, (n, m))),
            Mods(thrust_gain=1.1, tau=0.05, delay=0.01)]


def test_rotor_columns_from_kept_sums_equal_the_full_regression(flight):
    """Known answer: with motor outputs the per-rotor columns' share is summed from Ω², dΩ/dt
    and the gains instead of a matrix built per gain value; for constant, per-sample,
    per-rotor and per-rotor-and-sample gains, with a lag and delay, the model's channels
    equal the full regressor matrix times the coefficients (to rounding)."""
    nominal = fit_nominal(flight)
    chans = ("az", "p", "q", "r")
    n, m = flight.motors.shape
    for mods in _gain_cases(n, m):
        fast = nominal._unfiltered(flight, mods, chans, nominal.tau, nominal.delay)
        full = _features(flight, nominal.k, nominal.tau, mods, chans, nominal.delay,
                         nominal.v_ref)
        for c in chans:
            want = full[c] @ nominal.coef[c]
            assert np.allclose(fast[c], want, rtol=1e-12, atol=1e-12 * np.max(np.abs(want)))
