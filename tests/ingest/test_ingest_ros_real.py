"""Real-world ROS bags and MCAP files (tests/data/ros, credits in tests/data/README.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import inspect_log, read_log, read_raw
from etsid.ingest.detect import open_reader
from etsid.ingest.mavlink import tlog as tlog_reader

DATA = Path(__file__).parents[1] / "data" / "ros"
SITL = DATA / "mavros_from_sitl"
TLOG = Path(__file__).parents[1] / "data" / "ardupilot_sitl_quadplane.tlog"

ROS_FILES = {
    "ros1": SITL / "mavros_vtol.bag",
    "ros2-db3": SITL / "mavros_vtol_ros2_db3",
    "ros2-db3-file": SITL / "mavros_vtol_ros2_db3" / "mavros_vtol_ros2_db3.db3",
    "ros2-mcap": SITL / "mavros_vtol_ros2_mcap",
    "ros2-mcap-file": SITL / "mavros_vtol_ros2_mcap" / "mavros_vtol_ros2_mcap.mcap",
    "mcap-ros1": SITL / "mavros_vtol_ros1.mcap",
}
FLIGHT = ["p", "q", "r", "roll", "pitch", "yaw", "u_roll", "u_pitch", "u_yaw", "u_thrust"]


@pytest.fixture(scope="module")
def sitl_tables() -> dict[str, pd.DataFrame]:
    tables = {name: read_log(path) for name, path in ROS_FILES.items()}
    tables["mcap-json"] = read_log(SITL / "vtol_json.mcap")
    return tables


def _at(table: pd.DataFrame, column: str, t_abs: np.ndarray) -> np.ndarray:
    t = table.index.to_numpy() + table.attrs["start_time"]
    values = table[column].to_numpy()
    if column == "yaw":
        values = np.unwrap(values)
    return np.interp(t_abs, t, values)


def test_mavros_files_agree_exactly(sitl_tables: dict[str, pd.DataFrame]) -> None:
    ref = sitl_tables["ros1"]
    assert ref.shape == (855, 20)
    for name in ROS_FILES:
        pd.testing.assert_frame_equal(sitl_tables[name], ref,
                                      check_exact=False, atol=1e-9, obj=name)


def test_json_mcap_mavlink_messages_agree(sitl_tables: dict[str, pd.DataFrame]) -> None:
    ref, js = sitl_tables["ros1"], sitl_tables["mcap-json"]
    assert js.attrs["mapping"]["p"] == "/mavlink/attitude.rollspeed"
    assert len(js) == len(ref)
    for column in FLIGHT:
        diff = js[column].to_numpy() - ref[column].to_numpy()
        if column == "yaw":
            diff = np.angle(np.exp(1j * diff))
        assert np.nanmax(np.abs(diff)) < 3e-3, column


def test_frd_ned_values_match_the_tlog(sitl_tables: dict[str, pd.DataFrame]) -> None:
    assert open_reader("tlog") is tlog_reader.read
    tlog = read_log(TLOG)
    bag = sitl_tables["ros1"]
    t_abs = bag.index.to_numpy() + bag.attrs["start_time"]
    for column in [*FLIGHT, "alt"]:
        diff = bag[column].to_numpy() - _at(tlog, column, t_abs)
        if column == "yaw":
            diff = np.angle(np.exp(1j * diff))
        # 2 ms clock offset between the two readers' time bases and a 1.4 s clock step
        assert np.nanpercentile(np.abs(diff), 95) < 0.02, column
        assert np.nanmedian(np.abs(diff)) < 2e-3, column
    # the yaw sign: FLU/ENU → FRD/NED must not mirror the heading
    assert np.corrcoef(np.unwrap(bag["yaw"]), _at(tlog, "yaw", t_abs))[0, 1] > 0.99


def test_mavros_inspect(sitl_tables: dict[str, pd.DataFrame]) -> None:
    info = inspect_log(SITL / "mavros_vtol.bag")
    channels = {c["name"]: c for c in info["channels"]}
    assert channels["/mavros/imu/data"]["count"] == 888
    assert channels["/mavros/imu/data"]["columns"] == ["p", "q", "r", "roll", "pitch", "yaw"]
    assert "not converted" in channels["/mavros/vfr_hud"]["note"]
    assert info["mapping"]["roll"] == "/mavros/imu/data.orientation"
    assert info["extra"]["storage"] == "rosbag1"
    repaired = sitl_tables["ros1"].attrs["repaired"]
    assert {"reason": "out-of-order timestamp, re-sorted", "count": 8,
            "signal": "/mavros/imu/data.angular_velocity.x"} in repaired


def test_xsens_custom_types_imu_only() -> None:
    table = read_log(DATA / "xsens_imu_real.bag")
    assert list(table.columns) == ["p", "q", "r", "roll", "pitch", "yaw", "ax", "ay", "az",
                                   "segment"]
    assert len(table) == 356
    # a resting IMU: specific force ≈ −g along FRD z
    assert table["az"].mean() == pytest.approx(-9.8, abs=0.3)
    raw = read_raw(DATA / "xsens_imu_real.bag")
    channels = {c.name: c for c in raw.channels}
    assert channels["/temperature"].type == "xsens_mtig/msg/Thermistor"
    assert channels["/temperature"].count == 712 and channels["/temperature"].columns == []
    assert "twist frame not known" in channels["/velocity"].note


def test_old_metadata_bag_uses_shipped_definitions() -> None:
    table = read_log(DATA / "ros2_old_metadata_bag")
    assert {"p", "q", "r", "ax", "ay", "az", "roll", "vbat", "alt"} <= set(table.columns)
    assert table.attrs["mapping"]["p"] == "/imu.angular_velocity.x"
    assert len(table) == 1565
    assert {"reason": "voltage 0 or unknown", "count": 785, "signal": "/battery.voltage"} \
        in table.attrs["dropped"]


@pytest.mark.parametrize("name", ["ros2_talker_db3", "ros2_talker_mcap"])
def test_talker_bags_qos_mismatch_then_no_flight_data(name: str) -> None:
    raw = read_raw(DATA / name)
    assert any("metadata.yaml disagrees" in w and "directly" in w for w in raw.warnings)
    assert {c.name: c.count for c in raw.channels}["/topic"] == 10
    with pytest.raises(IngestError, match=rf"{name}: no usable flight data; found .*"
                                          r"/topic \(std_msgs/msg/String\)"):
        read_log(DATA / name)
    result = CliRunner().invoke(cli, ["ingest", str(DATA / name), "-o", "x.parquet"])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_topics_and_services_mcap_lists_service_events() -> None:
    raw = read_raw(DATA / "ros2_topics_and_services.mcap")
    channels = {c.name: c for c in raw.channels}
    assert channels["/add_two_ints/_service_event"].count == 6
    assert "service events" in channels["/add_two_ints/_service_event"].note
    assert channels["/parameter_events"].count == 7
    with pytest.raises(IngestError, match="no usable flight data.*_service_event"):
        read_log(DATA / "ros2_topics_and_services.mcap")


def test_directory_without_metadata_yaml(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "talker.db3").write_bytes((DATA / "ros2_talker_db3" / "talker.db3").read_bytes())
    with pytest.raises(IngestError, match="directory without metadata.yaml.*talker.db3"):
        read_log(bag)
    result = CliRunner().invoke(cli, ["inspect", str(bag)])
    assert result.exit_code == 1 and "Traceback" not in result.output
    # the storage file itself is readable
    assert read_raw(bag / "talker.db3").format == "ros2"


def test_metadata_pointing_nowhere_falls_back_to_storage(tmp_path: Path) -> None:
    bag = tmp_path / "moved"
    bag.mkdir()
    src = SITL / "mavros_vtol_ros2_db3"
    (bag / "renamed.db3").write_bytes((src / "mavros_vtol_ros2_db3.db3").read_bytes())
    (bag / "metadata.yaml").write_text((src / "metadata.yaml").read_text())
    table = read_log(bag)
    assert any("metadata.yaml unusable" in w and "renamed.db3" in w
               for w in table.attrs["warnings"])
    assert len(table) == 855
