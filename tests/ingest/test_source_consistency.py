"""Plausibility of a candidate against the other channels
(etsid/ingest/source_consistency.py), on ULogs written byte by byte in the ULog format and
read by pyulog: a gyro topic in deg/s, a height that does not follow the vertical
velocity, a specific force in g; and the rules on hand-made signals."""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.frames import euler_to_quat
from etsid.ingest import inspect_log, read_log
from etsid.ingest.base import Signal
from etsid.ingest.mapping import choose_signals
from etsid.ingest.source_consistency import (
    GAIN_RANGE,
    MIN_CORRELATION,
    Referee,
    gain,
    misfit,
)

TAKEOFF_S, LANDING_S, END_S = 5.0, 55.0, 60.0
G = 9.80665
DEG = np.pi / 180.0

ATTITUDE = ("vehicle_attitude", "uint64_t timestamp;uint64_t timestamp_sample;float[4] q;",
            "<QQ4f")
RATES = ("vehicle_angular_velocity", "uint64_t timestamp;uint64_t timestamp_sample;"
         "float[3] xyz;", "<QQ3f")
COMBINED = ("sensor_combined", "uint64_t timestamp;float[3] gyro_rad;"
            "float[3] accelerometer_m_s2;", "<Q6f")
ACCEL = ("sensor_accel", "uint64_t timestamp;uint64_t timestamp_sample;float x;float y;"
         "float z;", "<QQ3f")
LPOS = ("vehicle_local_position", "uint64_t timestamp;float z;float vz;float dist_bottom;"
        "bool z_valid;bool v_z_valid;bool dist_bottom_valid;uint8_t[5] _padding0;",
        "<Qfff???")
LANDED = ("vehicle_land_detected", "uint64_t timestamp;bool landed;uint8_t[7] _padding0;",
          "<Q?")


def _msg(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def write_ulog(path: Path, topics: list[tuple[str, str, str]],
               rows: Callable[[float], dict[str, tuple[float, ...]]],
               rates_hz: dict[str, int]) -> Path:
    """A ULog of ``topics`` (name, ULog format, struct format of the payload with its
    timestamps, trailing padding not written, as PX4 does), sampled on a 100 Hz clock:
    topic ``name`` every ``100 // rates_hz[name]`` ticks, its values ``rows(t)[name]``;
    timestamps (and timestamp_sample) in µs."""
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += _msg(b"B", bytes(40))
    for name, fields, _ in topics:
        out += _msg(b"F", f"{name}:{fields}".encode())
    for msg_id, (name, _, _) in enumerate(topics):
        out += _msg(b"A", struct.pack("<BH", 0, msg_id) + name.encode())
    for k in range(int(END_S * 100)):
        t = k / 100.0
        us = 1_000_000 + 10_000 * k
        values = rows(t)
        for msg_id, (name, _, fmt) in enumerate(topics):
            if k % (100 // rates_hz[name]):
                continue
            stamps = (us, us) if fmt.startswith("<QQ") else (us,)
            out += _msg(b"D", struct.pack("<H", msg_id) + struct.pack(fmt, *stamps,
                                                                      *values[name]))
    path.write_bytes(bytes(out))
    return path


def _flying(t: float) -> bool:
    return TAKEOFF_S <= t <= LANDING_S


def _attitude(t: float) -> tuple[float, float, float, float, float, float]:
    """Roll, pitch, yaw (rad) and the body rates p, q, r (rad/s) of a flight that rolls,
    pitches and turns (ZYX Euler kinematics); level and still on the ground."""
    if not _flying(t):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    phi, dphi = 0.3 * np.sin(1.3 * t), 0.39 * np.cos(1.3 * t)
    theta, dtheta = 0.2 * np.sin(0.9 * t + 0.5), 0.18 * np.cos(0.9 * t + 0.5)
    psi = (0.4 * (t - TAKEOFF_S) + np.pi) % (2 * np.pi) - np.pi
    dpsi = 0.4
    p = dphi - dpsi * np.sin(theta)
    q = dtheta * np.cos(phi) + dpsi * np.sin(phi) * np.cos(theta)
    r = -dtheta * np.sin(phi) + dpsi * np.cos(phi) * np.cos(theta)
    return phi, theta, psi, p, q, r


def _specific_force(phi: float, theta: float) -> tuple[float, float, float]:
    """FRD specific force of a vehicle at rest in the air (thrust balances weight)."""
    return (G * np.sin(theta), -G * np.sin(phi) * np.cos(theta),
            -G * np.cos(phi) * np.cos(theta))


def _height(t: float) -> tuple[float, float]:
    """Height (m, up) and climb rate (m/s) of a flight that climbs to 6 m and moves up and
    down by 3 m."""
    if not _flying(t):
        return 0.0, 0.0
    s = t - TAKEOFF_S
    return 6.0 + 3.0 * np.sin(0.3 * s) - 6.0 * np.exp(-s), 0.9 * np.cos(0.3 * s) + 6.0 * np.exp(-s)


def _quat(phi: float, theta: float, psi: float) -> tuple[float, ...]:
    return tuple(float(x) for x in euler_to_quat(np.array(phi), np.array(theta),
                                                   np.array(psi)))


def write_rates_ulog(path: Path, error: str = "deg") -> Path:
    """vehicle_angular_velocity (the preferred source) in deg/s (``error="deg"``) or with q
    of the wrong sign (``"sign_q"``); sensor_combined.gyro_rad sound; vehicle_attitude
    consistent with the true rates."""
    rng = np.random.default_rng(3)

    def rows(t: float) -> dict[str, tuple[float, ...]]:
        phi, theta, psi, p, q, r = _attitude(t)
        true = np.array([p, q, r]) + rng.normal(0.0, 0.01, 3)
        bad = true / DEG if error == "deg" else true * np.array([1.0, -1.0, 1.0])
        return {"vehicle_attitude": _quat(phi, theta, psi),
                "vehicle_angular_velocity": tuple(bad),
                "sensor_combined": (*true, *_specific_force(phi, theta)),
                "vehicle_land_detected": (not _flying(t),)}

    return write_ulog(path, [ATTITUDE, RATES, COMBINED, LANDED], rows,
                      {"vehicle_attitude": 50, "vehicle_angular_velocity": 100,
                       "sensor_combined": 100, "vehicle_land_detected": 2})


def test_a_gyro_in_deg_per_s_gives_way(tmp_path: Path) -> None:
    path = write_rates_ulog(tmp_path / "degs.ulg")
    table = read_log(path)
    for i, c in enumerate("pqr"):
        assert table.attrs["mapping"][c] == f"sensor_combined.gyro_rad[{i}]"
    note = next(w for w in table.attrs["warnings"] if w.startswith("p:"))
    assert "used sensor_combined.gyro_rad[0] by content, not " \
           "vehicle_angular_velocity.xyz[0]" in note
    assert "57.3 × the roll rate the attitude's derivative implies" in note
    assert "a unit error" in note
    assert table["p"].abs().max() < 1.0  # rad/s, not deg/s
    info = inspect_log(path)
    assert info["mapping"]["q"] == "sensor_combined.gyro_rad[1]"
    result = CliRunner().invoke(cli, ["inspect", str(path)])
    assert result.exit_code == 0, result.output
    assert "r: used sensor_combined.gyro_rad[2] by content" in result.output
    result = CliRunner().invoke(cli, ["ingest", str(path), "-o", str(tmp_path / "t.parquet")])
    assert result.exit_code == 0, result.output
    assert "note: q: used sensor_combined.gyro_rad[1] by content" in result.output


def test_a_gyro_axis_of_the_wrong_sign_gives_way(tmp_path: Path) -> None:
    """q of the wrong sign (FLU read as FRD): q switches, p and r keep their source."""
    path = write_rates_ulog(tmp_path / "sign.ulg", error="sign_q")
    table = read_log(path)
    assert table.attrs["mapping"]["q"] == "sensor_combined.gyro_rad[1]"
    assert table.attrs["mapping"]["p"] == "vehicle_angular_velocity.xyz[0]"
    assert table.attrs["mapping"]["r"] == "vehicle_angular_velocity.xyz[2]"
    note = next(w for w in table.attrs["warnings"] if w.startswith("q:"))
    assert "is -0.99" in note and "× the pitch rate" in note and "a sign or axis error" in note


def test_sound_rates_keep_their_priority(tmp_path: Path) -> None:
    """Both sources in rad/s: the preferred one stays, with no content note."""
    rng = np.random.default_rng(4)

    def rows(t: float) -> dict[str, tuple[float, ...]]:
        phi, theta, psi, p, q, r = _attitude(t)
        true = np.array([p, q, r]) + rng.normal(0.0, 0.01, 3)
        return {"vehicle_attitude": _quat(phi, theta, psi),
                "vehicle_angular_velocity": tuple(true),
                "sensor_combined": (*true, *_specific_force(phi, theta)),
                "vehicle_land_detected": (not _flying(t),)}

    path = write_ulog(tmp_path / "ok.ulg", [ATTITUDE, RATES, COMBINED, LANDED], rows,
                      {"vehicle_attitude": 10, "vehicle_angular_velocity": 100,
                       "sensor_combined": 100, "vehicle_land_detected": 2})
    table = read_log(path)
    assert table.attrs["mapping"]["p"] == "vehicle_angular_velocity.xyz[0]"
    assert not any("by content" in w or "anyway" in w for w in table.attrs["warnings"])


def write_height_ulog(path: Path, ranger: str) -> Path:
    """vehicle_local_position: z and vz of a flight that climbs and moves 3 m up and down,
    ``dist_bottom`` (preferred) valid throughout and ``ranger``: ``"sound"`` (the height
    plus 2 cm noise), ``"garbage"`` (a rangefinder that sees nothing useful: 0.5–1.5 m of
    noise) or ``"down"`` (the height with the sign of z)."""
    rng = np.random.default_rng(8)

    def rows(t: float) -> dict[str, tuple[float, ...]]:
        h, climb = _height(t)
        d = {"sound": h + rng.normal(0.0, 0.02), "garbage": rng.uniform(0.5, 1.5),
             "down": -h + rng.normal(0.0, 0.02)}[ranger]
        return {"vehicle_local_position": (-h + rng.normal(0.0, 0.02),
                                           -climb + rng.normal(0.0, 0.05), d,
                                           True, True, True),
                "vehicle_land_detected": (not _flying(t),)}

    return write_ulog(path, [LPOS, LANDED], rows,
                      {"vehicle_local_position": 50, "vehicle_land_detected": 2})


def test_a_height_that_does_not_follow_vz_gives_way(tmp_path: Path) -> None:
    table = read_log(write_height_ulog(tmp_path / "garbage.ulg", "garbage"))
    assert table.attrs["mapping"]["alt"] == "vehicle_local_position.z"
    note = next(w for w in table.attrs["warnings"] if w.startswith("alt:"))
    assert "by content, not vehicle_local_position.dist_bottom" in note
    assert "−vehicle_local_position.vz over the airborne part" in note
    air = table[(table.index > TAKEOFF_S + 10) & (table.index < LANDING_S - 5)]
    assert air["alt"].max() > 7.0  # the real height, not the ranger's 0.5–1.5 m


def test_a_height_of_the_wrong_sign_gives_way(tmp_path: Path) -> None:
    table = read_log(write_height_ulog(tmp_path / "down.ulg", "down"))
    assert table.attrs["mapping"]["alt"] == "vehicle_local_position.z"
    note = next(w for w in table.attrs["warnings"] if w.startswith("alt:"))
    assert "has a climb rate that is -1 ×" in note and "a sign or axis error" in note


def test_a_sound_range_finder_keeps_its_priority(tmp_path: Path) -> None:
    table = read_log(write_height_ulog(tmp_path / "sound.ulg", "sound"))
    assert table.attrs["mapping"]["alt"] == "vehicle_local_position.dist_bottom"
    assert not any(w.startswith("alt:") and "content" in w for w in table.attrs["warnings"])


def write_accel_ulog(path: Path, with_sensor_accel: bool = True) -> Path:
    """sensor_combined (preferred) with the accelerometer in g, sensor_accel in m/s²."""
    rng = np.random.default_rng(9)

    def rows(t: float) -> dict[str, tuple[float, ...]]:
        phi, theta, psi, p, q, r = _attitude(t)
        f = np.array(_specific_force(phi, theta)) + rng.normal(0.0, 0.3, 3)
        return {"vehicle_attitude": _quat(phi, theta, psi),
                "sensor_combined": (p, q, r, *(f / G)),
                "sensor_accel": tuple(f),
                "vehicle_land_detected": (not _flying(t),)}

    topics = [ATTITUDE, COMBINED, LANDED] + ([ACCEL] if with_sensor_accel else [])
    return write_ulog(path, topics, rows,
                      {"vehicle_attitude": 50, "sensor_combined": 100, "sensor_accel": 100,
                       "vehicle_land_detected": 2})


def test_a_specific_force_in_g_gives_way(tmp_path: Path) -> None:
    table = read_log(write_accel_ulog(tmp_path / "g.ulg"))
    for c, a in zip(("ax", "ay", "az"), "xyz", strict=True):
        assert table.attrs["mapping"][c] == f"sensor_accel.{a}"
    notes = table.attrs["warnings"]
    az = next(w for w in notes if w.startswith("az:"))
    assert "not sensor_combined.accelerometer_m_s2[2]" in az and "averages -0.9" in az
    ax = next(w for w in notes if w.startswith("ax:"))
    assert "shares its message (unit and frame) with sensor_combined.accelerometer_m_s2[2]" \
        in ax
    assert -10.5 < table["az"].mean() < -9.0


def test_a_lone_implausible_candidate_stays_with_a_note(tmp_path: Path) -> None:
    path = write_accel_ulog(tmp_path / "lone.ulg", with_sensor_accel=False)
    table = read_log(path)
    assert table.attrs["mapping"]["az"] == "sensor_combined.accelerometer_m_s2[2]"
    note = next(w for w in table.attrs["warnings"] if w.startswith("az:"))
    assert "it is the only candidate; used it anyway" in note
    result = CliRunner().invoke(cli, ["inspect", str(path)])
    assert "note: az: sensor_combined.accelerometer_m_s2[2] averages" in result.output


# the rules on hand-made signals -----------------------------------------------------------

def _sig(column: str, t: np.ndarray, v: np.ndarray, source: str, prio: int = 0) -> Signal:
    return Signal(column, t, np.asarray(v, dtype=float), source, prio)


def test_gain_and_misfit() -> None:
    rng = np.random.default_rng(1)
    ref = np.sin(np.linspace(0.0, 20.0, 200))
    sound = gain(0.9 * ref + rng.normal(0.0, 0.05, ref.size), ref, 0.05)
    assert sound is not None and abs(sound.k - 0.9) < 0.05 and misfit(sound) is None
    assert misfit(gain(57.3 * ref, ref, 0.05)) == "scale"
    assert misfit(gain(-ref, ref, 0.05)) == "gain"
    assert misfit(gain(0.1 * ref, ref, 0.05)) == "gain"
    noise = gain(rng.normal(0.0, 1.0, ref.size), ref, 0.05)
    assert noise is not None and noise.r < MIN_CORRELATION and misfit(noise) is not None
    # a k just inside the range but very uncertain is not condemned
    assert misfit(gain(GAIN_RANGE[0] * 0.9 * ref + rng.normal(0.0, 3.0, ref.size), ref,
                       0.05)) in (None, "follow")
    # too still a referee, or too few bins: not judged
    assert gain(57.3 * ref, 0.01 * ref, 0.05) is None
    assert gain(57.3 * ref[:10], ref[:10], 0.05) is None


def test_a_still_axis_follows_its_siblings_unit() -> None:
    """r in deg/s on a flight that never yaws: its own axis cannot tell, its siblings can."""
    t = np.arange(0.0, 60.0, 0.01)
    roll = 0.3 * np.sin(1.3 * t)
    zero = np.zeros_like(t)
    att = [_sig(c, t, v, "att.q") for c, v in (("roll", roll), ("pitch", zero),
                                                ("yaw", zero))]
    p_true = 0.39 * np.cos(1.3 * t)
    cands = {"p": [_sig("p", t, p_true / DEG, "rates.xyz[0]"),
                   _sig("p", t, p_true, "gyro.x", 2)],
             "r": [_sig("r", t, zero + 1e-3 * np.sin(50 * t) / DEG, "rates.xyz[2]"),
                   _sig("r", t, zero + 1e-3 * np.sin(50 * t), "gyro.z", 2)]}
    chosen, notes = choose_signals([*att, *cands["p"], *cands["r"]], [], Path("x"))
    assert chosen["p"].source == "gyro.x" and chosen["r"].source == "gyro.z"
    assert any("r: used gyro.z by content" in n and "shares its message (unit) with "
               "rates.xyz[0]" in n for n in notes)
    referee = Referee({c.column: c for c in att}, cands, (0.0, 60.0, "the log"))
    assert referee.judge("r", cands["r"][1]) is None


def test_no_referee_no_verdict() -> None:
    """Without attitude or vz nothing is judged against them: the order stays."""
    t = np.arange(0.0, 60.0, 0.01)
    p = _sig("p", t, 57.3 * np.sin(t), "rates.x")
    referee = Referee({}, {"p": [p]}, (0.0, 60.0, "the log"))
    assert referee.judge("p", p) is None
    assert referee.judge("alt", _sig("alt", t, np.sin(t), "rng")) is None


def test_damaged_samples_and_clocks_judge_nothing() -> None:
    """Samples ingest drops as implausible later (a gyro reading 1e30) do not condemn a
    sound source, and a damaged timestamp (a span of 30 years) is not binned at all."""
    t = np.arange(0.0, 60.0, 0.01)
    roll = 0.3 * np.sin(1.3 * t)
    zero = np.zeros_like(t)
    att = {c: _sig(c, t, v, "att.q") for c, v in (("roll", roll), ("pitch", zero),
                                                  ("yaw", zero))}
    p = 0.39 * np.cos(1.3 * t)
    damaged = p.copy()
    damaged[::500] = 1e30
    sound = _sig("p", t, damaged, "rates.xyz[0]")
    assert Referee(att, {"p": [sound]}, (0.0, 60.0, "the log")).judge("p", sound) is None
    deg = _sig("p", t, p / DEG, "rates.xyz[0]")
    assert "57.3 ×" in Referee(att, {"p": [deg]}, (0.0, 60.0, "the log")).judge("p", deg)
    stray = _sig("p", np.append(t, 1e9), np.append(p / DEG, 0.0), "rates.xyz[0]")
    assert Referee(att, {"p": [stray]}, (0.0, 1e9, "the log")).judge("p", stray) is None
    g = _sig("az", t, np.where(np.arange(t.size) % 100, -G, 1e30), "imu.z")
    assert Referee(att, {"az": [g]}, (0.0, 60.0, "the log")).judge("az", g) is None


def test_compiled_bin_means_equal_numpys(monkeypatch: pytest.MonkeyPatch) -> None:
    """The one-pass binning (numba loaded) gives the bin means of numpy's masks and
    ``bincount``, bit for bit: NaN and implausible samples, times outside the edges, on an
    edge and at the last edge, unordered times."""
    import sys

    import numba  # noqa: F401  (the compiled pass runs once numba is loaded)

    from etsid.ingest.source_consistency import BIN_KERNEL_MIN, bin_means

    rng = np.random.default_rng(8)
    for case in range(20):
        n = BIN_KERNEL_MIN + int(rng.integers(1, 20000))
        t = np.sort(rng.uniform(-5.0, 65.0, n))
        if case % 3 == 0:
            t = np.round(t * 2.0) / 2.0  # on the edges
        if case % 4 == 0:
            t = rng.permutation(t)
        v = rng.normal(0.0, 1.0, n) * rng.choice([1e-3, 1.0, 1e3])
        v[rng.integers(0, n, 30)] = np.nan
        v[rng.integers(0, n, 30)] = 1e6  # beyond the limits of p
        t[rng.integers(0, n, 5)] = np.nan
        sig = Signal("p", t, v, "TEST.p", 0)
        edges = 0.5 * np.arange(int(rng.integers(2, 120)) + 1)
        got = bin_means(sig, edges)
        with monkeypatch.context() as patch:
            patch.delitem(sys.modules, "numba")
            want = bin_means(sig, edges)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))
