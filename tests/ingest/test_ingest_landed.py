"""The ``landed`` column from ArduPilot and MAVLink/MAVROS sources: tlog (pymavlink-written
HEARTBEAT armed flag and EXTENDED_SYS_STATE), DataFlash (byte-built EV and ARM), ROS 2 bag
(rosbags-written mavros State and ExtendedState), and the real SITL quadplane tlog."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from etsid.ident.flight import LAND_MARGIN_S, is_armed_state, select_flight
from etsid.ingest import read_log
from etsid.ingest.base import Override, ReadOptions
from etsid.rosmsgs import typestore
from etsid.sim.writers.rosbag import instantiate

DATA = Path(__file__).parents[1] / "data"
START = 1.7e9
ARMED = common.MAV_MODE_FLAG_SAFETY_ARMED | common.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


def _phase(t: float) -> tuple[bool, int]:
    """(armed, landed_state) of a flight: armed at 2 s, airborne 4–14 s, disarmed at 16 s."""
    armed = 2.0 <= t < 16.0
    if not armed or t < 4.0 or t >= 14.0:
        return armed, common.MAV_LANDED_STATE_ON_GROUND
    return armed, common.MAV_LANDED_STATE_IN_AIR


def write_landed_tlog(path: Path, extended: bool, duration: float = 20.0) -> Path:
    """ATTITUDE at 50 Hz (p wobbling), HEARTBEAT and EXTENDED_SYS_STATE at 5 Hz."""
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for k in range(int(duration * 50)):
        t = k / 50.0
        frames = [mav.attitude_encode(int(1e3 * (t + 30.0)), 0.0, 0.0, 0.0,
                                      0.2 * np.sin(3 * t), 0.0, 0.0)]
        if k % 10 == 0:
            armed, state = _phase(t)
            frames.append(mav.heartbeat_encode(2, 3, ARMED if armed else 81 & ~128, 0, 4))
            if extended:
                frames.append(mav.extended_sys_state_encode(0, state))
        for msg in frames:
            out += struct.pack(">Q", int((START + t + 0.003) * 1e6)) + msg.pack(mav)
    path.write_bytes(bytes(out))
    return path


def _between(table, t0: float, t1: float) -> np.ndarray:
    tt = table.index.to_numpy()
    return table["landed"].to_numpy()[(tt > t0) & (tt < t1)]


def test_tlog_extended_sys_state_is_the_land_detector(tmp_path: Path) -> None:
    table = read_log(write_landed_tlog(tmp_path / "ext.tlog", extended=True))
    assert table.attrs["mapping"]["landed"] == "EXTENDED_SYS_STATE.landed_state"
    assert (_between(table, 0.3, 3.9) == 1).all()  # armed but on the ground
    assert (_between(table, 4.3, 13.9) == 0).all()
    assert (_between(table, 14.3, 19.8) == 1).all()
    sel = select_flight(table)
    # no touch-down stages in MAVLink: the documented margin is cut at take-off and landing
    assert sel.method == f"land detector, {LAND_MARGIN_S:g} s margins"
    assert sel.windows[0][0] == pytest.approx(4.0 + LAND_MARGIN_S, abs=0.25)
    assert sel.windows[0][1] == pytest.approx(14.0 - LAND_MARGIN_S, abs=0.25)


def test_tlog_heartbeat_armed_flag_is_an_armed_state(tmp_path: Path) -> None:
    table = read_log(write_landed_tlog(tmp_path / "hb.tlog", extended=False))
    assert table.attrs["mapping"]["landed"] == "HEARTBEAT.base_mode"
    assert is_armed_state(table)
    assert (_between(table, 0.3, 1.9) == 1).all()
    assert (_between(table, 2.3, 15.9) == 0).all()
    assert (_between(table, 16.3, 19.8) == 1).all()
    sel = select_flight(table)  # no thrust, no altitude: armed rows only
    assert sel.method.startswith("armed state")
    assert sel.windows[0][0] == pytest.approx(2.0, abs=0.25)
    assert sel.windows[0][1] == pytest.approx(16.0, abs=0.25)


# --- DataFlash, byte by byte -----------------------------------------------------------

HEAD = b"\xa3\x95"


def _fmt(mtype: int, name: str, fmt: str, columns: str) -> bytes:
    length = 3 + struct.calcsize("<" + fmt)
    return HEAD + b"\x80" + struct.pack("<BB4s16s64s", mtype, length, name.encode(),
                                        fmt.encode(), columns.encode())


def _rec(mtype: int, fmt: str, *values: float) -> bytes:
    return HEAD + bytes([mtype]) + struct.pack("<" + fmt, *values)


def write_landed_bin(path: Path, events: list[tuple[float, int]],
                     arm: list[tuple[float, int]]) -> Path:
    """IMU at 100 Hz for 20 s, EV events (s, id) and ARM records (s, ArmState)."""
    out = bytearray(_fmt(130, "IMU", "Qffffff", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ"))
    out += _fmt(131, "EV", "QB", "TimeUS,Id")
    out += _fmt(132, "ARM", "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method")
    items = [(k / 100.0, _rec(130, "Qffffff", int(1e6 * (5 + k / 100.0)),
                              0.1 * np.sin(k / 10), 0, 0, 0, 0, -9.8)) for k in range(2000)]
    items += [(t, _rec(131, "QB", int(1e6 * (5 + t)), i)) for t, i in events]
    items += [(t, _rec(132, "QBIBB", int(1e6 * (5 + t)), s, 0, 0, 0)) for t, s in arm]
    for _, rec in sorted(items, key=lambda x: x[0]):
        out += rec
    path.write_bytes(bytes(out))
    return path


def test_dataflash_land_complete_events(tmp_path: Path) -> None:
    # ARMED 2 s, NOT_LANDED 4 s, LAND_COMPLETE 14 s, DISARMED 16 s (ArduPilot LogEvent ids)
    path = write_landed_bin(tmp_path / "ev.bin", [(2.0, 10), (4.0, 28), (14.0, 18), (16.0, 11)],
                            [(2.0, 1), (16.0, 0)])
    table = read_log(path)
    assert table.attrs["mapping"]["landed"] == "EV.Id"
    assert not is_armed_state(table)
    assert np.isnan(_between(table, 0.0, 1.9)).all()  # before the first event: unknown
    assert (_between(table, 2.05, 3.95) == 1).all()
    assert (_between(table, 4.05, 13.95) == 0).all()
    assert (_between(table, 14.05, 19.9) == 1).all()  # held to the end of the log
    sel = select_flight(table)
    assert sel.method == f"land detector, {LAND_MARGIN_S:g} s margins"
    assert sel.windows[0] == pytest.approx([4.0 + LAND_MARGIN_S, 13.99 - LAND_MARGIN_S],
                                           abs=0.05)


def test_dataflash_armed_events_and_arm_messages(tmp_path: Path) -> None:
    only_armed = write_landed_bin(tmp_path / "arm.bin", [(2.0, 10), (16.0, 11)], [])
    table = read_log(only_armed)
    assert table.attrs["mapping"]["landed"] == "EV.Id (armed)"
    assert is_armed_state(table)
    assert (_between(table, 2.05, 15.95) == 0).all()
    assert (_between(table, 16.05, 19.9) == 1).all()
    arm_only = write_landed_bin(tmp_path / "armmsg.bin", [], [(3.0, 1), (12.0, 0)])
    table = read_log(arm_only)
    assert table.attrs["mapping"]["landed"] == "ARM.ArmState"
    assert (_between(table, 3.05, 11.95) == 0).all()
    assert (_between(table, 12.05, 19.9) == 1).all()


# --- MAVROS, ROS 2 bag written with rosbags -----------------------------------------------

def write_landed_bag(path: Path) -> Path:
    from rosbags.rosbag2 import Writer

    store = typestore()
    t0 = 1_700_000_000_000_000_000
    with Writer(path, version=9) as writer:
        imu = writer.add_connection("/mavros/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        ext = writer.add_connection("/mavros/extended_state", "mavros_msgs/msg/ExtendedState",
                                    typestore=store)
        st = writer.add_connection("/mavros/state", "mavros_msgs/msg/State", typestore=store)
        for k in range(1000):
            ns = t0 + k * 20_000_000
            t = k / 50.0
            head = {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}, "frame_id": ""}
            msg = instantiate(store, "sensor_msgs/msg/Imu", {
                "header": head, "orientation": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0},
                "angular_velocity": {"x": 0.2 * np.sin(3 * t), "y": 0.0, "z": 0.0}})
            writer.write(imu, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
            if k % 10 == 0:
                armed, state = _phase(t)
                msg = instantiate(store, "mavros_msgs/msg/ExtendedState",
                                  {"header": head, "landed_state": state})
                writer.write(ext, ns, store.serialize_cdr(msg, "mavros_msgs/msg/ExtendedState"))
                msg = instantiate(store, "mavros_msgs/msg/State", {
                    "header": head, "connected": True, "armed": armed, "mode": "STABILIZED"})
                writer.write(st, ns, store.serialize_cdr(msg, "mavros_msgs/msg/State"))
    return path


def test_mavros_extended_state_wins_over_armed(tmp_path: Path) -> None:
    bag = write_landed_bag(tmp_path / "landed_bag")
    table = read_log(bag)
    assert table.attrs["mapping"]["landed"] == "/mavros/extended_state.landed_state"
    assert (_between(table, 0.3, 3.9) == 1).all()
    assert (_between(table, 4.3, 13.9) == 0).all()
    assert (_between(table, 14.3, 19.8) == 1).all()
    assert select_flight(table).method == f"land detector, {LAND_MARGIN_S:g} s margins"


def test_mavros_state_armed(tmp_path: Path) -> None:
    bag = write_landed_bag(tmp_path / "armed_bag")
    table = read_log(bag, ReadOptions(overrides=[Override("landed", "/mavros/state")]))
    assert table.attrs["mapping"]["landed"] == "/mavros/state.armed"
    assert is_armed_state(table)
    assert (_between(table, 2.3, 15.9) == 0).all()
    assert (_between(table, 16.3, 19.8) == 1).all()


# --- the real ArduPilot SITL quadplane tlog ---------------------------------------------

def test_real_sitl_quadplane_landed() -> None:
    table = read_log(DATA / "ardupilot_sitl_quadplane.tlog")
    assert table.attrs["mapping"]["landed"] == "HEARTBEAT.base_mode"
    tt = table.index.to_numpy()
    landed = table["landed"].to_numpy()
    armed = tt[landed == 0]
    # armed from the first heartbeat (~0.9 s) until the disarm after the landing (~177 s)
    assert armed[0] < 2.0 and 170.0 < armed[-1] < 180.0
    assert (landed[tt > 180.0] == 1).all()
    sel = select_flight(table)
    assert sel.method == "armed state + altitude above arming level"
    (t0, t1), = sel.windows
    alt = table["alt"].to_numpy()
    # take-off: the climb starts after 20 s of armed ground time at 6.75 m
    assert 22.0 < t0 < 30.0 and 160.0 < t1 < 177.0
    assert np.nanmin(alt[(tt > t0 + 5) & (tt < t1 - 5)]) > alt[0] + 3.0
