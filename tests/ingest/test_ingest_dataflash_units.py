"""DataFlash units per message and field (ArduPilot log-message documentation,
https://ardupilot.org/copter/docs/logmessages.html) and the choice of the fastest body-rate
source, on a log built byte by byte as ArduCopter writes it."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from etsid.ingest import read_log, read_raw

HEAD = b"\xa3\x95"
DEG = np.pi / 180.0

# message, field → (value written, value expected in the signal): deg → rad, deg/s → rad/s,
# rad/s, m/s² and the −1…1 controller outputs stay as written
FIELDS = {
    ("RATE", "R"): (57.0, 57.0 * DEG), ("RATE", "P"): (-20.0, -20.0 * DEG),
    ("RATE", "Y"): (10.0, 10.0 * DEG), ("RATE", "RDes"): (50.0, 50.0 * DEG),
    ("RATE", "PDes"): (-15.0, -15.0 * DEG), ("RATE", "YDes"): (8.0, 8.0 * DEG),
    ("RATE", "ROut"): (0.1, 0.1), ("RATE", "POut"): (-0.2, -0.2),
    ("RATE", "YOut"): (0.05, 0.05), ("RATE", "AOut"): (0.45, 0.45),
    ("ATT", "Roll"): (12.0, 12.0 * DEG), ("ATT", "Pitch"): (-5.0, -5.0 * DEG),
    ("ATT", "Yaw"): (270.0, -90.0 * DEG), ("ATT", "DesRoll"): (10.0, 10.0 * DEG),
    ("ATT", "DesPitch"): (-4.0, -4.0 * DEG), ("ATT", "DesYaw"): (350.0, -10.0 * DEG),
    ("IMU", "GyrX"): (0.9, 0.9), ("IMU", "GyrY"): (-0.3, -0.3), ("IMU", "GyrZ"): (0.2, 0.2),
    ("IMU", "AccX"): (0.5, 0.5), ("IMU", "AccZ"): (-9.8, -9.8),
}
LAYOUT = {
    "RATE": (130, "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut,ADes,A,AOut", 10),
    "ATT": (131, "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw", 25),
    "IMU": (132, "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ", 50),
}


def _fmt_msg(mtype: int, name: str, columns: str) -> bytes:
    n = columns.count(",")
    length = 3 + 8 + 4 * n
    return HEAD + bytes([0x80]) + struct.pack("<BB4s16s64s", mtype, length, name.encode(),
                                              ("Q" + "f" * n).encode(), columns.encode())


def write_copter_bin(path: Path, seconds: float = 4.0) -> Path:
    out = bytearray()
    for name, (mtype, columns, _) in LAYOUT.items():
        out += _fmt_msg(mtype, name, columns)
    events = sorted((k / hz, name) for name, (_, _, hz) in LAYOUT.items()
                    for k in range(int(seconds * hz)))
    for t, name in events:
        mtype, columns, _ = LAYOUT[name]
        values = [FIELDS.get((name, f), (0.0, 0.0))[0] for f in columns.split(",")[1:]]
        out += HEAD + bytes([mtype]) + struct.pack("<Q" + "f" * len(values),
                                                   int(1e6 * (5.0 + t)), *values)
    path.write_bytes(bytes(out))
    return path


@pytest.fixture(scope="module")
def copter_bin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_copter_bin(tmp_path_factory.mktemp("df") / "copter.bin")


@pytest.mark.parametrize("key", sorted(FIELDS), ids=lambda k: f"{k[0]}.{k[1]}")
def test_field_unit(copter_bin: Path, key: tuple[str, str]) -> None:
    signals = {s.source: s for s in read_raw(copter_bin).signals}
    source = f"{key[0]}.{key[1]}"
    assert source in signals, sorted(signals)
    np.testing.assert_allclose(signals[source].values, FIELDS[key][1], rtol=1e-6, atol=1e-7)


def test_body_rates_from_the_fast_imu_not_the_10_hz_rate_message(copter_bin: Path) -> None:
    table = read_log(copter_bin)
    assert table.attrs["mapping"]["p"] == "IMU.GyrX"
    assert table.attrs["rate_hz"] == pytest.approx(50.0, rel=0.02)
    assert table["p"].abs().max() == pytest.approx(0.9, rel=1e-6)  # rad/s, not 57 "rad/s"
    assert table.attrs["mapping"]["sp_roll"] == "ATT.DesRoll"
    np.testing.assert_allclose(table["sp_yaw"].dropna(), -10.0 * DEG, rtol=1e-6)
