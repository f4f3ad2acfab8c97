"""Round trips FlightTable → real ROS bag / MCAP writers → read_log, with every axis non-zero."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import ReadOptions, inspect_log, read_log
from etsid.ingest.mapping import parse_override
from etsid.sim.writers.mcapfile import write_mcap
from etsid.sim.writers.rosbag import write_ros1_bag, write_ros2_bag

START = 1.7e9


def synthetic_table(duration: float = 6.0, rate: float = 250.0) -> pd.DataFrame:
    """Smooth signals with non-zero mean on every axis, so any sign error shows."""
    t = np.arange(int(duration * rate)) / rate
    w = 2 * np.pi
    cols = {
        "p": 0.8 * np.sin(w * 0.7 * t) + 0.1, "q": -0.6 * np.sin(w * 0.5 * t + 1) + 0.05,
        "r": 0.5 * np.cos(w * 0.3 * t) - 0.07,
        "roll": 0.3 * np.sin(w * 0.2 * t) + 0.05, "pitch": -0.2 * np.sin(w * 0.15 * t) - 0.04,
        "yaw": np.angle(np.exp(1j * (1.0 + 0.5 * t))),
        "u_roll": 0.5 * np.sin(w * 0.2 * t) + 0.1, "u_pitch": -0.4 * np.sin(w * 0.25 * t) - 0.1,
        "u_yaw": 0.3 * np.cos(w * 0.1 * t) + 0.05, "u_thrust": 0.55 + 0.2 * np.sin(w * 0.1 * t),
        "sp_p": 0.5 * np.sin(w * 0.3 * t) + 0.1, "sp_q": -0.4 * np.sin(w * 0.2 * t) - 0.1,
        "sp_r": 0.3 * np.cos(w * 0.25 * t) + 0.05,
        "alt": 2.0 + np.sin(w * 0.1 * t),
        "vx": 1.5 * np.sin(w * 0.1 * t) + 0.3, "vy": -np.cos(w * 0.12 * t) - 0.2,
        "vz": 0.5 * np.sin(w * 0.2 * t) + 0.1,
        "ax": 0.8 * np.sin(w * 0.4 * t) + 0.2, "ay": -0.6 * np.cos(w * 0.3 * t) - 0.3,
        "az": -9.81 + 0.5 * np.sin(w * 0.2 * t),
        "vbat": 16.0 - 0.02 * t,
    }
    for i in range(1, 7):
        cols[f"m{i}"] = 0.5 + 0.2 * np.sin(w * 0.15 * t + i)
    table = pd.DataFrame(cols, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = START
    return table


TOL = {"p": 1e-3, "q": 1e-3, "r": 1e-3, "roll": 1e-3, "pitch": 1e-3, "yaw": 1e-3,
       "ax": 1e-3, "ay": 1e-3, "az": 1e-3, "vx": 0.02, "vy": 0.02, "vz": 0.02, "alt": 0.02,
       "vbat": 0.01, "u_roll": 0.04, "u_pitch": 0.04, "u_yaw": 0.04, "u_thrust": 0.04,
       "sp_p": 0.03, "sp_q": 0.03, "sp_r": 0.03, **{f"m{i}": 0.02 for i in range(1, 7)}}
"""Per column: interpolation / hold error at the writers' native rates plus 1 µs PWM steps."""


def compare(table: pd.DataFrame, read: pd.DataFrame) -> dict[str, float]:
    """Max abs difference per column, the source table interpolated at the read times."""
    t = read.index.to_numpy() + read.attrs["start_time"] - table.attrs["start_time"]
    errors = {}
    for column in TOL:
        ref = table[column].to_numpy()
        if column == "yaw":
            ref = np.unwrap(ref)
        diff = read[column].to_numpy() - np.interp(t, table.index.to_numpy(), ref)
        if column == "yaw":
            diff = np.angle(np.exp(1j * diff))
        errors[column] = float(np.nanmax(np.abs(diff)))
    return errors


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    return synthetic_table()


@pytest.fixture(scope="module")
def written(table: pd.DataFrame, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("ros")
    return {
        "ros1": write_ros1_bag(table, out / "flight.bag"),
        "ros2-db3": write_ros2_bag(table, out / "flight_db3", storage="sqlite3"),
        "ros2-mcap": write_ros2_bag(table, out / "flight_mcap", storage="mcap"),
        "mcap-ros2": write_mcap(table, out / "flight_ros2.mcap", encoding="ros2"),
        "mcap-ros1": write_mcap(table, out / "flight_ros1.mcap", encoding="ros1"),
        "mcap-json": write_mcap(table, out / "flight_json.mcap", encoding="json"),
    }


@pytest.mark.parametrize("fmt", ["ros1", "ros2-db3", "ros2-mcap", "mcap-ros2", "mcap-ros1",
                                 "mcap-json"])
def test_round_trip_every_column(table: pd.DataFrame, written: dict[str, Path],
                                 fmt: str) -> None:
    read = read_log(written[fmt])
    assert set(TOL) <= set(read.columns)
    assert read.attrs["start_time"] == pytest.approx(START, abs=1e-3)
    assert read.attrs["rate_hz"] == pytest.approx(100.0, rel=1e-3)
    assert read.attrs["mapping"]["p"] == "/mavros/imu/data.angular_velocity.x"
    assert read.attrs["mapping"]["u_thrust"] == "/mavros/rc/in.channels[2]"
    assert read.attrs["dropped"] == []
    errors = compare(table, read)
    bad = {c: e for c, e in errors.items() if not e <= TOL[c]}
    assert not bad, f"{fmt}: columns off beyond tolerance: {bad}"


def test_all_formats_give_the_same_table(written: dict[str, Path]) -> None:
    tables = {fmt: read_log(path) for fmt, path in written.items()}
    ref = tables.pop("ros1")
    for fmt, other in tables.items():
        assert other.shape == ref.shape, fmt
        np.testing.assert_allclose(other.to_numpy(), ref.to_numpy(), atol=1e-9, err_msg=fmt)


def test_ros2_storage_file_equals_bag_directory(written: dict[str, Path]) -> None:
    bag = written["ros2-mcap"]
    storage = next(bag.glob("*.mcap"))
    from_dir, from_file = read_log(bag), read_log(storage)
    pd.testing.assert_frame_equal(from_dir, from_file, check_exact=True)
    db3 = next(written["ros2-db3"].glob("*.db3"))
    pd.testing.assert_frame_equal(read_log(written["ros2-db3"]), read_log(db3))


def test_inspect_lists_topics_rates_and_columns(written: dict[str, Path]) -> None:
    info = inspect_log(written["ros1"])
    channels = {c["name"]: c for c in info["channels"]}
    assert channels["/mavros/imu/data"]["rate_hz"] == pytest.approx(100.0, rel=0.01)
    assert channels["/mavros/rc/in"]["rate_hz"] == pytest.approx(25.0, rel=0.01)
    assert channels["/mavros/battery"]["columns"] == ["vbat"]
    assert channels["/mavros/imu/data"]["columns"] == ["p", "q", "r", "roll", "pitch", "yaw",
                                                       "ax", "ay", "az"]
    assert info["format"] == "ros1" and info["duration_s"] == pytest.approx(6.0, abs=0.1)


def test_field_override_is_raw_without_frame_conversion(table: pd.DataFrame,
                                                        written: dict[str, Path]) -> None:
    opts = ReadOptions(overrides=[parse_override("q=/mavros/imu/data.angular_velocity.y"),
                                  parse_override("extra=/mavros/rc/in.channels[6]")])
    read = read_log(written["ros2-db3"], opts)
    t = read.index.to_numpy() + read.attrs["start_time"] - START
    flu_y = -np.interp(t, table.index.to_numpy(), table["q"].to_numpy())
    np.testing.assert_allclose(read["q"].to_numpy(), flu_y, atol=1e-3)
    extra = read["extra"].dropna()
    assert len(extra) > 0.95 * len(read) and np.all(extra == 1500.0)
    assert read.attrs["mapping"]["q"] == "/mavros/imu/data.angular_velocity.y"


def test_rc_map_changes_stick_channels(table: pd.DataFrame, written: dict[str, Path]) -> None:
    opts = ReadOptions(rc_map={"u_roll": 2, "u_pitch": 1, "u_thrust": 3, "u_yaw": 4})
    read = read_log(written["ros1"], opts)
    t = read.index.to_numpy() + read.attrs["start_time"] - START
    expected = np.interp(t, table.index.to_numpy(), table["u_pitch"].to_numpy())
    np.testing.assert_allclose(read["u_roll"].to_numpy(), expected, atol=0.04)


def test_nan_and_inf_fields_are_dropped_and_counted(tmp_path: Path) -> None:
    table = synthetic_table(duration=4.0)
    table.iloc[100:130, table.columns.get_loc("p")] = np.nan
    table.iloc[200:300, table.columns.get_loc("vbat")] = np.inf
    table.iloc[50:75, table.columns.get_loc("alt")] = np.inf
    read = read_log(write_ros1_bag(table, tmp_path / "nan.bag"))
    dropped = {(d["reason"], d["signal"]): d["count"] for d in read.attrs["dropped"]}
    assert dropped[("NaN or inf sample", "/mavros/imu/data.angular_velocity.x")] == 12
    assert dropped[("range outside min_range..max_range",
                    "/mavros/distance_sensor/rangefinder_pub.range")] == 2
    assert np.isfinite(read["p"]).all() and np.isfinite(read["q"]).all()
    assert not np.isinf(read["vbat"].to_numpy()).any()


def _imu_bag(path: Path, stamps_ns: list[int], record_ns: list[int]) -> Path:
    """A ROS 1 bag with one Imu topic and the given header stamps, written by rosbags."""
    from rosbags.rosbag1 import Writer

    from etsid.rosmsgs import typestore
    from etsid.sim.writers.rosbag import instantiate

    store = typestore(ros1=True)
    with Writer(path) as writer:
        conn = writer.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        for i, (stamp, rec) in enumerate(zip(stamps_ns, record_ns, strict=True)):
            msg = instantiate(store, "sensor_msgs/msg/Imu", {
                "header": {"stamp": {"sec": stamp // 10**9, "nanosec": stamp % 10**9}},
                "orientation": {"w": 1.0}, "angular_velocity": {"x": 0.01 * i, "y": 0.2},
                "orientation_covariance": [-1.0] + [0.0] * 8})
            writer.write(conn, rec, store.serialize_ros1(msg, "sensor_msgs/msg/Imu"))
    return path


def test_duplicate_backward_and_zero_header_stamps(tmp_path: Path) -> None:
    base = 1_700_000_000 * 10**9
    step = 10_000_000
    stamps = [base + i * step for i in range(50)]
    stamps[10] = stamps[9]  # duplicate
    stamps[20], stamps[21] = stamps[21], stamps[20]  # out of order
    stamps[30] = 0  # unset: record time is used
    record = [base + i * step + 2_000_000 for i in range(50)]
    read = read_log(_imu_bag(tmp_path / "stamps.bag", stamps, record))
    repaired = {(d["reason"], d["signal"]): d["count"] for d in read.attrs["repaired"]}
    dropped = {(d["reason"], d["signal"]): d["count"] for d in read.attrs["dropped"]}
    assert repaired[("header.stamp zero or implausible, used record time", "/imu/data")] == 1
    assert repaired[("out-of-order timestamp, re-sorted",
                     "/imu/data.angular_velocity.x")] == 2
    assert dropped[("duplicate timestamp", "/imu/data.angular_velocity.x")] == 1
    assert "roll" not in read.columns  # orientation covariance -1: not provided
    np.testing.assert_allclose(read["q"], -0.2)


def test_truncated_ros1_bag_keeps_the_valid_part(written: dict[str, Path],
                                                 tmp_path: Path) -> None:
    data = written["ros1"].read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    full, part = read_log(written["ros1"]), read_log(cut)
    assert 0.3 * len(full) < len(part) < 0.9 * len(full)
    assert any("truncated bag" in w and "could not be read" in w
               for w in part.attrs["warnings"])
    np.testing.assert_allclose(part["p"].to_numpy(), full["p"].to_numpy()[: len(part)],
                               atol=1e-12)


def test_truncated_mcap_keeps_the_valid_part(written: dict[str, Path], tmp_path: Path) -> None:
    data = written["mcap-ros2"].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.7)])
    full, part = read_log(written["mcap-ros2"]), read_log(cut)
    assert 0.2 * len(full) < len(part) < 0.95 * len(full)
    assert any("cut.mcap: truncated" in w and f"kept {len(part) and ''}" in w
               and "the rest of the recording is lost" in w for w in part.attrs["warnings"])
    tiny = tmp_path / "tiny.mcap"
    tiny.write_bytes(data[:2000])
    with pytest.raises(IngestError, match="tiny.mcap: truncated MCAP file"):
        read_log(tiny)


@pytest.mark.parametrize(("name", "content", "message"), [
    ("junk.bag", b"#ROSBAG V2.0\n" + bytes(range(256)) * 4, "not a readable ROS 1 bag"),
    ("junk.mcap", b"\x89MCAP0\r\n" + bytes(range(256)) * 4, "not a readable MCAP file"),
    ("junk.db3", b"SQLite format 3\x00" + bytes(range(256)) * 16, "not a readable ROS 2 bag"),
])
def test_garbage_after_valid_magic(tmp_path: Path, name: str, content: bytes,
                                   message: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(IngestError, match=message):
        read_log(path)
    result = CliRunner().invoke(cli, ["ingest", str(path), "-o", str(tmp_path / "o.parquet")])
    assert result.exit_code == 1 and "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and name in lines[0] and message in lines[0]


def test_cli_ingest_writes_the_table(written: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "table.parquet"
    result = CliRunner().invoke(cli, ["ingest", str(written["ros2-mcap"]), "-o", str(out)])
    assert result.exit_code == 0, result.output
    from etsid.table import load_table

    loaded = load_table(out)
    assert loaded.attrs["format"] == "ros2" and "vbat" in loaded.columns


@pytest.mark.parametrize("fmt", ["ros1", "ros2-db3", "mcap"])
def test_stream_rates_are_the_writers_rates_option(table: pd.DataFrame, tmp_path: Path,
                                                   fmt: str) -> None:
    from etsid.sim.writers import write_log

    name = {"ros1": "r.bag", "ros2-db3": "r.db3", "mcap": "r.mcap"}[fmt]
    path = write_log(table, tmp_path / name, fmt, rates={"rc_in": 50.0, "battery": 0.0})
    channels = {c["name"]: c for c in inspect_log(path)["channels"]}
    assert "/mavros/battery" not in channels
    assert channels["/mavros/rc/in"]["rate_hz"] == pytest.approx(50.0, rel=0.01)  # default 25
    assert channels["/mavros/imu/data"]["rate_hz"] == pytest.approx(100.0, rel=0.01)
    with pytest.raises(ValueError, match="unknown MAVROS stream"):
        write_log(table, tmp_path / f"x{name}", fmt, rates={"gyro": 10.0})
