"""Attitude states of the rate model: roll/pitch terms are integrated from the simulated
rates in free run (never read from the log after the start), the stability check carries
them as states, and the default model adds them only where the attitude loop closes around
the inputs. Known answers on constructed systems and a simulated flight."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify
from etsid.ident.defaults import ATTITUDE_TERMS, default_model
from etsid.ident.regressors import RegressorSpec, attitude_map, build
from etsid.ident.simulate import MIN_BIAS_PAIRS, free_run, kinematic_bias, linear_stability
from etsid.sim import simulate

DT = 0.02  # s, 50 Hz
A, C, B = 0.8, 6.0, 0.5  # p(k) = A p(k-1) − C·DT roll(k-1) + B u(k-1)
SPEC = "p[k-1],q[k-1],r[k-1],u[k-1],roll[k-1],pitch[k-1]"


def _theta() -> np.ndarray:
    """(3, 6) true coefficients on SPEC's terms: roll stiff through p, q and r decoupled."""
    theta = np.zeros((3, 6))
    theta[0, [0, 3, 4]] = [A, B, -C * DT]
    theta[1, 1] = 0.5
    theta[2, 2] = 0.5
    return theta


def _truth(n: int = 400, seed: int = 0) -> pd.DataFrame:
    """Roll-only flight of the true system; roll by the trapezoid rule on p (pitch 0, q r 0:
    the Euler kinematics reduce to d roll/dt = p, so integration reproduces it exactly)."""
    u = np.random.default_rng(seed).standard_normal(n)
    p, roll = np.zeros(n), np.zeros(n)
    for k in range(1, n):
        p[k] = A * p[k - 1] - C * DT * roll[k - 1] + B * u[k - 1]
        roll[k] = roll[k - 1] + DT * 0.5 * (p[k - 1] + p[k])
    zeros = np.zeros(n)
    return pd.DataFrame({"p": p, "q": zeros, "r": zeros, "u": u, "roll": roll,
                         "pitch": zeros}, index=pd.Index(np.arange(n) * DT, name="t"))


def test_free_run_integrates_the_angles_instead_of_reading_them() -> None:
    truth = _truth()
    spec = RegressorSpec.parse(SPEC, ["p", "q", "r"])
    theta = _theta()
    start = 50
    first = int(build(truth, spec).rows[start])  # the table row simulated first
    logged = truth.copy()
    logged.iloc[first:, logged.columns.get_loc("roll")] += 0.3  # a wrong log after the start
    reg = build(logged, spec)
    assert reg.kinematics is not None
    sim = free_run(lambda x: theta @ x, reg, spec, start, len(logged))
    rows = reg.rows[start:]
    # the true p follows, because roll came from integrating the simulated p …
    np.testing.assert_allclose(sim[:, 0], truth["p"].to_numpy()[rows], atol=1e-9)
    # … and reading the (wrong) logged roll would not have given it
    exo = build(logged, RegressorSpec.parse(SPEC, ["p", "q", "r"]))
    exo.kinematics = None
    misled = free_run(lambda x: theta @ x, exo, spec, start, len(logged))
    assert np.max(np.abs(misled[:, 0] - truth["p"].to_numpy()[rows])) > 0.05


def test_attitude_terms_are_states_only_for_a_model_of_p_q_r() -> None:
    assert [k for _, k, _ in attitude_map(RegressorSpec.parse(SPEC, ["p", "q", "r"]))] == [0, 1]
    assert attitude_map(RegressorSpec.parse("p[k-1],roll[k-1]", ["p"])) == []
    table = _truth().rename(columns={"q": "q_other"})
    reg = build(table, RegressorSpec.parse("p[k-1],roll[k-1]", ["p"]))
    assert reg.kinematics is None  # exogenous: taken from the table


def test_stability_carries_the_angle_states() -> None:
    spec = RegressorSpec.parse(SPEC, ["p", "q", "r"])
    theta = _theta()
    theta[1, 5] = -2.0 * DT  # pitch stiff through q too
    x0 = np.zeros(6)
    # state (p, q, r, roll, pitch): rates from theta, angle+ = angle + DT·rate+
    a = np.zeros((5, 5))
    a[:3] = theta[:, [0, 1, 2, 4, 5]]
    a[3] = DT * a[0] + np.eye(5)[3]
    a[4] = DT * a[1] + np.eye(5)[4]
    expected = np.max(np.abs(np.linalg.eigvals(a)))
    assert expected < 1.0
    out = linear_stability(lambda x: theta @ x, spec, x0, rate_hz=1 / DT)
    assert out["spectral_radius"] == pytest.approx(expected, rel=1e-6)
    assert not out["unstable"]
    # the angle pushing the rate the wrong way: the rate lags alone are stable (A < 1),
    # the loop through the integrated angle is not
    theta[0, 4] = +C * DT
    out = linear_stability(lambda x: theta @ x, spec, x0, rate_hz=1 / DT)
    assert out["unstable"]
    rates_only = RegressorSpec.parse("p[k-1],q[k-1],r[k-1],u[k-1]", ["p", "q", "r"])
    assert not linear_stability(lambda x: theta[:, :4] @ x, rates_only, np.zeros(4),
                                1 / DT)["unstable"]


def _stick_table(*extra: str) -> pd.DataFrame:
    rng = np.random.default_rng(1)
    cols = ["p", "q", "r", "u_roll", "u_pitch", "u_yaw", "u_thrust", *extra]
    return pd.DataFrame({c: rng.standard_normal(50) for c in cols})


def test_default_model_adds_the_angles_only_around_an_attitude_loop() -> None:
    terms = ATTITUDE_TERMS.split(",")
    with_att = default_model(_stick_table("roll", "pitch"))
    assert [str(t) for t in with_att.spec.terms[-2:]] == terms and with_att.attitude
    assert not default_model(_stick_table("roll", "pitch"), attitude="none").attitude
    assert default_model(_stick_table("roll", "pitch"), attitude="on").attitude
    assert not default_model(_stick_table()).attitude  # no angles in the log
    torque = _stick_table("roll", "pitch")
    torque.attrs["input_selection"] = {"kind": "torque"}
    assert not default_model(torque).attitude  # the rate loop's torque: angle already inside
    rates = pd.DataFrame({c: np.ones(5) for c in ("p", "q", "r", "sp_p", "sp_q", "sp_r",
                                                  "roll", "pitch")})
    assert not default_model(rates).attitude
    with pytest.raises(IdentError, match="--attitude-states"):
        default_model(_stick_table("roll", "pitch"), attitude="maybe")


@pytest.fixture(scope="module")
def hover() -> pd.DataFrame:
    """Hover out of ground effect, seed 9 (used for no choice): sticks command the angle."""
    return simulate("hover-oge", duration=60.0, seed=9).table


def test_attitude_states_raise_free_run_fit_on_a_simulated_flight(hover) -> None:
    table = hover
    runs = {att: identify(table, IdentConfig(attitude=att)) for att in ("none", "auto")}
    fit = {att: [run.metrics["outputs"][y]["validation"]["free_run"]["fit"] for y in "pq"]
           for att, run in runs.items()}
    terms = {att: run.config["model"]["regressors"].split(",") for att, run in runs.items()}
    assert terms["auto"][-2:] == ["roll[k-1]", "pitch[k-1]"]
    assert "roll[k-1]" not in terms["none"]
    assert all(a > b + 0.5 for a, b in zip(fit["auto"], fit["none"], strict=True)), fit


def test_kinematic_bias_recovers_a_gyro_bias_and_the_free_run_removes_it() -> None:
    truth = _truth(n=600, seed=3)
    bias = 0.02  # rad/s on the roll gyro; the logged roll (an estimator's) has none
    logged = truth.copy()
    logged["p"] += bias
    spec = RegressorSpec.parse(SPEC, ["p", "q", "r"])
    reg = build(logged, spec)
    assert reg.kinematics is not None
    start = 300
    est = kinematic_bias(reg.kinematics, int(reg.rows[start]))
    np.testing.assert_allclose(est, [bias, 0.0], atol=1e-9)
    # a gap (a missing second) is skipped, too few rows give no correction
    gappy = reg.kinematics.copy()
    gappy[150:, 0] += 1.0
    np.testing.assert_allclose(kinematic_bias(gappy, 300), [bias, 0.0], atol=1e-9)
    np.testing.assert_array_equal(kinematic_bias(reg.kinematics, MIN_BIAS_PAIRS), [0.0, 0.0])
    # the true model fed biased rates: p(k) = … + A·bias-shifted lags; predict the logged p
    theta = _theta()
    shift = (1.0 - A) * bias  # keeps the logged p = true p + bias a fixed point of the model

    def model(x: np.ndarray) -> np.ndarray:
        return theta @ x + np.array([shift, 0.0, 0.0])

    sim = free_run(model, reg, spec, start, len(logged))
    np.testing.assert_allclose(sim[:, 0], logged["p"].to_numpy()[reg.rows[start:]],
                               atol=1e-9)


def test_inner_split_keeps_true_angles_and_drops_angles_that_do_not_match_the_rates(
        hover) -> None:
    kept = identify(hover, IdentConfig()).config["model"]
    assert kept["attitude_states"]["kept"]
    assert kept["regressors"].split(",")[-2:] == ["roll[k-1]", "pitch[k-1]"]
    fits = kept["attitude_states"]["inner_free_run_fit"]
    assert min(fits["with"].values()) > max(fits["without"].values())
    # angles logged 1 s late: learnt against the late angle, integrated without the delay
    late = hover.copy()
    for column in ("roll", "pitch"):
        late[column] = np.roll(late[column].to_numpy(), 250)
    dropped = identify(late, IdentConfig()).config["model"]
    assert not dropped["attitude_states"]["kept"]
    assert "roll[k-1]" not in dropped["regressors"].split(",")
    assert any(n.startswith("attitude states") and "left out" in n for n in dropped["notes"])
    forced = identify(late, IdentConfig(attitude="on")).config["model"]
    assert "attitude_states" not in forced and "roll[k-1]" in forced["regressors"]


def test_predict_on_another_flight_integrates_the_angles(hover, tmp_path) -> None:
    from etsid.ident import predict, write_run

    run = identify(hover, IdentConfig())
    write_run(run, tmp_path / "A")
    other = simulate("hover-oge", duration=40.0, seed=10).table
    t0 = 25.0
    clean = predict(other, tmp_path / "A" / "rules.json", sim_from=t0)
    wrong = other.copy()
    after = wrong.index > t0
    wrong.loc[after, ["roll", "pitch"]] += 0.3  # a log whose angles are wrong after t0
    misled = predict(wrong, tmp_path / "A" / "rules.json", sim_from=t0)
    sim = clean.predictions[["p_sim", "q_sim"]].to_numpy()
    assert np.isfinite(sim[clean.predictions["t"].to_numpy() > t0 + 1]).all()
    np.testing.assert_allclose(misled.predictions[["p_sim", "q_sim"]].to_numpy(), sim,
                               atol=1e-12, equal_nan=True)
    assert clean.metrics["outputs"]["p"]["validation"]["free_run"]["fit"] > 80.0


def test_kept_kinematic_biases_equal_a_fresh_computation() -> None:
    """The biases kept per (terms, rows) and the terms found again for an equal copy of the
    kinematics give the numbers computed afresh, and a changed array is not mistaken."""
    from etsid.ident import simulate as sim_module

    reg = build(_truth(n=600, seed=4), RegressorSpec.parse(SPEC, ["p", "q", "r"]))
    kin = reg.kinematics
    assert kin is not None and not kin.flags.writeable
    copy = kin.copy()
    copy.flags.writeable = False
    other = kin.copy()
    other[:, 3] += 0.01
    other.flags.writeable = False
    for upto in (MIN_BIAS_PAIRS + 1, 200, 200, 451, len(kin)):
        for array in (kin, copy, other, kin):
            fresh = sim_module._bias_of(sim_module._bias_terms(array.copy()), upto)
            got = kinematic_bias(array, upto)
            assert got.tobytes() == fresh.tobytes()
            got[:] = 9.0  # the caller's copy: the kept one is not changed
    assert sim_module._bias_terms(copy) is sim_module._bias_terms(kin)
    assert not np.array_equal(kinematic_bias(other, 451), kinematic_bias(kin, 451))
