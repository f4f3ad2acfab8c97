"""What logs say about the aircraft (vehicle, autopilot, firmware, board), read from the
real logs and from tlogs written with pymavlink."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega

from etsid.ingest import read_log, read_raw
from etsid.ingest.vehicle import banner_facts, mav_type_name, px4_version
from etsid.sim.writers.tlog import write_tlog
from etsid.table import load_table, save_table

DATA = Path(__file__).parents[1] / "data"
FACTS = ("vehicle", "autopilot", "firmware", "hardware")


def facts_of(mapping: dict) -> dict:
    return {k: mapping[k] for k in FACTS if k in mapping}


@pytest.mark.parametrize(("name", "expected"), [
    # ArduPilot SITL QuadPlane: HEARTBEAT type 1 (fixed wing), autopilot 3, banner STATUSTEXT
    ("ardupilot_sitl_quadplane.tlog", {"vehicle": "fixed wing", "autopilot": "ArduPilot",
                                       "firmware": "ArduPlane V3.10.0-dev (f2b4e06a)"}),
    # ArduPlane DataFlash: banner MSG and the board line "PX4v4 00360029 30365103 31323731"
    ("arduplane_truncated.BIN", {"vehicle": "fixed wing", "autopilot": "ArduPilot",
                                 "firmware": "ArduPlane V3.8.2-dev (8178ab40)",
                                 "hardware": "PX4v4"}),
    # PX4 ULogs: sys_name, ver_sw_release (0x010B0200 = v1.11.2 dev build), ver_sw, ver_hw,
    # parameter MAV_TYPE (22: a VTOL, 2: quadrotor)
    ("px4_cubeorange_real.ulg", {"vehicle": "VTOL", "autopilot": "PX4",
                                 "firmware": "v1.11.2-dev (8583f1da)",
                                 "hardware": "CUBEPILOT_CUBEORANGE"}),
    ("px4_quad_mission_lowrate_real.ulg", {"vehicle": "quadrotor", "autopilot": "PX4",
                                           "firmware": "v1.9.0-beta (654ed4b9)",
                                           "hardware": "PX4_FMU_V3"}),
    ("px4_sitl_tagged.ulg", {"vehicle": "quadrotor", "autopilot": "PX4",
                             "firmware": "v1.13.0-dev (cea3da71)", "hardware": "PX4_SITL"}),
])
def test_real_logs_name_their_aircraft(name: str, expected: dict) -> None:
    assert facts_of(read_raw(DATA / name).extra) == expected


def test_facts_reach_the_table_attrs_and_survive_saving(tmp_path: Path) -> None:
    table = read_log(DATA / "px4_sitl_tagged.ulg")
    assert facts_of(table.attrs) == {"vehicle": "quadrotor", "autopilot": "PX4",
                                     "firmware": "v1.13.0-dev (cea3da71)",
                                     "hardware": "PX4_SITL"}
    save_table(table, tmp_path / "t.parquet")
    assert facts_of(load_table(tmp_path / "t.parquet").attrs) == facts_of(table.attrs)


def test_a_bag_without_such_topics_names_nothing() -> None:
    assert facts_of(read_raw(DATA / "ros" / "xsens_imu_real.bag").extra) == {}


def _frames(build: list, start: float, sysid: int = 1) -> bytes:
    mav = ardupilotmega.MAVLink(None, srcSystem=sysid, srcComponent=1)
    out = bytearray()
    for k, encode in enumerate(build):
        out += struct.pack(">Q", int((start + 0.01 * k) * 1e6))
        out += encode(mav).pack(mav)
    return bytes(out)


def test_written_tlog_banner_and_version_fallback(tmp_path: Path) -> None:
    import numpy as np
    import pandas as pd

    t = np.arange(0, 4, 0.01)
    table = pd.DataFrame({"p": np.sin(t), "q": np.cos(t), "r": 0 * t, "roll": 0 * t,
                          "pitch": 0 * t, "yaw": 0 * t}, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = 1.7e9
    log = write_tlog(table, tmp_path / "a.tlog", sysid=1)  # HEARTBEAT: hexarotor, ArduPilot
    assert facts_of(read_raw(log).extra) == {"vehicle": "hexarotor", "autopilot": "ArduPilot"}
    banner = _frames([lambda m: m.statustext_encode(6, b"ArduCopter V4.5.1 (1a2b3c4d)")],
                     1.7e9 + 1)
    other = _frames([lambda m: m.statustext_encode(6, b"ArduPlane V9.9.9 (ffffffff)")],
                    1.7e9 + 1, sysid=7)  # another system's banner is not this vehicle's
    (tmp_path / "b.tlog").write_bytes(log.read_bytes() + other + banner)
    assert facts_of(read_raw(tmp_path / "b.tlog").extra) == {
        "vehicle": "hexarotor", "autopilot": "ArduPilot",
        "firmware": "ArduCopter V4.5.1 (1a2b3c4d)"}
    version = _frames([lambda m: m.autopilot_version_encode(
        capabilities=0, flight_sw_version=(4 << 24) | (2 << 16) | (3 << 8) | 255,
        middleware_sw_version=0, os_sw_version=0, board_version=0,
        flight_custom_version=[0] * 8, middleware_custom_version=[0] * 8,
        os_custom_version=[0] * 8, vendor_id=0, product_id=0, uid=0, uid2=[0] * 18)], 1.7e9 + 2)
    (tmp_path / "c.tlog").write_bytes(log.read_bytes() + version)
    assert read_raw(tmp_path / "c.tlog").extra["firmware"] == "v4.2.3"


def test_decoders() -> None:
    assert px4_version(0x01080200 | 0xFF) == "v1.8.2"
    assert px4_version(0x010E00C0) == "v1.14.0-rc"
    assert px4_version(0) is None
    assert mav_type_name(0) is None and mav_type_name(2) == "quadrotor"
    assert banner_facts("EKF2 IMU0 switching to compass 1") == {}
    assert banner_facts("ArduSub V4.1.0 (deadbeef)")["vehicle"] == "submarine"
