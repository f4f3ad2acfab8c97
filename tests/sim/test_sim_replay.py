"""Replay: a simulated flight's own commands give back the flight; fitting by simulation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
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
    with pytest.raises(SimError, match="mode 'motors' needs the motor outputs"):
        replay(table.drop(columns=["m3"]), mode="motors")
    with pytest.raises(SimError, match="uniform time grid"):
        replay(table.iloc[[0, 1, 3, 4]])
    with pytest.raises(SimError, match="has 4 rotors"):
        replay(table, "quad250")
    with pytest.raises(SimError, match="mode must be one of loop, motors"):
        replay(table, mode="dream")
    # missing optional columns are assumed and said so
    twin = replay(table.iloc[:500].drop(columns=["vx", "vy", "vz"]))
    assert twin.sources["vx"].startswith("not in the log")


def test_cli_replay_writes_the_twin(tmp_path: Path) -> None:
    log = tmp_path / "flight.parquet"
    runner = CliRunner()
    result = runner.invoke(cli, ["simulate", "hover-oge", "--duration", "4", "-o", str(log)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "twin.parquet"
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out),
                                 "--thrust", "alt-hold", "--set", "vehicle.thrust_scale=1.0"])
    assert result.exit_code == 0, result.output
    assert "twin of" in result.output and "controller: vehicle file" in result.output
    twin = pd.read_parquet(out)
    original = pd.read_parquet(log)
    assert len(twin) == len(original)
    d = twin["true_p"] - original["true_p"]
    assert math.sqrt(float(np.mean(d**2))) < 0.01  # rad/s
    result = runner.invoke(cli, ["simulate", "hover-oge", "--replay", str(log), "-o",
                                 str(out)])
    assert result.exit_code == 2 and "either SCENARIO or --replay" in result.output
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out), "--set",
                                 "scenario.duration=2"])
    assert result.exit_code == 1 and "vehicle settings only" in result.stderr


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
