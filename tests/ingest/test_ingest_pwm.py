"""One PWM conversion for every format: real files with known PWM → sticks and motors.

Each log is written by etsid's own writer from a table of constant sticks and motors, so
every RC / servo sample in the file has one known pulse width; it is read back with the
default and with a narrower, non-default RC range. Out-of-range PWM must be clipped (not
passed through) and counted in ``repaired``, the same way in every format. DataFlash and
ULog have no writer and are tested in their own files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from etsid.ingest import ReadOptions, read_log, read_raw
from etsid.ingest.base import RawLog
from etsid.pwm import motor_to_pwm, pwm_to_motor, pwm_to_stick, stick_to_pwm
from etsid.sim.writers import write_log

NARROW = (1100.0, 1500.0, 1900.0)
"""A non-default RC range, µs."""
WRITTEN = {"u_roll": -1.0, "u_pitch": 0.5, "u_yaw": 1.2, "u_thrust": 0.25,
           "m1": 0.0, "m2": 0.5, "m3": 1.05, "m4": 0.9}
"""Table values; with the default range they are written as these PWM (µs):"""
PWM_DEFAULT = {"u_roll": 1000, "u_pitch": 1750, "u_yaw": 2100, "u_thrust": 1250,
               "m1": 1000, "m2": 1500, "m3": 2050, "m4": 1900}
READ_DEFAULT = {"u_roll": -1.0, "u_pitch": 0.5, "u_yaw": 1.0, "u_thrust": 0.25,
                "m1": 0.0, "m2": 0.5, "m3": 1.0, "m4": 0.9}
"""The default-range file read with the default range (u_yaw 2100 µs, m3 2050 µs clipped)."""
READ_NARROW = {"u_roll": -1.0, "u_pitch": 0.625, "u_yaw": 1.0, "u_thrust": 0.1875,
               "m1": 0.0, "m2": 0.5, "m3": 1.0, "m4": 1.0}
"""The default-range file read with 1100/1500/1900 µs: (pwm − 1500)/400, (pwm − 1100)/800."""
CLIPPED_NARROW = {"u_roll", "u_yaw", "m1", "m3"}
"""Columns whose PWM lies outside 1100…1900 µs (m4 at 1900 µs is exactly on the edge)."""
FORMATS = ["tlog", "ros1", "ros2-db3", "ros2-mcap", "mcap", "mcap-ros1", "mcap-json"]


def constant_table(values: dict[str, float], seconds: float = 2.0) -> pd.DataFrame:
    t = np.arange(int(seconds * 100)) / 100.0
    table = pd.DataFrame({c: np.full(t.size, v) for c, v in values.items()},
                         index=pd.Index(t, name="t"))
    table.attrs["start_time"] = 1.7e9
    return table


def written(fmt: str, tmp_path: Path, **kwargs: object) -> Path:
    suffix = {"tlog": ".tlog", "ros1": ".bag", "mcap": ".mcap", "mcap-ros1": ".mcap",
              "mcap-json": ".mcap"}.get(fmt, "")
    path = tmp_path / f"pwm_{fmt}{suffix}"
    table = constant_table(WRITTEN)
    if kwargs:
        from etsid.sim.writers.mcapfile import write_mcap
        from etsid.sim.writers.rosbag import write_ros1_bag, write_ros2_bag
        from etsid.sim.writers.tlog import write_tlog

        writers = {"tlog": write_tlog, "ros1": write_ros1_bag,
                   "ros2-db3": lambda t, p, **k: write_ros2_bag(t, p, "sqlite3", **k),
                   "ros2-mcap": lambda t, p, **k: write_ros2_bag(t, p, "mcap", **k),
                   "mcap": write_mcap,
                   "mcap-ros1": lambda t, p, **k: write_mcap(t, p, "ros1", **k),
                   "mcap-json": lambda t, p, **k: write_mcap(t, p, "json", **k)}
        return writers[fmt](table, path, **kwargs)
    return write_log(table, path, fmt)


def by_column(raw: RawLog) -> dict[str, np.ndarray]:
    """The one RC / servo signal of each stick and motor column."""
    out: dict[str, np.ndarray] = {}
    for sig in raw.signals:
        if sig.column in WRITTEN:
            assert sig.column not in out, f"two signals for {sig.column}"
            out[sig.column] = sig.values
    assert set(out) == set(WRITTEN)
    return out


def clipped(raw: RawLog) -> dict[str, int]:
    """Column → samples reported clipped (through the signal's source)."""
    column = {s.source: s.column for s in raw.signals}
    return {column[i.signal]: i.count for i in raw.repaired
            if "PWM outside the RC range" in i.reason}


@pytest.mark.parametrize("fmt", FORMATS)
def test_known_pwm_read_with_default_and_narrow_range(fmt: str, tmp_path: Path) -> None:
    path = written(fmt, tmp_path)
    default = read_raw(path)
    for column, values in by_column(default).items():
        np.testing.assert_allclose(values, READ_DEFAULT[column], atol=1e-12, err_msg=column)
    counts = clipped(default)
    assert set(counts) == {"u_yaw", "m3"}
    n_rc = by_column(default)["u_yaw"].size
    assert counts["u_yaw"] == n_rc

    narrow = read_raw(path, ReadOptions(rc_range_us=NARROW))
    values = by_column(narrow)
    for column, v in values.items():
        np.testing.assert_allclose(v, READ_NARROW[column], atol=1e-12, err_msg=column)
    counts = clipped(narrow)
    assert set(counts) == CLIPPED_NARROW
    assert all(counts[c] == values[c].size for c in CLIPPED_NARROW)
    assert all("1100–1900 µs" in i.reason for i in narrow.repaired if "PWM" in i.reason)


@pytest.mark.parametrize("fmt", FORMATS)
def test_writer_honours_the_rc_range(fmt: str, tmp_path: Path) -> None:
    """Written and read with 1100/1500/1900 µs: in-range values come back unchanged."""
    path = written(fmt, tmp_path, rc_range_us=NARROW)
    values = by_column(read_raw(path, ReadOptions(rc_range_us=NARROW)))
    expect = {"u_roll": -1.0, "u_pitch": 0.5, "u_yaw": 1.0, "u_thrust": 0.25,
              "m1": 0.0, "m2": 0.5, "m3": 1.0, "m4": 0.9}
    for column, v in values.items():
        np.testing.assert_allclose(v, expect[column], atol=1e-12, err_msg=column)
    # the same file read with the default range shows the narrower PWM it holds
    wide = by_column(read_raw(path))
    np.testing.assert_allclose(wide["u_pitch"], 0.4)  # 1700 µs
    np.testing.assert_allclose(wide["m4"], 0.82)  # 1820 µs


def test_clipped_counts_reach_the_table(tmp_path: Path) -> None:
    table = read_log(written("tlog", tmp_path), ReadOptions(rc_range_us=NARROW))
    reasons = {(r["reason"], r["signal"]) for r in table.attrs["repaired"]}
    assert ("PWM outside the RC range 1100–1900 µs, clipped", "RC_CHANNELS.chan1_raw") in reasons
    assert table["u_roll"].min() == -1.0 and table["m3"].max() == 1.0


def test_unused_channel_values_are_no_value() -> None:
    values, n = pwm_to_stick(np.array([0, 65535, 1500, 900], dtype=np.uint16), "u_pitch")
    assert np.isnan(values[:2]).all() and values[2] == 0.0 and values[3] == -1.0 and n == 1
    motors, n = pwm_to_motor(np.array([np.nan, -5.0, 1250.0]))
    assert np.isnan(motors[:2]).all() and motors[2] == 0.25 and n == 0


@given(st.floats(-1.0, 1.0), st.sampled_from(["u_roll", "u_thrust", "m"]),
       st.floats(900.0, 1200.0), st.floats(100.0, 600.0))
def test_write_then_read_is_the_identity_inside_the_range(value: float, column: str,
                                                          lo: float, half: float) -> None:
    rc = (lo, lo + half, lo + 2 * half)
    if column == "m":
        value = abs(value)
        back, _ = pwm_to_motor(motor_to_pwm(np.array([value]), rc), rc)
    else:
        value = abs(value) if column == "u_thrust" else value
        back, _ = pwm_to_stick(stick_to_pwm(np.array([value]), column, rc), column, rc)
    assert back[0] == pytest.approx(value, abs=1e-12)
