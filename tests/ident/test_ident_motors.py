"""--inputs motors: motor outputs as the model's inputs, the commands they carry when the
motor layout is known, and their place in the auto order."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify, predict
from etsid.ident.inputs import choose_inputs, load_for_ident
from etsid.ident.motors import add_motor_commands, layout_of
from etsid.ident.rundir import write_run
from etsid.ingest.base import Signal
from etsid.sim import simulate

CUBE = Path(__file__).parents[1] / "data" / "px4_cubeorange_real.ulg"


@pytest.fixture(scope="module")
def sim_flight():
    return simulate("hover-oge", duration=30.0, seed=3)


def test_motor_commands_invert_the_simulators_own_mixer(sim_flight) -> None:
    # the simulator's vehicle mixes [thrust, roll, pitch, yaw] into its six motors with its
    # own matrix; the layout it records must give the same commands back
    veh = sim_flight.vehicle
    rng = np.random.default_rng(1)
    commands = np.column_stack([rng.uniform(0.3, 0.6, 50), rng.normal(0, 0.1, (50, 3))])
    motors = commands @ veh.mixer.T
    table = pd.DataFrame(motors, columns=[f"m{i + 1}" for i in range(veh.n_rotors)])
    table.attrs["motor_layout"] = sim_flight.table.attrs["motor_layout"]
    out = add_motor_commands(table)
    for j, name in enumerate(("mot_thrust", "mot_roll", "mot_pitch", "mot_yaw")):
        np.testing.assert_allclose(out[name], commands[:, j], atol=1e-12)


def test_layout_must_match_the_motor_columns(sim_flight) -> None:
    table = sim_flight.table
    assert layout_of(table) is not None
    short = table.drop(columns=["m6"])
    assert layout_of(short) is None and "mot_roll" not in add_motor_commands(short)


def test_motor_inputs_fit_a_simulated_flight(sim_flight, tmp_path: Path) -> None:
    table = sim_flight.table
    sticks = identify(table, IdentConfig())
    motors = identify(table, IdentConfig(inputs="motors"))
    assert motors.config["model"]["inputs"]["family"] == "motor commands"
    raw_table = table.copy()
    raw_table.attrs = {k: v for k, v in table.attrs.items() if k != "motor_layout"}
    raw = identify(raw_table, IdentConfig(inputs="motors"))
    assert raw.config["model"]["inputs"]["columns"] == [f"m{i}" for i in range(1, 7)]
    run_dir = tmp_path / "run"
    write_run(motors, run_dir)
    again = predict(table, run_dir, sim_from=motors.metrics["validation"]["t_start"])
    assert (again.metrics["outputs"]["p"]["validation"]["one_step"]
            == motors.metrics["outputs"]["p"]["validation"]["one_step"])
    with pytest.raises(IdentError, match="no layout matching its motor columns"):
        predict(raw_table, run_dir)
    for y in ("p", "q", "r"):
        m = motors.metrics["outputs"][y]["validation"]
        s = sticks.metrics["outputs"][y]["validation"]
        persist = motors.metrics["outputs"][y]["persistence"]["validation"]["rmse"]
        # the motors carry the controller's action: one step as good as the sticks' model
        assert m["one_step"]["rmse"] < 1.1 * s["one_step"]["rmse"]
        assert m["one_step"]["rmse"] < 0.5 * persist
        assert m["free_run"]["diverged"] is False and m["free_run"]["fit"] > 20.0
        # a linear function of the same outputs: the raw motors give the same one-step fit
        r = raw.metrics["outputs"][y]["validation"]["one_step"]["rmse"]
        assert r == pytest.approx(m["one_step"]["rmse"], rel=0.05)


def _motor_signals(n: int = 4) -> list[Signal]:
    t = np.arange(0.0, 10.0, 1 / 50)
    out = [Signal(c, t, np.sin(t), f"vehicle_angular_velocity.xyz[{i}]", 0)
           for i, c in enumerate("pqr")]
    out += [Signal(f"m{i + 1}", t, 0.5 + 0.01 * np.sin(t + i), f"actuator_outputs.output[{i}]",
                   1) for i in range(n)]
    return out


def test_auto_takes_motors_only_when_nothing_else_exists() -> None:
    choice = choose_inputs(_motor_signals())
    assert choice.kind == "motors" and choice.columns == ["m1", "m2", "m3", "m4"]
    assert "4 motor outputs at 50 Hz" in choice.reason
    t = np.arange(0.0, 10.0, 1 / 50)
    with_sp = _motor_signals() + [Signal(f"sp_{c}", t, np.cos(t), f"vehicle_rates_setpoint.{a}",
                                         0) for c, a in zip("pqr", ("roll", "pitch", "yaw"),
                                                             strict=True)]
    assert choose_inputs(with_sp).kind == "setpoints"
    assert choose_inputs(with_sp, "motors").kind == "motors"
    with pytest.raises(IdentError, match=r"--inputs motors: the log has no at least 4 motor"):
        choose_inputs(_motor_signals(3), "motors")
    with pytest.raises(IdentError, match="nor 4 motor outputs"):
        choose_inputs(_motor_signals(3))


def test_real_px4_log_motor_outputs() -> None:
    # the real CubeOrange log: actuator_outputs at 10 Hz, PWM → 0…1
    table = load_for_ident(CUBE, inputs="motors")
    selection = table.attrs["input_selection"]
    assert selection["kind"] == "motors"
    assert selection["sources"]["m1"] == "actuator_outputs.output[0]"
    run = identify(table, IdentConfig(inputs="motors", segments="all"))
    inputs = run.config["model"]["inputs"]
    assert inputs["family"] == "motor outputs"  # PX4 1.11: no CA_ROTOR layout parameters
    assert inputs["columns"][:4] == ["m1", "m2", "m3", "m4"]
    assert table[inputs["columns"]].dropna().to_numpy().min() >= 0.0


def _ulog_message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def _param(ctype: str, name: str, value: float) -> bytes:
    key = f"{ctype} {name}".encode()
    data = struct.pack("<f", value) if ctype == "float" else struct.pack("<i", int(value))
    return _ulog_message(b"P", bytes([len(key)]) + key + data)


# PX4's Quad X geometry (CA_ROTOR* defaults of the generic quadcopter): front-right CCW,
# rear-left CCW, front-left CW, rear-right CW
QUAD_X = [(0.15, 0.15, 0.05), (-0.15, -0.15, 0.05), (0.15, -0.15, -0.05), (-0.15, 0.15, -0.05)]


def write_ca_ulog(path: Path, roll_cmd: np.ndarray) -> Path:
    """A ULog (byte by byte) with CA_ROTOR* parameters, actuator_motors (PX4 ≥ 1.13 format)
    driven by a known roll command through the Quad X mixer, and body rates, at 100 Hz."""
    topics = [
        ("vehicle_angular_velocity", "uint64_t timestamp;uint64_t timestamp_sample;"
                                     "float[3] xyz;"),
        ("actuator_motors", "uint64_t timestamp;uint64_t timestamp_sample;float[12] control;"
                            "uint16_t reversible_flags;"),
    ]
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += _ulog_message(b"B", bytes(16) + bytes(24))
    for name, fields in topics:
        out += _ulog_message(b"F", f"{name}:{fields}".encode())
    out += _param("int32_t", "CA_ROTOR_COUNT", 4)
    for i, (x, y, km) in enumerate(QUAD_X):
        out += _param("float", f"CA_ROTOR{i}_PX", x) + _param("float", f"CA_ROTOR{i}_PY", y)
        out += _param("float", f"CA_ROTOR{i}_KM", km)
    for msg_id, (name, _) in enumerate(topics):
        out += _ulog_message(b"A", struct.pack("<BH", 0, msg_id) + name.encode())
    roll_column = np.array([-y for _, y, _ in QUAD_X]) / 0.15
    for k, cmd in enumerate(roll_cmd):
        us = 1_000_000 + 10_000 * k
        motors = [0.5 + cmd * c for c in roll_column] + [float("nan")] * 8
        out += _ulog_message(b"D", struct.pack("<HQQ3f", 0, us, us, 0.1 * cmd, 0.0, 0.0))
        out += _ulog_message(b"D", struct.pack("<HQQ12fH", 1, us, us, *motors, 0))
    path.write_bytes(bytes(out))
    return path


def test_px4_control_allocation_layout(tmp_path: Path) -> None:
    roll = 0.1 * np.sin(np.arange(500) * 0.05)
    table = load_for_ident(write_ca_ulog(tmp_path / "ca.ulg", roll), inputs="motors")
    layout = table.attrs["motor_layout"]
    np.testing.assert_allclose(layout["x"], [0.15, -0.15, 0.15, -0.15], rtol=1e-6)
    np.testing.assert_allclose(layout["y"], [0.15, -0.15, -0.15, 0.15], rtol=1e-6)
    assert layout["spin"] == [1.0, 1.0, -1.0, -1.0]
    out = add_motor_commands(table)
    # motor outputs are held: each row carries the command of its sample or the one before
    got = out["mot_roll"].to_numpy()
    err = np.minimum(np.abs(got - roll[:got.size]), np.abs(got - np.r_[roll[0], roll[:-1]][
        :got.size]))
    assert got.size >= 495 and err.max() < 1e-6
    np.testing.assert_allclose(out[["mot_pitch", "mot_yaw"]], 0.0, atol=1e-6)
    np.testing.assert_allclose(out["mot_thrust"], 0.5, atol=1e-6)
