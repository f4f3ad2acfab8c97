"""MAVROS setpoint topics fill only setpoint columns (a ROS 2 bag written with rosbags):
the commanded pose of ``setpoint_attitude/attitude`` never becomes alt/roll/pitch/yaw."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from etsid.frames import euler_to_quat
from etsid.ingest import read_log, read_raw
from etsid.rosmsgs import typestore
from etsid.sim.writers.rosbag import instantiate

T0 = 1_700_000_000_000_000_000


def _stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _quat(roll: float, pitch: float, yaw: float) -> dict:
    w, x, y, z = (float(v) for v in euler_to_quat(np.array(roll), np.array(pitch),
                                                  np.array(yaw)))
    return {"w": w, "x": x, "y": y, "z": z}


def write_bag(path: Path, n: int = 200) -> Path:
    from rosbags.rosbag2 import Writer

    store = typestore()
    # FLU/ENU: roll 0.1 rad right-wing-down (FRD +0.1), yaw ENU 0 = NED heading π/2
    measured, commanded = _quat(0.1, 0.0, 0.0), _quat(0.3, 0.0, 0.0)
    with Writer(path, version=9) as writer:
        imu = writer.add_connection("/mavros/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        sp = writer.add_connection("/mavros/setpoint_attitude/attitude",
                                   "geometry_msgs/msg/PoseStamped", typestore=store)
        for i in range(n):
            ns = T0 + i * 20_000_000
            head = {"stamp": _stamp(ns), "frame_id": "base_link"}
            msg = instantiate(store, "sensor_msgs/msg/Imu", {
                "header": head, "orientation": measured,
                "angular_velocity": {"x": 0.2, "y": 0.0, "z": 0.0}})
            writer.write(imu, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
            pose = instantiate(store, "geometry_msgs/msg/PoseStamped", {
                "header": head, "pose": {"position": {"z": 5.0}, "orientation": commanded}})
            writer.write(sp, ns, store.serialize_cdr(pose, "geometry_msgs/msg/PoseStamped"))
    return path


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(tmp_path_factory.mktemp("sp") / "setpoint_bag")


def test_setpoint_pose_is_never_a_measurement(bag: Path) -> None:
    columns = {s.column for s in read_raw(bag).signals
               if s.topic == "/mavros/setpoint_attitude/attitude"}
    assert columns == {"sp_roll", "sp_pitch", "sp_yaw"}
    table = read_log(bag)
    assert "alt" not in table.columns
    assert table.attrs["mapping"]["roll"].startswith("/mavros/imu/data")
    np.testing.assert_allclose(table["roll"], 0.1, atol=1e-6)
    np.testing.assert_allclose(table["sp_roll"].dropna(), 0.3, atol=1e-6)
    np.testing.assert_allclose(table["sp_yaw"].dropna(), np.pi / 2, atol=1e-6)
