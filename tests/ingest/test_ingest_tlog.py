"""MAVLink telemetry logs: writer round trip, time handling, real SITL log, bad input."""

from __future__ import annotations

import shutil
import struct
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from pymavlink import mavutil
from pymavlink.dialects.v20 import common

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import read_log, read_raw
from etsid.ingest.base import Override, ReadOptions
from etsid.ingest.mavlink.clock import BOOT, NONE, WRAP32_US, autopilot_clock
from etsid.ingest.mavlink.dtypes import crc_extra_table
from etsid.ingest.mavlink.scan import (
    KEYS_MAX,
    OK,
    ScanResult,
    crc_x25,
    frame_key,
    frame_key_stats,
    gather_payloads,
    gather_payloads_reference,
    key_stats,
    scan_frames,
    scan_frames_reference,
    use_kernels,
)
from etsid.ingest.mavlink.store import FrameStore
from etsid.sim.writers.tlog import write_tlog

DATA = Path(__file__).parents[1] / "data"
SITL = DATA / "ardupilot_sitl_quadplane.tlog"
START = 1.7e9


def flight_table(duration: float = 12.0, rate: float = 250.0, start: float = START) -> pd.DataFrame:
    """Smooth known signals in every column the tlog writer knows."""
    t = np.arange(0.0, duration, 1.0 / rate)
    d = {c: 0.5 * np.sin(2 * np.pi * (0.3 + 0.1 * i) * t) for i, c in enumerate("pqr")}
    d |= {"roll": 0.2 * np.sin(0.5 * t), "pitch": 0.1 * np.cos(0.4 * t),
          "yaw": np.angle(np.exp(1j * (0.3 * t + 3.0)))}
    d |= {c: 0.6 * np.sin(0.7 * t + k) for k, c in enumerate(("u_roll", "u_pitch", "u_yaw"))}
    d |= {"u_thrust": 0.5 + 0.2 * np.sin(0.3 * t)}
    d |= {c: 0.3 * np.sin(0.5 * t + k) for k, c in enumerate(("sp_p", "sp_q", "sp_r"))}
    d |= {"alt": 2.0 + np.sin(0.2 * t), "vx": np.sin(0.1 * t), "vy": np.cos(0.1 * t),
          "vz": 0.1 * np.sin(t), "ax": np.sin(t), "ay": np.cos(t),
          "az": -9.8 + 0.1 * np.sin(t), "vbat": 16.0 - 0.01 * t}
    d |= {f"m{i}": 0.5 + 0.1 * np.sin(t + i) for i in range(1, 7)}
    table = pd.DataFrame(d, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = start
    return table


# quantisation of the written fields (+ the hold of a 25 Hz command against a smooth truth)
TOL = {"u_roll": 0.02, "u_pitch": 0.02, "u_yaw": 0.02, "u_thrust": 0.01, "sp_p": 0.01,
       "sp_q": 0.01, "sp_r": 0.01, "alt": 0.006, "vbat": 0.003, "vx": 0.002, "vy": 0.002,
       "vz": 0.002, **{f"m{i}": 0.01 for i in range(1, 7)}}


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    return flight_table()


@pytest.fixture(scope="module")
def tlog(table: pd.DataFrame, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_tlog(table, tmp_path_factory.mktemp("tlog") / "flight.tlog")


def test_round_trip_every_column(table: pd.DataFrame, tlog: Path) -> None:
    out = read_log(tlog)
    assert set(table.columns) <= set(out.columns)
    assert out.attrs["rate_hz"] == pytest.approx(50.0)  # ATTITUDE carries p q r
    tt = out.index.to_numpy()
    for column in table.columns:
        truth = np.interp(tt, table.index.to_numpy(), table[column].to_numpy())
        got = out[column].to_numpy()
        ok = np.isfinite(got)
        assert ok.mean() > 0.95, column
        err = np.abs(got[ok] - truth[ok])
        if column == "yaw":
            err = np.abs(np.angle(np.exp(1j * (got[ok] - truth[ok]))))
        assert err.max() < TOL.get(column, 1e-5), column
    assert out.attrs["mapping"]["p"] == "ATTITUDE.rollspeed"
    assert out.attrs["mapping"]["alt"] == "DISTANCE_SENSOR.current_distance"
    assert out.attrs["mapping"]["u_thrust"] == "RC_CHANNELS.chan3_raw"
    assert out.attrs["start_time"] == pytest.approx(START, abs=0.05)


def test_gcs_stamp_differs_from_autopilot_clock(tlog: Path) -> None:
    conn = mavutil.mavlink_connection(str(tlog))
    lags = []
    while (msg := conn.recv_match(type="ATTITUDE")) is not None:
        lags.append(msg._timestamp - (START + msg.time_boot_ms * 1e-3 - 30.0))
    lags = np.array(lags)
    assert lags.min() > 0.0 and lags.std() > 1e-3  # delayed, and not by a constant


def test_rates_are_unequal_and_as_configured(tlog: Path) -> None:
    raw = read_raw(tlog)
    rates = {c.name: c.rate_hz for c in raw.channels}
    assert rates["ATTITUDE"] == pytest.approx(50, rel=0.02)
    assert rates["HIGHRES_IMU"] == pytest.approx(100, rel=0.02)
    assert rates["RC_CHANNELS"] == pytest.approx(25, rel=0.02)
    assert rates["SYS_STATUS"] == pytest.approx(2, rel=0.1)
    assert raw.extra["sysids"] == [1]


def test_crc_equals_pymavlinks_x25() -> None:
    """The reference CRC (binascii on bit-reversed bytes) is pymavlink's X.25, seed byte
    included, on random frames of every length a MAVLink 2 frame can have."""
    from pymavlink.generator.mavcrc import x25crc

    rng = np.random.default_rng(7)
    for size in [*range(0, 40), *rng.integers(40, 281, 60)]:
        data = rng.integers(0, 256, int(size), dtype=np.uint8).tobytes()
        extra = int(rng.integers(0, 256))
        want = x25crc(data)
        want.accumulate(bytes((extra,)))
        assert crc_x25(data, extra) == want.crc, size


def test_scan_kernel_matches_reference(tlog: Path) -> None:
    import etsid.ingest.mavlink.scan_kernels  # noqa: F401  (loads numba: the kernels run)

    data = bytearray(tlog.read_bytes()[:20000])
    data[5000] ^= 0xFF  # break one frame's CRC
    data[9000:9000] = b"\x00\xfe\x12junk"  # garbage between records
    buf = np.frombuffer(bytes(data), np.uint8)
    assert use_kernels(buf.size)
    fast = scan_frames(buf, crc_extra_table(), final=True)
    slow = scan_frames_reference(bytes(data), crc_extra_table(), final=True)
    for name in ("offset", "length", "msgid", "sysid", "compid", "stamp_us", "status"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name))
    assert (fast.consumed, fast.skipped, fast.bad_crc) == (slow.consumed, slow.skipped,
                                                           slow.bad_crc)
    assert fast.bad_crc >= 1 and fast.skipped > 0
    payload = gather_payloads(buf, fast.offset, fast.length, 40)
    np.testing.assert_array_equal(payload,
                                  gather_payloads_reference(buf, fast.offset, fast.length, 40))


def test_sliced_crc_matches_the_bitwise_crc() -> None:
    from etsid.ingest.mavlink.scan_kernels import _crc

    rng = np.random.default_rng(11)
    for size in [*range(0, 40), 255, 263]:  # every tail after the 8- and 4-byte steps
        data = rng.integers(0, 256, size, dtype=np.uint8)
        extra = int(rng.integers(0, 256))
        assert _crc(data, 0, size, extra) == crc_x25(data.tobytes(), extra), size
        if size > 3:  # from an offset into the buffer
            assert _crc(data, 3, size, extra) == crc_x25(data[3:].tobytes(), extra), size


def _chunked_scans(data: bytes, size: int) -> list[tuple[np.ndarray, ScanResult, int, float]]:
    """(buffer, its scan, file frame number of its first frame, share of the file read)
    per chunk of ``size`` bytes, the partial record carried over as the reader does."""
    out = []
    carry, pos, first = b"", 0, 0
    while True:
        got = data[pos:pos + size]
        pos += len(got)
        final = pos >= len(data)
        buf = np.frombuffer(carry + got, np.uint8)
        res = scan_frames(buf, crc_extra_table(), final)
        out.append((buf, res, first, pos / len(data)))
        first += res.offset.size
        carry = bytes(buf[res.consumed:])
        if final:
            return out


def _joined_gathers(scans: list[tuple[np.ndarray, ScanResult, int, float]], ids: list[int],
                    sizes: list[int]) -> dict[int, dict[str, np.ndarray]]:
    """The former computation: each chunk's frames of an id (status OK) gathered by the
    plain reference, then the chunks' parts joined."""
    out = {}
    for mid, size in zip(ids, sizes, strict=True):
        parts = []
        for buf, res, first, _ in scans:
            sel = np.flatnonzero((res.msgid == mid) & (res.status == OK))
            parts.append({"rec": gather_payloads_reference(buf, res.offset[sel],
                                                           res.length[sel], size).ravel(),
                          "index": first + sel, "stamp": res.stamp_us[sel],
                          "sysid": res.sysid[sel], "compid": res.compid[sel]})
        if sum(p["index"].size for p in parts):
            out[mid] = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return out


def test_frame_store_equals_the_joined_gathers(tlog: Path) -> None:
    """The store's arrays, numba and plain, equal the chunks' gathers joined, bit for
    bit: a bad CRC and garbage between records, several chunk sizes (the regions grow,
    from estimates that are too small or too large), payloads cut and zero-padded, an id
    that never comes."""
    import etsid.ingest.mavlink.scan_kernels  # noqa: F401  (loads numba: the kernels run)

    data = bytearray(tlog.read_bytes()[:40000])
    data[7000] ^= 0xFF
    data[15000:15000] = b"\x00\xfe\x12junk"
    present = sorted(set(scan_frames(np.frombuffer(bytes(data), np.uint8), crc_extra_table(),
                                     True).msgid.tolist()))
    ids = [*present[::-1], 99999]
    sizes = [9 if i % 3 == 0 else 70 for i in range(len(ids))]
    for size in (997, 4096, 15000, len(data)):
        scans = _chunked_scans(bytes(data), size)
        want = _joined_gathers(scans, ids, sizes)
        for fast, skew in ((True, 1.0), (False, 1.0), (True, 0.3), (True, 3.0)):
            store = FrameStore(ids, sizes)
            for buf, res, first, share in scans:
                store.add(buf, res, first, min(share * skew, 1.0), fast)
            got = store.parts({mid: np.dtype((np.void, n)) for mid, n in zip(ids, sizes,
                                                                              strict=True)})
            assert list(got) == [mid for mid in ids if mid in want]
            for mid, part in got.items():
                assert set(part) == set(want[mid])
                for key, value in part.items():
                    ref = want[mid][key]
                    value = value.view(np.uint8) if key == "rec" else value
                    assert value.dtype == ref.dtype, (size, fast, skew, mid, key)
                    np.testing.assert_array_equal(value, ref)


def test_key_counts_match_their_reference(tlog: Path) -> None:
    import etsid.ingest.mavlink.scan_kernels  # noqa: F401  (loads numba: the kernels run)

    data = bytearray(tlog.read_bytes()[:30000])
    data[7000] ^= 0xFF
    res = scan_frames(np.frombuffer(bytes(data), np.uint8), crc_extra_table(), final=True)
    key = (res.sysid.astype(np.int64) << 32) | res.msgid
    assert key_stats(key, res.stamp_us, True) == key_stats(key, res.stamp_us, False)
    # the keys made in the pass: the counts of the keys made by numpy
    compid = (res.msgid % 3).astype(np.uint8)  # several components too
    whole = ((res.sysid.astype(np.int64) << 32) | (compid.astype(np.int64) << 24)
             | res.msgid)
    assert np.array_equal(frame_key(res.sysid, compid, res.msgid), whole)
    want = key_stats(whole, res.stamp_us, False)
    assert len(want[0]) > 3
    assert frame_key_stats(res.sysid, compid, res.msgid, res.stamp_us, True) == want
    assert frame_key_stats(res.sysid, compid, res.msgid, res.stamp_us, False) == want
    # keys that share a message id's low 16 bits (the pass's hint of the key's slot)
    rng = np.random.default_rng(4)
    sysid = rng.integers(0, 3, 5000).astype(np.uint8)
    compid = rng.integers(0, 2, 5000).astype(np.uint8)
    msgid = (rng.integers(0, 4, 5000) + (rng.integers(0, 3, 5000) << 16)).astype(np.int32)
    stamp = rng.integers(0, 10**9, 5000).astype(np.int64)
    want = key_stats(frame_key(sysid, compid, msgid), stamp, False)
    assert len(want[0]) > 40
    assert frame_key_stats(sysid, compid, msgid, stamp, True) == want
    many = np.arange(KEYS_MAX + 5, dtype=np.int64)[::-1]  # more keys than the kernel holds
    assert key_stats(many, many * 2, True) == key_stats(many, many * 2, False)
    assert key_stats(many, many * 2, True)[0] == sorted(many.tolist())


def test_small_chunks_give_the_same_table(tlog: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.ingest.mavlink.tlog as reader

    whole = read_log(tlog)
    monkeypatch.setattr(reader, "CHUNK", 997)
    chunked = read_log(tlog)
    pd.testing.assert_frame_equal(whole, chunked)


def test_real_sitl_log_late_packets_resorted() -> None:
    raw = read_raw(SITL)
    att = {s.column: s for s in raw.signals if s.topic == "ATTITUDE"}
    t = att["p"].t
    assert np.all(np.diff(t) > 0)  # strictly increasing autopilot clock
    late = [i for i in raw.repaired if i.signal == "ATTITUDE"]
    assert late and late[0].count == 2 and "late" in late[0].reason
    # values equal pymavlink's decoding of the same packets, in autopilot-clock order
    conn = mavutil.mavlink_connection(str(SITL))
    ref, epochs = [], []
    while (m := conn.recv_match(type="ATTITUDE")) is not None:
        ref.append((m.time_boot_ms, m.rollspeed))
        epochs.append(m._timestamp - m.time_boot_ms * 1e-3)
    ref.sort()
    np.testing.assert_allclose(t, [r[0] * 1e-3 for r in ref])
    np.testing.assert_allclose(att["p"].values, [r[1] for r in ref], rtol=1e-6)
    # the ground station lags the autopilot by 0-4 s: clock zero from the smallest lag
    assert raw.start_time <= min(epochs) + 1e-6
    assert raw.start_time == pytest.approx(min(epochs), abs=0.05)
    assert max(epochs) - min(epochs) > 1.0  # bursty: the lag varies by more than 1 s
    assert raw.extra["sysid"] == 1 and raw.extra["sysids"] == [1]


def test_real_sitl_log_table() -> None:
    out = read_log(SITL)
    assert out.attrs["rate_hz"] == pytest.approx(4.17, abs=0.1)
    assert out.index[-1] == pytest.approx(208.3, abs=0.5)
    assert {"p", "u_roll", "m1", "ax", "vx", "alt"} <= set(out.columns)
    assert out["u_thrust"].dropna().between(0, 1).all()


def test_reboot_is_detected_and_placed_by_gcs_time(tmp_path: Path) -> None:
    first = write_tlog(flight_table(8.0), tmp_path / "a.tlog")
    second = write_tlog(flight_table(8.0, start=START + 40.0), tmp_path / "b.tlog", seed=1)
    both = tmp_path / "reboot.tlog"
    both.write_bytes(first.read_bytes() + second.read_bytes())  # uptime restarts at 30 s
    raw = read_raw(both)
    reboot = [i for i in raw.repaired if "reboot" in i.reason]
    assert reboot and reboot[0].count > 0
    p = next(s for s in raw.signals if s.source == "ATTITUDE.rollspeed")
    assert np.all(np.diff(p.t) > 0)
    jump = np.diff(p.t).max()
    assert jump == pytest.approx(40.0 - 8.0, abs=0.1)  # gap as the GCS saw it


def test_uint32_wraps_unwrapped() -> None:
    wrap_ms = 2**32 / 1000.0
    t = np.arange(0.0, 20.0, 0.02)
    boot = (wrap_ms - 10.0 + t) % wrap_ms  # time_boot_ms wraps after 10 s
    servo = ((wrap_ms - 10.0 + t) * 1e6 % 2**32) * 1e-6  # uint32 µs wraps too
    gcs = START + t + 0.01
    value = np.empty(2 * t.size)
    value[0::2], value[1::2] = boot, servo
    kind = np.tile([BOOT, WRAP32_US], t.size)
    clock = autopilot_clock(np.repeat(gcs, 2), value, kind)
    assert clock.ms_wraps == 1 and clock.reboots == 0 and clock.us_wraps > 0
    np.testing.assert_allclose(clock.t[0::2] - clock.t[0], t, atol=1e-9)
    np.testing.assert_allclose(clock.t[1::2] - clock.t[0], t, atol=1e-6)


def test_clock_walk_in_python_equals_the_compiled_walk() -> None:
    from etsid.ingest.mavlink.clock import MS_WRAP_S, REBOOT_LAG_S, STEP_S, US_WRAP_S, _walk
    from etsid.ingest.mavlink.clock_kernel import walk

    # a boot clock that wraps, a uint32 µs clock, frames without a clock, late packets
    # and a reboot 60 s in
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 120.0, 0.05)
    boot = np.where(t < 60.0, (MS_WRAP_S - 30.0 + t) % MS_WRAP_S, t - 60.0 + 0.5)
    gcs = START + t + 0.01 + rng.exponential(0.02, t.size)
    late = rng.random(t.size) < 0.05
    boot[late] -= 0.3  # packets that arrive late keep their own (earlier) clock
    kind = rng.choice([BOOT, WRAP32_US, NONE], size=t.size, p=[0.6, 0.3, 0.1])
    value = np.where(kind == WRAP32_US, (boot * 1e6 % 2**32) * 1e-6, boot)
    args = (gcs, value, kind.astype(np.int64), STEP_S, REBOOT_LAG_S, MS_WRAP_S, US_WRAP_S)
    plain, compiled = _walk(*args), walk(*args)
    np.testing.assert_array_equal(plain[0], compiled[0])
    np.testing.assert_array_equal(plain[1], compiled[1])
    assert plain[2:] == compiled[2:]
    assert plain[1].max() == 1 and plain[2] == 1  # the reboot and the ms wrap were seen


def test_frames_without_clock_take_the_latest_autopilot_time() -> None:
    gcs = START + np.array([0.0, 0.1, 0.2, 0.3])
    value = np.array([0.0, 5.0, 0.0, 5.2])
    kind = np.array([NONE, BOOT, NONE, BOOT])
    clock = autopilot_clock(gcs, value, kind)
    np.testing.assert_allclose(clock.t, [5.0, 5.0, 5.0, 5.2])


def _heartbeats(sysid: int, n: int, start: float) -> bytes:
    out = bytearray()
    mav = common.MAVLink(None, srcSystem=sysid, srcComponent=190)
    for k in range(n):
        out += struct.pack(">Q", int((start + 0.01 * k) * 1e6))
        out += mav.heartbeat_encode(6, 8, 0, 0, 4).pack(mav)
    return bytes(out)


def test_sysid_choice_and_gcs_ignored(tmp_path: Path) -> None:
    a = write_tlog(flight_table(6.0), tmp_path / "a.tlog", sysid=1)
    b = write_tlog(flight_table(3.0), tmp_path / "b.tlog", sysid=2)
    mixed = tmp_path / "mixed.tlog"
    mixed.write_bytes(_heartbeats(255, 5000, START - 60) + a.read_bytes() + b.read_bytes())
    raw = read_raw(mixed)
    assert raw.extra["sysid"] == 1 and raw.extra["sysids"] == [1, 2, 255]
    assert any("ignored other system ids" in w for w in raw.warnings)
    other = read_log(mixed, ReadOptions(sysid=2))
    assert other.index[-1] == pytest.approx(3.0, abs=0.05)
    with pytest.raises(IngestError, match="--sysid 7 not in the log"):
        read_raw(mixed, ReadOptions(sysid=7))


def test_override_extracts_raw_field(tlog: Path) -> None:
    opts = ReadOptions(overrides=[Override("p", "HIGHRES_IMU", "xgyro")])
    out = read_log(tlog, opts)
    assert out.attrs["mapping"]["p"] == "HIGHRES_IMU.xgyro"
    assert out.attrs["rate_hz"] == pytest.approx(100.0)
    bad = ReadOptions(overrides=[Override("p", "HIGHRES_IMU", "nosuch")])
    with pytest.raises(IngestError, match="HIGHRES_IMU has no field 'nosuch'"):
        read_log(tlog, bad)


def test_nan_and_inf_fields_are_dropped_and_counted(tmp_path: Path) -> None:
    table = flight_table(6.0)
    table.iloc[100:110, table.columns.get_loc("p")] = np.nan
    table.iloc[300:305, table.columns.get_loc("roll")] = np.inf
    table.iloc[500:520, table.columns.get_loc("vbat")] = np.nan
    out = read_log(write_tlog(table, tmp_path / "nan.tlog"))
    dropped = {i["signal"]: i["count"] for i in out.attrs["dropped"]
               if i["reason"] == "NaN or inf sample"}
    assert dropped["ATTITUDE.rollspeed"] == 2  # 40 ms of NaN at 50 Hz
    assert dropped["ATTITUDE.roll"] >= 1
    assert np.isfinite(out["p"]).all() and np.isfinite(out["roll"]).all()


def test_truncated_tlog_gives_valid_part_and_warning(tlog: Path, tmp_path: Path) -> None:
    data = tlog.read_bytes()
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(data[: len(data) // 2 + 7])
    out = read_log(cut)
    warn = [w for w in out.attrs["warnings"] if "truncated" in w]
    assert warn and "bytes" in warn[0]
    skipped = [i["count"] for i in out.attrs["dropped"] if "truncated" in i["reason"]]
    assert skipped and 0 < skipped[0] < 300
    assert out.index[-1] == pytest.approx(6.0, abs=0.3)


def test_bad_crc_and_unknown_ids_are_counted(tlog: Path, tmp_path: Path) -> None:
    data = bytearray(tlog.read_bytes())
    data[20 + 8 + 12] ^= 0x55  # inside the payload of an early frame
    frame = bytes([0xFD, 2, 0, 0, 0, 1, 1]) + (60001).to_bytes(3, "little") + b"\x01\x02\xaa\xbb"
    data += struct.pack(">Q", int(START * 1e6)) + frame  # id unknown to the dialect
    bad = tmp_path / "bad.tlog"
    bad.write_bytes(bytes(data))
    raw = read_raw(bad)
    reasons = {i.reason: i.count for i in raw.dropped}
    assert reasons["frame with a bad CRC"] >= 1
    assert reasons["unknown MAVLink message id 60001"] == 1


def test_only_unmapped_messages_is_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "hb.tlog"
    path.write_bytes(_heartbeats(1, 50, START))
    with pytest.raises(IngestError, match=r"no usable flight data; found HEARTBEAT"):
        read_log(path)


@pytest.mark.parametrize(("content", "match"), [
    (b"", "empty file"),
    (bytes(8) + b"\xfe" + bytes(range(256)) * 4, "no valid MAVLink packets"),
    (b"hello world, this is not a tlog", "not a MAVLink telemetry log"),
])
def test_bad_files(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.tlog"
    path.write_bytes(content)
    with pytest.raises(IngestError, match=match):
        read_log(path)
    result = CliRunner().invoke(cli, ["inspect", str(path)])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and match in lines[0]


def test_cli_ingest_truncated_warns(tlog: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.tlog"
    shutil.copy(tlog, cut)
    with cut.open("r+b") as handle:
        handle.truncate(cut.stat().st_size - 11)
    result = CliRunner().invoke(cli, ["ingest", str(cut), "-o", str(tmp_path / "o.parquet")])
    assert result.exit_code == 0, result.output
    assert "truncated" in result.output


def test_logged_clocks_equal_the_joined_and_sorted_arrays() -> None:
    """The frames placed at their rank (numba and numpy) give the arrays of the former
    computation, bit for bit: every message's stamps, clocks and kinds joined, then taken
    in the order of ``np.argsort`` of the frame numbers; all frames decoded or some, and
    each kind of clock (ms, µs with some in Unix time, uint32 µs, none)."""
    import etsid.ingest.mavlink.clock_kernel  # noqa: F401  (loads numba: the kernel runs)
    import etsid.ingest.mavlink.tlog as reader

    rng = np.random.default_rng(11)
    kinds = {"ATTITUDE": ("time_boot_ms", np.uint32, BOOT, 1e-3),
             "HIGHRES_IMU": ("time_usec", np.uint64, BOOT, 1e-6),
             "SERVO_OUTPUT_RAW": ("time_usec", np.uint32, WRAP32_US, 1e-6),
             "SYS_STATUS": ("", np.uint16, NONE, 0.0)}
    for case in range(12):
        nframes = int(rng.integers(0, 3000))
        numbers = rng.permutation(nframes)
        if case % 2:
            numbers = numbers[: int(rng.integers(0, nframes + 1))]
        cuts = np.sort(rng.integers(0, numbers.size + 1, len(kinds) - 1))
        msgs, names = {}, {}
        for mid, (name, part) in enumerate(zip(kinds, np.split(numbers, cuts), strict=True)):
            fld, dtype, _, _ = kinds[name]
            index = np.sort(part).astype(np.int64)
            rec = np.zeros(index.size, [("pad", np.uint8), (fld or "x", dtype)])
            rec[fld or "x"] = rng.integers(0, 2**31, index.size).astype(dtype)
            if dtype == np.uint64:
                rec[fld][::3] += np.uint64(1_700_000_000_000_000)  # Unix time
            msgs[mid] = {"rec": rec, "index": index,
                         "stamp": rng.integers(1.7e15, 1.8e15, index.size).astype(np.int64)}
            names[mid] = name
        index = np.concatenate([m["index"] for m in msgs.values()])
        order = np.argsort(index, kind="stable")
        want_gcs = np.concatenate([m["stamp"] * 1e-6 for m in msgs.values()])[order]
        values, codes = [], []
        for mid, m in msgs.items():
            fld, dtype, code, scale = kinds[names[mid]]
            if not fld:
                values.append(np.zeros(m["index"].size))
                codes.append(np.full(m["index"].size, NONE, np.int8))
                continue
            raw = m["rec"][fld]
            values.append(raw.astype(np.float64) * scale)
            codes.append(np.where(raw > 10**15, NONE, code).astype(np.int8)
                         if dtype == np.uint64 else np.full(raw.size, code, np.int8))
        want = (want_gcs, np.concatenate(values)[order], np.concatenate(codes)[order])
        places = reader._logged_places([m["index"] for m in msgs.values()], nframes)
        assert np.array_equal(np.concatenate(places), np.argsort(order, kind="stable"))
        for fast in (True, False):
            with pytest.MonkeyPatch.context() as patch:
                if not fast:
                    patch.delitem(sys.modules, "numba")
                got = reader._logged_clocks(msgs, names, places)
            for g, w in zip(got, want, strict=True):
                assert g.dtype == w.dtype
                np.testing.assert_array_equal(g, w)


def test_a_messages_signals_share_one_plain_time_array(tlog: Path) -> None:
    """With the compiled clock, the fields of one message still share one time array that
    ``np.asarray(t, dtype=float)`` returns as it is (numba's arrays carry float64 as another
    dtype object; a view per signal would repeat the per-array work of the table build)."""
    import etsid.ingest.mavlink.clock_kernel  # noqa: F401  (loads numba: the kernels run)

    raw = read_raw(tlog)
    by_topic: dict[str, set[int]] = {}
    for sig in raw.signals:
        by_topic.setdefault(sig.topic, set()).add(id(sig.t))
        assert np.asarray(sig.t, dtype=float) is sig.t
    assert len(by_topic["ATTITUDE"]) == 1 and len(by_topic["HIGHRES_IMU"]) == 1


@pytest.mark.parametrize("duration", [46.78, 49.75])
def test_motor_outputs_stamped_with_the_attitude_are_not_held_late(tmp_path: Path,
                                                                    duration: float) -> None:
    """SERVO_OUTPUT_RAW written at ATTITUDE's own instants (both 50 Hz, as the octocopter
    pairs' logs are) reads back with each grid point's own motor value: the grid is built
    from ATTITUDE's estimated period, and its floating-point error had put 15 % of the
    points of the 49.75 s log a hair before their motor sample (held 20 ms late) and 0.4 %
    of the 46.78 s log's, a 3 ms difference in apparent motor timing between the two."""
    t = np.arange(0.0, duration, 0.01)
    steps = np.floor(t / 0.02 + 1e-9)  # a new value at every 50 Hz instant
    table = pd.DataFrame({"p": np.sin(t), "q": np.cos(t), "r": 0.1 * t, "roll": 0.1 * np.sin(t),
                          "pitch": 0.1 * np.cos(t), "yaw": 0.0 * t, "az": -9.8 + 0.0 * t,
                          **{f"m{i}": 0.2 + 0.001 * (steps % 400) for i in (1, 2, 3, 4)}},
                         index=pd.Index(t, name="t"))
    table.attrs["start_time"] = START
    path = write_tlog(table, tmp_path / "servo.tlog", rates={"ATTITUDE": 50.0,
                                                            "SERVO_OUTPUT_RAW": 50.0})
    back = read_log(path)
    want = 0.2 + 0.001 * (np.floor(back.index.to_numpy() / 0.02 + 0.5) % 400)
    assert np.allclose(back["m1"].to_numpy(), want, atol=5e-4)
