"""Replay: a simulated flight's own commands give back the flight; fitting by simulation."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import SimError
from etsid.sim import load_vehicle, simulate
from etsid.sim.params import pack
from etsid.sim.replay import motor_speed_history, replay, replay_many


@pytest.fixture(scope="module")
def flight():
    return simulate("hover-ige", duration=30.0, seed=1)


def _rel_rmse(twin: pd.DataFrame, truth: pd.DataFrame, axis: str) -> float:
    d = twin[f"true_{axis}"] - truth[f"true_{axis}"]
    return float(np.sqrt(np.mean(d**2)) / truth[f"true_{axis}"].std())


@pytest.mark.parametrize("thrust", ["command", "alt_hold"])
def test_loop_replay_reproduces_rates_and_altitude(flight, thrust: str) -> None:
    twin = replay(flight.table, thrust=thrust)
    assert twin.table.index.equals(flight.table.index)
    for axis in "pqr":
        assert _rel_rmse(twin.truth, flight.truth, axis) < 0.10, axis
    alt_err = (twin.truth["true_alt"] - flight.truth["true_alt"]).abs().max()
    assert alt_err < (0.1 if thrust == "command" else 0.05)
    # against what a log has (noisy, biased gyro): the noise floor dominates
    for axis in "pqr":
        err = twin.errors[axis]
        assert err["rmse"] < 2.0 * flight.table.attrs["noise"]["gyro_std"]
        assert err["ratio"] == pytest.approx(err["rmse"] / np.std(flight.table[axis]))
    assert "log" in twin.sources["loop commands"] and "vehicle file" in twin.sources["controller"]


def test_loop_replay_with_the_wrong_vehicle_is_worse(flight) -> None:
    good = replay(flight.table).errors
    bad = replay(flight.table, settings={"inertia_scale": 1.6}).errors
    assert bad["p"]["rmse"] > 1.3 * good["p"]["rmse"]


def test_motor_replay_over_short_horizons() -> None:
    fast = simulate("hover-ige", duration=10.0, seed=2, rate_hz=1000.0)
    twin = replay(fast.table, mode="motors", horizon=1.0)
    assert np.allclose(twin.horizons, np.arange(10.0))
    starts = np.searchsorted(fast.table.index, twin.horizons)
    # every horizon starts from the recorded state
    assert np.allclose(twin.table["roll"].to_numpy()[starts],
                       fast.table["roll"].to_numpy()[starts], atol=1e-12)
    for axis in "pqr":  # open loop, exact model: 0.09-0.23 of std over 1 s horizons
        assert _rel_rmse(twin.truth, fast.truth, axis) < 0.3, axis
    longer = replay(fast.table, mode="motors", horizon=5.0)
    assert _rel_rmse(longer.truth, fast.truth, "roll") > _rel_rmse(twin.truth, fast.truth,
                                                                   "roll")


def test_replay_many_fits_a_time_delay_and_equals_single_runs() -> None:
    delayed = simulate("hover-oge", duration=12.0, seed=3,
                       settings={"vehicle.time_delay": 0.02})
    delays = [0.0, 0.01, 0.02, 0.03]
    twins = replay_many(delayed.table, [{"time_delay": d} for d in delays])
    score = [sum(_rel_rmse(t.truth, delayed.truth, a) for a in "pq") for t in twins]
    assert delays[int(np.argmin(score))] == 0.02
    single = replay(delayed.table, settings={"time_delay": 0.01})
    assert np.array_equal(single.truth.to_numpy(), twins[1].truth.to_numpy())


def test_motor_speed_history_matches_a_plain_loop() -> None:
    veh = load_vehicle().with_settings({"motor_lag": [0.03, 0.08]})
    P = pack(veh, dt=1e-3, ground_effect=False, thr_hover=0.5, alt_hold=True)
    rng = np.random.default_rng(0)
    m = np.clip(0.5 + 0.2 * rng.standard_normal((200, 6)), 0, 1)
    vbat = np.full(200, 22.0)
    got = motor_speed_history(m, vbat, P, 0.004)
    mo = veh["motor"]
    wss = mo["omega_idle"] + (mo["omega_max"] * 22.0 / mo["v_ref"] - mo["omega_idle"]) * m
    ref = np.empty_like(wss)
    ref[0] = wss[0]
    for i in range(1, 200):
        tau = np.where(wss[i] > ref[i - 1], 0.03, 0.08)
        ref[i] = wss[i] + (ref[i - 1] - wss[i]) * np.exp(-0.004 / tau)
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_replay_refuses_what_it_cannot_do(flight) -> None:
    table = flight.table
    with pytest.raises(SimError, match="no 'roll' column"):
        replay(table.drop(columns=["roll"]))
    with pytest.raises(SimError, match="no 'u_thrust' column"):
        replay(table.drop(columns=["u_thrust"]))
    motors = [f"m{i}" for i in range(1, 7)]
    with pytest.raises(SimError, match="mode 'motors' needs the motor outputs"):
        replay(table.drop(columns=motors), mode="motors")
    with pytest.raises(SimError, match="6 motor outputs but the vehicle 'quad250' has 4"):
        replay(table, "quad250")
    with pytest.raises(SimError, match="5 motor outputs but the vehicle 'tarot680' has 6"):
        replay(table.drop(columns=["m6"]))
    with pytest.raises(SimError, match="mode must be one of loop, motors"):
        replay(table, mode="dream")
    # missing optional columns are assumed and said so
    twin = replay(table.iloc[:500].drop(columns=["vx", "vy", "vz"]))
    assert twin.sources["vx"].startswith("not in the log")


def test_motor_replay_tells_delay_from_lag() -> None:
    truth_fx = {"time_delay": 0.02, "motor_lag": [0.04, 0.08]}
    flight = simulate("hover-ige", duration=8.0, seed=3, rate_hz=1000.0,
                      settings={f"vehicle.{k}": v for k, v in truth_fx.items()})
    candidates = [{"time_delay": d, "motor_lag": [0.04, 0.08]} for d in (0.0, 0.01, 0.02, 0.03)]
    candidates.append({"time_delay": 0.02})  # right delay, symmetric file lag
    twins = replay_many(flight.table, candidates, mode="motors", horizon=1.0)
    score = [sum(_rel_rmse(t.truth, flight.truth, a) for a in "pqr") for t in twins]
    assert int(np.argmin(score)) == 2
    assert score[4] > 1.3 * score[2]


def test_replay_of_an_uneven_log_is_resampled_and_says_so(flight) -> None:
    uneven = flight.table.iloc[:600].drop(flight.table.index[[5, 6, 90]])
    twin = replay(uneven)
    assert "resampled" in twin.sources["time grid"]
    assert np.allclose(np.diff(twin.table.index), np.median(np.diff(flight.table.index)))


def test_log_noise_is_measured_and_given_to_the_twin(flight) -> None:
    """The twin's sensors carry the log's own noise (estimated from second differences),
    not the vehicle file's: a log with 3× the file's gyro and accelerometer noise gives a
    twin with 3× (within 25 %)."""
    from etsid.sim.params import NZ_ACC, NZ_GYRO
    from etsid.sim.replay import log_noise_std

    veh = flight.vehicle
    noisy = simulate("hover-oge", duration=8.0, seed=5, settings={
        "vehicle.sensors.gyro_std": 3 * veh["sensors"]["gyro_std"],
        "vehicle.sensors.accel_std": 3 * veh["sensors"]["accel_std"]})
    std = log_noise_std(noisy.table, np.zeros(14))
    assert std[NZ_GYRO] == pytest.approx(3 * veh["sensors"]["gyro_std"], rel=0.25)
    assert std[NZ_ACC + 2] == pytest.approx(3 * veh["sensors"]["accel_std"], rel=0.25)
    twin = replay(noisy.table, noise="log")
    assert "log's own sensor noise" in twin.sources["sensors"]
    hf = np.std(np.diff(twin.table["p"].to_numpy(), 2)) / np.sqrt(6)
    assert hf == pytest.approx(3 * veh["sensors"]["gyro_std"], rel=0.3)
    assert np.std(np.diff(replay(noisy.table).table["p"].to_numpy(), 2)) < 0.3 * hf * np.sqrt(6)


def test_a_twin_that_leaves_the_recording_is_reported() -> None:
    """Half the thrust: the twin cannot hold the recorded height and the replay says when
    and how it left the recording (and that it is on the ground while the log flies)."""
    high = simulate("hover-oge", duration=20.0, seed=4)
    assert replay(high.table).divergence is None
    weak = replay(high.table, settings={"thrust_scale": 0.5})
    assert weak.divergence is not None
    assert weak.divergence["t"] < 10.0 and "ground_t" in weak.divergence
    assert "from the recording" in weak.divergence["what"] or \
        "on the ground" in weak.divergence["what"]
