"""The free-run kernel equals the plain loop (``free_run_reference``) on small cases that
take every branch: lagged outputs fed back, roll and pitch integrated with a gyro bias,
two segments, a divergence per segment, eTS models with rules on the regressors and on
measured scheduling inputs, and the linear ARX packing."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.ets import ETS
from etsid.ident.arx import ARX
from etsid.ident.regressors import RegressorSpec, build
from etsid.ident.simulate import envelope, free_run, free_run_reference
from etsid.ident.simulate_kernel import pack_linear

DT = 0.02  # s
SPEC = "p[k-1..k-2],q[k-1],r[k-1],u_roll[k-1..k-2],u_pitch[k-1],roll[k-1],pitch[k-1]"
OUTPUTS = ("p", "q", "r")


def _flight(n: int = 700, seed: int = 4) -> pd.DataFrame:
    """A coupled rate system with roll and pitch from the Euler kinematics, two segments
    and a varying altitude (for the scheduled model); gyro bias 0.01 rad/s on p."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 2)).cumsum(axis=0) * 0.05
    u -= u.mean(axis=0)
    p, q, r = np.zeros(n), np.zeros(n), np.zeros(n)
    roll, pitch = np.zeros(n), np.zeros(n)
    alt = 1.0 + 0.8 * np.sin(np.arange(n) * DT * 0.7) ** 2
    for k in range(1, n):
        gain = 0.5 + 0.3 / alt[k - 1]  # the response depends on the height
        p[k] = 0.8 * p[k - 1] - 0.1 * roll[k - 1] + gain * u[k - 1, 0]
        q[k] = 0.85 * q[k - 1] - 0.1 * pitch[k - 1] + 0.4 * u[k - 1, 1]
        r[k] = 0.9 * r[k - 1] + 0.05 * p[k - 1]
        roll[k] = roll[k - 1] + DT * (p[k] + (q[k] * np.sin(roll[k - 1])
                                                + r[k] * np.cos(roll[k - 1]))
                                      * np.tan(pitch[k - 1]))
        pitch[k] = pitch[k - 1] + DT * (q[k] * np.cos(roll[k - 1]) - r[k] * np.sin(roll[k - 1]))
    noise = rng.standard_normal((n, 3)) * 0.002
    seg = (np.arange(n) >= n // 2).astype(int)
    return pd.DataFrame({"p": p + 0.01 + noise[:, 0], "q": q + noise[:, 1], "r": r + noise[:, 2],
                         "u_roll": u[:, 0], "u_pitch": u[:, 1], "roll": roll,
                         "pitch": pitch, "alt": alt, "segment": seg},
                        index=pd.Index(np.arange(n) * DT, name="t"))


def _both(model, reg, spec, start, bounds, predict_one):  # type: ignore[no-untyped-def]
    fast_div: list[float] = []
    slow_div: list[float] = []
    fast = free_run(model, reg, spec, start, len(reg.kinematics), bounds, fast_div)
    slow = free_run_reference(predict_one, reg, spec, start, len(reg.kinematics), bounds,
                              slow_div)
    return fast, slow, fast_div, slow_div


def _ets(reg, spec, upto: int, scheduled: bool) -> ETS:  # type: ignore[no-untyped-def]
    model = ETS(radius=0.3 if scheduled else 0.6, input_names=spec.input_names,
                output_names=list(spec.outputs))
    model.run(reg.X[:upto], reg.Y[:upto], reg.S[:upto] if scheduled else None)
    return model


@pytest.mark.parametrize("antecedent", [None, "inv_alt[k-1]"])
def test_kernel_equals_the_plain_loop_for_ets(antecedent: str | None) -> None:
    spec = RegressorSpec.parse(SPEC, OUTPUTS, antecedent)
    reg = build(_flight(), spec)
    assert reg.kinematics is not None and (reg.S is not None) == (antecedent is not None)
    assert len(np.unique(reg.segment)) == 2
    model = _ets(reg, spec, 250, antecedent is not None)
    assert model.n_rules >= 2  # several rules fire: the firing arithmetic is exercised
    predict = ((lambda x, s: model.predict_one(x, s)) if antecedent
               else (lambda x: model.predict_one(x)))
    for bounds in (None, envelope(reg.Y)):
        fast, slow, fd, sd = _both(model, reg, spec, 250, bounds, predict)
        assert np.isfinite(slow).sum() > 300
        np.testing.assert_array_equal(np.isnan(fast), np.isnan(slow))
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
        assert fd == sd


def test_kernel_equals_the_plain_loop_for_arx_and_stops_each_segment() -> None:
    spec = RegressorSpec.parse(SPEC, OUTPUTS)
    reg = build(_flight(), spec)
    start = 200
    arx = ARX.fit(reg.X[:start], reg.Y[:start])
    fast, slow, fd, sd = _both(arx, reg, spec, start, envelope(reg.Y), arx.predict_one)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    assert np.isfinite(slow).sum() > 300
    # an unstable model: the p feedback gain doubled diverges, once in each segment
    wild = ARX(arx.theta.copy())
    wild.theta[1, 0] = 2.5
    fast, slow, fd, sd = _both(wild, reg, spec, start, envelope(reg.Y), wild.predict_one)
    assert len(sd) == 2 and fd == sd
    np.testing.assert_array_equal(np.isnan(fast), np.isnan(slow))
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)


def test_linear_packing_predicts_as_the_linear_model() -> None:
    from etsid.ets.kernels import predict_row

    rng = np.random.default_rng(1)
    theta = rng.standard_normal((5, 3))
    frozen, work = pack_linear(theta)
    for x in rng.standard_normal((20, 4)):
        out = np.empty(3)
        assert predict_row(x, np.zeros(0), out, frozen, work)
        np.testing.assert_allclose(out, theta[0] + x @ theta[1:], rtol=1e-14, atol=1e-14)


def _fallback(spec: RegressorSpec, arx: ARX, replace: dict[str, str]):  # type: ignore[no-untyped-def]
    from etsid.ident.fallback import Fallback

    m, names = len(spec.outputs), spec.input_names
    mask, theta = np.zeros(m, dtype=bool), np.zeros((len(names) + 1, m))
    for y, model in replace.items():
        o = spec.outputs.index(y)
        mask[o] = True
        if model == "ARX":
            theta[:, o] = arx.theta[:, o]
        else:
            theta[names.index(f"{y}[k-1]") + 1, o] = 1.0
    return Fallback(mask, theta, dict(replace))


def test_kernel_interpolates_a_model_with_an_interpolated_blend() -> None:
    """``blend="interpolate"``: the kernel equals the plain loop, and its first step (fed
    measured history) is the batch prediction, which interpolates (not the firing blend)."""
    spec = RegressorSpec.parse(SPEC, OUTPUTS, "inv_alt[k-1]")
    reg = build(_flight(), spec)
    models = {}
    for blend in ("firing", "interpolate"):
        models[blend] = ETS(radius=0.3, blend=blend, input_names=spec.input_names,
                            output_names=list(spec.outputs))
        models[blend].run(reg.X[:250], reg.Y[:250], reg.S[:250])
    model = models["interpolate"]
    assert model.n_rules >= 2
    fast, slow, _, _ = _both(model, reg, spec, 250, None, lambda x, s: model.predict_one(x, s))
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    first = model.predict(reg.X[250:251], reg.S[250:251])[0]
    np.testing.assert_allclose(fast[0], first, rtol=0, atol=1e-12)
    fired = models["firing"].predict(reg.X[250:251], reg.S[250:251])[0]
    assert np.abs(first - fired).max() > 1e-6


@pytest.mark.parametrize("antecedent", [None, "inv_alt[k-1]"])
def test_kernel_equals_the_plain_loop_for_a_mixed_model(antecedent: str | None) -> None:
    """eTS on p and r, its fall-back on q (ARX, then no-change): the kernel's mixed model
    equals the plain loop fed with the mixed ``predict_one``, divergences included."""
    from etsid.ident.simulate import mixed_predict_one

    spec = RegressorSpec.parse(SPEC, OUTPUTS, antecedent)
    reg = build(_flight(), spec)
    model = _ets(reg, spec, 250, antecedent is not None)
    arx = ARX.fit(reg.X[:250], reg.Y[:250])
    for replace in ({"q": "ARX"}, {"q": "no-change"}):
        fb = _fallback(spec, arx, replace)
        one = mixed_predict_one(model, fb)
        for bounds in (None, envelope(reg.Y)):
            fd: list[float] = []
            sd: list[float] = []
            fast = free_run(model, reg, spec, 250, len(reg.kinematics), bounds, fd, fb)
            slow = free_run_reference(one, reg, spec, 250, len(reg.kinematics), bounds, sd)
            assert np.isfinite(slow).sum() > 300
            np.testing.assert_array_equal(np.isnan(fast), np.isnan(slow))
            np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
            assert fd == sd
        pure = free_run(model, reg, spec, 250, len(reg.kinematics), None)
        assert not np.allclose(fast[:, 1], pure[:, 1])  # q is not eTS's any more


def test_every_output_on_its_fall_back_is_the_arx_free_run() -> None:
    """Known answer: an eTS model with every output replaced by ARX simulates exactly as
    ARX alone, and no-change on every output holds the first value of each segment."""
    spec = RegressorSpec.parse(SPEC, OUTPUTS)
    reg = build(_flight(), spec)
    model = _ets(reg, spec, 250, False)
    arx = ARX.fit(reg.X[:250], reg.Y[:250])
    n_table = len(reg.kinematics)
    mixed = free_run(model, reg, spec, 250, n_table, None, None,
                     _fallback(spec, arx, dict.fromkeys(OUTPUTS, "ARX")))
    np.testing.assert_allclose(mixed, free_run(arx, reg, spec, 250, n_table), rtol=0,
                               atol=1e-12)
    held = free_run(model, reg, spec, 250, n_table, None, None,
                    _fallback(spec, arx, dict.fromkeys(OUTPUTS, "no-change")))
    names = spec.input_names
    for seg in np.unique(reg.segment[250:]):
        rows = np.flatnonzero(reg.segment[250:] == seg)
        first = [reg.X[250 + rows[0], names.index(f"{y}[k-1]")] for y in OUTPUTS]
        np.testing.assert_array_equal(held[rows], np.tile(first, (len(rows), 1)))
