"""Closed-loop flights: FlightTable contract, ground effect, step responses, yaw sign,
determinism, noise levels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from etsid.sim import SCENARIOS, hover_trim, load_vehicle, simulate

MEASURED = ["p", "q", "r", "roll", "pitch", "yaw", "u_roll", "u_pitch", "u_yaw", "u_thrust",
            "sp_p", "sp_q", "sp_r", "alt", "vx", "vy", "vz", "ax", "ay", "az", "vbat"]


@pytest.fixture(scope="module")
def ige():
    return simulate("hover-ige", duration=30.0, seed=1)


def test_flight_table_contract(ige) -> None:
    table, truth = ige.table, ige.truth
    assert table.index.name == "t"
    assert table.index.dtype == np.float64
    assert table.index[0] == 0.0
    assert np.allclose(np.diff(table.index), 1 / 250.0, rtol=0, atol=1e-12)
    assert list(table.columns) == MEASURED + [f"m{i}" for i in range(1, 7)]
    assert truth.index.equals(table.index)
    assert {"true_p", "true_z", "true_alt", "true_w6", "true_T1", "true_ge3"} <= set(truth)
    assert table["yaw"].between(-math.pi, math.pi, inclusive="right").all()
    assert table[["u_roll", "u_pitch", "u_yaw"]].abs().max().max() <= 1.0
    assert table["u_thrust"].between(0, 1).all()
    motors = table[[f"m{i}" for i in range(1, 7)]]
    assert ((motors >= 0) & (motors <= 1)).all().all()
    assert table["az"].mean() == pytest.approx(-9.81, abs=0.1)
    attrs = table.attrs
    assert attrs["source"] == "etsid.sim" and attrs["format"] == "sim"
    assert attrs["scenario"] == "hover-ige" and attrs["vehicle"] == "tarot680"
    assert attrs["seed"] == 1 and attrs["ground_effect"] is True
    assert attrs["noise"]["gyro_std"] > 0
    quat = truth[["true_qw", "true_qx", "true_qy", "true_qz"]].to_numpy()
    assert np.allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)


def test_hover_ige_is_low_with_significant_ground_effect(ige) -> None:
    table, truth = ige.table, ige.truth
    assert table["alt"].max() < 0.40
    assert truth["true_alt"].min() > ige.vehicle["ground"]["gear_height"]  # never touches
    ge = truth[[f"true_ge{i}" for i in range(1, 7)]].to_numpy()
    assert ge.mean() > 1.10  # >10 % more thrust at the same rotor speed
    # the altitude loop has taken the extra thrust off the collective
    assert table["u_thrust"].mean() < table.attrs["hover_command"] - 0.03
    # excitation makes the rates rich: well above the gyro noise floor, broadband
    sigma = table.attrs["noise"]["gyro_std"]
    for axis in "pqr":
        assert truth[f"true_{axis}"].std() > 5 * sigma
    spec = np.abs(np.fft.rfft(table["u_roll"].to_numpy())) ** 2
    freq = np.fft.rfftfreq(len(table), 1 / 250.0)
    assert spec[(freq > 2.0) & (freq < 8.0)].sum() > 0.02 * spec[freq < 2.0].sum()


def test_measured_noise_matches_declared_levels(ige) -> None:
    table, truth = ige.table, ige.truth
    noise = ige.table.attrs["noise"]
    for i, axis in enumerate("pqr"):
        err = table[axis] - truth[f"true_{axis}"]
        assert err.mean() == pytest.approx(noise["gyro_bias"][i], abs=0.002)
        assert err.std() == pytest.approx(noise["gyro_std"], rel=0.05)
    assert (table["az"] - truth["true_az"]).std() == pytest.approx(noise["accel_std"], rel=0.05)


def test_same_seed_is_bit_identical_and_seed_matters() -> None:
    a = simulate("hover-ige", duration=4.0, seed=7)
    b = simulate("hover-ige", duration=4.0, seed=7)
    c = simulate("hover-ige", duration=4.0, seed=8)
    assert np.array_equal(a.table.to_numpy(), b.table.to_numpy())
    assert np.array_equal(a.truth.to_numpy(), b.truth.to_numpy())
    assert a.table.index.equals(b.table.index)
    assert not np.array_equal(a.table.to_numpy(), c.table.to_numpy())


def test_fixed_command_hover_sits_higher_with_ground_effect() -> None:
    veh = load_vehicle("tarot680")
    height = 0.35
    throttle = hover_trim(veh, height).command  # trimmed for 0.35 m in ground effect
    kw = {"duration": 12.0, "altitude": height, "alt_hold": False, "throttle": throttle,
          "excitation": "none"}
    on = simulate("hover-ige", ground_effect=True, **kw).truth["true_alt"]
    off = simulate("hover-ige", ground_effect=False, **kw).truth["true_alt"]
    assert on.iloc[-500:].mean() == pytest.approx(height, abs=0.03)  # stable IGE equilibrium
    assert off.iloc[-500:].mean() < veh["ground"]["gear_height"] + 0.01  # sinks onto its gear
    assert on.iloc[-1] > off.iloc[-1] + 0.1


@pytest.fixture(scope="module")
def steps():
    return simulate("steps", seed=0)


def _step_metrics(t: np.ndarray, y: np.ndarray, target: float, t0: float, hold: float
                  ) -> tuple[float, float, float]:
    """Overshoot fraction, 90 % rise time (s), final error fraction over the last 0.5 s."""
    win = (t >= t0) & (t < t0 + hold)
    ys, ts = y[win], t[win] - t0
    overshoot = max(0.0, (np.max(ys * np.sign(target)) - abs(target)) / abs(target))
    rise = ts[np.argmax(ys * np.sign(target) >= 0.9 * abs(target))]
    final = abs(np.mean(ys[ts > hold - 0.5]) - target) / abs(target)
    return overshoot, rise, final


def test_attitude_step_responses_settle(steps) -> None:
    table, truth = steps.table, steps.truth
    t = table.index.to_numpy()
    ctrl = steps.vehicle["controller"]
    tilt = math.radians(ctrl["max_tilt_deg"]) * 0.4
    settle = steps.params["settle"]
    for k, axis in enumerate(["roll", "pitch"]):
        over, rise, final = _step_metrics(t, truth[f"true_{axis}"].to_numpy(), tilt,
                                          settle + 4.0 * k, 2.0)
        assert over < 0.2, axis
        assert rise < 0.8, axis
        assert final < 0.05, axis
    yaw_rate = math.radians(ctrl["max_yaw_rate_deg"]) * 0.4
    over, rise, final = _step_metrics(t, truth["true_r"].to_numpy(), yaw_rate, settle + 8.0, 2.0)
    assert over < 0.25 and rise < 1.0 and final < 0.05


def test_yaw_command_turns_right_through_rotor_torque(steps) -> None:
    """u_yaw > 0 gives r > 0 (nose right) by speeding up the counter-clockwise rotors,
    whose drag torque on the body points along +z (down) in FRD."""
    table, truth = steps.table, steps.truth
    veh = steps.vehicle
    t = table.index.to_numpy()
    t0 = steps.params["settle"] + 8.0
    win = (t > t0 + 0.5) & (t < t0 + 2.0)
    assert (table["u_yaw"][win] > 0).all()
    assert truth["true_r"][win].mean() > 0.3
    ccw = [i + 1 for i, s in enumerate(veh.spin) if s > 0]
    cw = [i + 1 for i, s in enumerate(veh.spin) if s < 0]
    early = (t > t0) & (t < t0 + 0.3)
    w_ccw = truth[[f"true_w{i}" for i in ccw]][early].mean().mean()
    w_cw = truth[[f"true_w{i}" for i in cw]][early].mean().mean()
    assert w_ccw > w_cw
    q_net = sum(veh.spin[i] * truth[f"true_Q{i + 1}"][early].mean() for i in range(veh.n_rotors))
    assert q_net > 0


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_scenario_flies_quad_and_hexa(name: str) -> None:
    for vehicle, n_motors in (("quad250", 4), ("tarot680", 6)):
        flight = simulate(name, vehicle=vehicle, duration=8.0, rate_hz=200.0)
        table = flight.table
        assert len(table) == 1600
        assert [c for c in table if c.startswith("m")] == [f"m{i}" for i in range(1, n_motors + 1)]
        assert np.isfinite(table.to_numpy()).all()
        assert np.isfinite(flight.truth.to_numpy()).all()
        assert flight.truth["true_alt"].min() > 0.1, (name, vehicle)
        assert flight.truth[["true_roll", "true_pitch"]].abs().max().max() < math.radians(35)


def test_forward_flight_reaches_speed_and_sine_altitude_tracks() -> None:
    ff = simulate("forward-flight", duration=30.0).truth
    speed = np.hypot(ff["true_vx"], ff["true_vy"])
    assert speed.iloc[-1000:].mean() == pytest.approx(6.0, abs=0.6)
    sa = simulate("sine-altitude", duration=30.0).truth
    late = sa.index > 15.0
    err = sa["true_alt"][late] - sa["true_alt_sp"][late]
    assert np.sqrt(np.mean(err**2)) < 0.25
    assert np.ptp(sa["true_alt"][late]) > 1.5
