"""Source choice by content (etsid/ingest/source_check.py): the S500-style ``dist_bottom``
case as a real ULog (written byte by byte in the ULog format, read by pyulog), and the
rules on hand-made signals."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from etsid.cli import cli
from etsid.ingest import inspect_log, read_log
from etsid.ingest.base import Signal
from etsid.ingest.source_check import (
    MIN_COVERAGE,
    coverage,
    order_by_content,
    reference_span,
    stuck_value,
)

TAKEOFF_S, LANDING_S, END_S = 8.0, 52.0, 60.0


def _ulog_message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def write_s500_ulog(path: Path, valid_share: float = 0.2) -> Path:
    """A 60 s PX4-1.11-like mission without a range finder (trailing padding not written,
    as PX4 does): vehicle_local_position at 50 Hz with ``z`` climbing to 10 m and
    ``dist_bottom`` at its 0.1 m floor, valid (``dist_bottom_valid``) only on the first
    ``valid_share`` of the samples (the ground and the climb); vehicle_angular_velocity at
    100 Hz; the land detector airborne 8–52 s."""
    topics = [
        ("vehicle_angular_velocity",
         "uint64_t timestamp;uint64_t timestamp_sample;float[3] xyz;"),
        ("vehicle_local_position",
         "uint64_t timestamp;float z;float vz;float dist_bottom;bool z_valid;bool v_z_valid;"
         "bool dist_bottom_valid;uint8_t[5] _padding0;"),
        ("vehicle_land_detected", "uint64_t timestamp;bool landed;uint8_t[7] _padding0;"),
    ]
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += _ulog_message(b"B", bytes(16) + bytes(24))
    for name, fields in topics:
        out += _ulog_message(b"F", f"{name}:{fields}".encode())
    for msg_id, (name, _) in enumerate(topics):
        out += _ulog_message(b"A", struct.pack("<BH", 0, msg_id) + name.encode())
    rng = np.random.default_rng(5)
    n = int(END_S * 100)
    for k in range(n):
        t = k / 100.0
        us = 1_000_000 + 10_000 * k
        flying = TAKEOFF_S <= t <= LANDING_S
        gyro = rng.normal(0.0, 0.01, 3) + (0.2 * np.sin(1.7 * t) if flying else 0.0)
        out += _ulog_message(b"D", struct.pack("<HQQ3f", 0, us, us, *gyro))
        if k % 2 == 0:
            height = 0.0 if not flying else 10.0 * min(1.0, (t - TAKEOFF_S) / 5.0,
                                                       (LANDING_S - t) / 5.0)
            valid = k < valid_share * n
            out += _ulog_message(b"D", struct.pack(
                "<HQfff???", 1, us, -height + rng.normal(0.0, 0.02), 0.0, 0.1, True, True,
                valid))
        if k % 50 == 0:
            out += _ulog_message(b"D", struct.pack("<HQ?", 2, us, not flying))
    path.write_bytes(bytes(out))
    return path


def test_s500_dist_bottom_at_its_floor_gives_way_to_z(tmp_path: Path) -> None:
    path = write_s500_ulog(tmp_path / "s500.ulg")
    table = read_log(path)
    assert table.attrs["mapping"]["alt"] == "vehicle_local_position.z"
    note = next(w for w in table.attrs["warnings"] if w.startswith("alt:"))
    assert "by content, not vehicle_local_position.dist_bottom" in note
    assert "of the airborne part" in note
    air = table[(table.index > TAKEOFF_S + 6) & (table.index < LANDING_S - 6)]
    assert air["alt"].min() > 9.0  # the real height, not the 0.1 m floor
    info = inspect_log(path)
    assert info["mapping"]["alt"] == "vehicle_local_position.z"
    assert any("dist_bottom" in w and "by content" in w for w in info["warnings"])


def test_inspect_shows_the_winner_and_why(tmp_path: Path) -> None:
    path = write_s500_ulog(tmp_path / "s500.ulg")
    result = CliRunner().invoke(cli, ["inspect", str(path)])
    assert result.exit_code == 0, result.output
    assert "used vehicle_local_position.z by content" in result.output


def test_a_valid_range_finder_keeps_its_priority(tmp_path: Path) -> None:
    """dist_bottom valid over the whole flight (a real range finder) and moving: kept."""
    path = write_s500_ulog(tmp_path / "ok.ulg", valid_share=1.0)
    raw_table = read_log(path)
    # the writer's dist_bottom is constant (0.1 m): now valid everywhere, it is judged
    # stuck, and z wins again; a moving one is tested on signals below
    assert raw_table.attrs["mapping"]["alt"] == "vehicle_local_position.z"
    note = next(w for w in raw_table.attrs["warnings"] if w.startswith("alt:"))
    assert "is constant at 0.1" in note


def _sig(column: str, t: np.ndarray, v: np.ndarray, source: str, prio: int) -> Signal:
    return Signal(column, t, v, source, prio)


def test_rules_on_signals() -> None:
    t = np.arange(0.0, 100.0, 0.1)
    landed = _sig("landed", t, np.where((t > 10) & (t < 90), 0.0, 1.0), "det.landed", 0)
    span = reference_span([landed])
    assert span[0] > 10 and span[1] < 90 and span[2] == "the airborne part"
    ranger = np.where(t < 60, 2.0 + np.sin(t), np.nan)  # empty in the last third of the flight
    good = _sig("alt", t, ranger, "rng.d", 0)
    assert 0.6 < coverage(good, *span[:2]) < 0.65
    est = _sig("alt", t, 2.0 + np.sin(t) + 0.01 * np.cos(7 * t), "lpos.z", 5)
    order, note = order_by_content("alt", [good, est], span)
    assert order[0] is good and note is None  # 62 % ≥ MIN_COVERAGE: priority holds
    sparse = _sig("alt", t, np.where(t < 30, 2.0 + np.sin(t), np.nan), "rng.d", 0)
    assert coverage(sparse, *span[:2]) < MIN_COVERAGE
    order, note = order_by_content("alt", [sparse, est], span)
    assert order[0] is est and "rng.d has a value on only 25 % of the airborne part" in note
    stuck = _sig("alt", t, np.full(t.size, 0.1), "rng.d", 0)
    assert stuck_value(stuck, *span[:2]) == 0.1
    order, note = order_by_content("alt", [stuck, est], span)
    assert order[0] is est and "constant at 0.1" in note
    # inputs are not judged by content: a still stick stays a stick
    order, note = order_by_content("u_roll", [_sig("u_roll", t, 0 * t, "rc.1", 0),
                                              _sig("u_roll", t, np.sin(t), "ctl.0", 5)], span)
    assert order[0].source == "rc.1" and note is None
    # every candidate flawed: the order stays and the note says so
    order, note = order_by_content("alt", [stuck, sparse], span)
    assert order[0] is stuck and "no other candidate is better" in note
