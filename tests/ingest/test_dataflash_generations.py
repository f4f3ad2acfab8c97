"""Airborne detection on ArduCopter DataFlash logs of each generation (3.1–4.x).

Each log is built byte by byte in the generation's own layout (read back by pymavlink's
DFReader, the real reader) with the ``EV`` ids that generation writes
(ArduCopter/defines.h ``DATA_*``; AP_Logger ``LogEvent`` in 4.x): 3.1–3.2 log
``DATA_TAKEOFF`` (16) at lift-off in the manual-throttle modes and never clear the
land-complete flag there; 3.3 on log ``DATA_NOT_LANDED`` (28). Untimed ``EV``/``ATT``/
``CTUN`` in 3.1, ``TimeMS`` up to 3.3, ``TimeUS`` from 3.4, ``CTUN.ThrOut`` 0…1000 up to
3.3 and ``ThO`` 0…1 later, ``ARM`` messages in 4.x. The flight is the same in each: armed at
5 s, lift-off at 8 s, 5 m, touch-down at 55 s, disarmed at 58 s, 62 s of log."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from etsid.ident.flight import select_flight
from etsid.ingest import read_log, read_raw

HEAD = b"\xa3\x95"
_STRUCT = {"Q": "Q", "I": "I", "f": "f", "h": "h", "c": "h", "C": "H", "B": "B",
           "e": "i", "H": "H"}
ARM_T, LIFT_T, DOWN_T, DISARM_T, END_T = 5.0, 8.0, 55.0, 58.0, 62.0


def _fmt(mtype: int, name: str, fmt: str, columns: str) -> bytes:
    length = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
    return HEAD + bytes([0x80]) + struct.pack("<BB4s16s64s", mtype, length, name.encode(),
                                               fmt.encode(), columns.encode())


def _msg(mtype: int, fmt: str, *values: float) -> bytes:
    return HEAD + bytes([mtype]) + struct.pack("<" + "".join(_STRUCT[c] for c in fmt),
                                               *values)


def _height(t: float) -> float:
    """Barometric height above the arming point, m."""
    if t < LIFT_T or t > DOWN_T:
        return 0.0
    return 5.0 * min(1.0, (t - LIFT_T) / 2.0, (DOWN_T - t) / 2.0)


def _throttle(t: float) -> float:
    """Throttle to the motors, 0…1."""
    if t < ARM_T or t >= DISARM_T:
        return 0.0
    return 0.5 if LIFT_T - 0.5 <= t <= DOWN_T + 0.5 else 0.12


def write_generation(path: Path, generation: str, events: list[tuple[float, int]]) -> Path:
    """A 62 s ArduCopter log of ``generation`` (``3.1``, ``3.3``, ``3.4``, ``4.0``) with EV
    ``events`` (time s, id)."""
    us = generation in ("3.4", "4.0")
    tcol, tfmt = ("TimeUS,", "Q") if us else ("TimeMS,", "I")
    out = bytearray()
    out += _fmt(140, "IMU", tfmt + "ffffff", tcol + "GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
    if generation == "3.1":
        out += _fmt(141, "ATT", "cccccCC", "RollIn,Roll,PitchIn,Pitch,YawIn,Yaw,NavYaw")
        out += _fmt(142, "CTUN", "hhefhhhhh",
                    "ThrIn,SonAlt,BarAlt,WPAlt,NavThr,AngBst,CRate,ThrOut,DCRate")
    else:
        out += _fmt(141, "ATT", tfmt + "ccccCC", tcol + "DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw")
        out += (_fmt(142, "CTUN", tfmt + "fffff", tcol + "ThI,ABst,ThO,ThH,BAlt") if us else
                _fmt(142, "CTUN", tfmt + "hhhf", tcol + "ThrIn,AngBst,ThrOut,BarAlt"))
    out += _fmt(143, "EV", (tfmt + "B") if us else "B", (tcol + "Id") if us else "Id")
    if generation == "4.0":
        out += _fmt(144, "ARM", "QBH", "TimeUS,ArmState,ArmChecks")
    rng = np.random.default_rng(3)
    pending = sorted(events)
    armed = False
    for k in range(int(END_T * 50)):
        t = k / 50.0
        stamp = int(t * 1e6) if us else int(t * 1e3)
        flying = LIFT_T <= t <= DOWN_T
        gyro = rng.normal(0.0, 0.003, 3) + (0.3 * np.sin(2.1 * t) if flying else 0.0)
        out += _msg(140, tfmt + "ffffff", stamp, *gyro, 0.0, 0.0, -9.81)
        if k % 5 == 0:  # ATT and CTUN at 10 Hz
            roll = float(np.degrees(0.1 * np.sin(2.1 * t))) if flying else 0.0
            thr, alt = _throttle(t), _height(t) + rng.normal(0.0, 0.05)
            if generation == "3.1":
                out += _msg(141, "cccccCC", 0, int(roll * 100), 0, 0, 0, 0, 0)
                out += _msg(142, "hhefhhhhh", int(thr * 1000), 0, int(alt * 100), 0.0, 0, 0,
                            0, int(thr * 1000), 0)
            else:
                out += _msg(141, tfmt + "ccccCC", stamp, 0, int(roll * 100), 0, 0, 0, 0)
                if us:
                    out += _msg(142, tfmt + "fffff", stamp, thr, 0.0, thr, 0.4, alt)
                else:
                    out += _msg(142, tfmt + "hhhf", stamp, int(thr * 1000), 0,
                                int(thr * 1000), alt)
        while pending and pending[0][0] <= t:
            _, ev = pending.pop(0)
            out += _msg(143, tfmt + "B", stamp, ev) if us else _msg(143, "B", ev)
        if generation == "4.0" and armed != (ARM_T <= t < DISARM_T):
            armed = not armed
            out += _msg(144, "QBH", stamp, int(armed), 0)
    path.write_bytes(bytes(out))
    return path


GENERATIONS = {
    # 3.1 in Stabilize: LAND_COMPLETE at boot, ARMED, AUTO_ARMED, TAKEOFF at lift-off,
    # no NOT_LANDED and no LAND_COMPLETE at touch-down (the detector does not run there)
    "3.1": [(1.0, 18), (ARM_T, 10), (ARM_T + 0.5, 15), (LIFT_T, 16), (DISARM_T, 11)],
    # 3.3: NOT_LANDED at lift-off, LAND_COMPLETE one second after touch-down
    "3.3": [(ARM_T, 10), (ARM_T + 0.5, 15), (LIFT_T, 28), (DOWN_T + 1.0, 18),
            (DISARM_T, 11)],
    # 3.4 with LAND_COMPLETE_MAYBE (17) before LAND_COMPLETE
    "3.4": [(ARM_T, 10), (ARM_T + 0.5, 15), (LIFT_T, 28), (DOWN_T + 0.3, 17),
            (DOWN_T + 1.0, 18), (DISARM_T, 11)],
    "4.0": [(ARM_T, 10), (ARM_T + 0.5, 15), (LIFT_T, 28), (DOWN_T + 0.3, 17),
            (DOWN_T + 1.0, 18), (DISARM_T, 11)],
}


@pytest.mark.parametrize("generation", sorted(GENERATIONS))
def test_each_generation_finds_the_flight(tmp_path: Path, generation: str) -> None:
    path = write_generation(tmp_path / f"copter{generation}.bin", generation,
                            GENERATIONS[generation])
    table = read_log(path)
    assert table.attrs["mapping"]["landed"] == "EV.Id"
    sel = select_flight(table)
    assert sel.method.startswith("land detector")
    assert len(sel.windows) == 1
    t0, t1 = sel.windows[0]
    assert LIFT_T <= t0 <= LIFT_T + 1.5  # lift-off plus the documented 1 s margin
    assert DOWN_T - 1.0 <= t1 <= DOWN_T + 2.5  # the detector lags touch-down by ≤ 1 s


@pytest.mark.parametrize("generation", ["3.1", "3.3", "3.4"])
def test_ctun_throttle_is_read_in_the_generations_unit(tmp_path: Path, generation: str
                                                       ) -> None:
    path = write_generation(tmp_path / "c.bin", generation, GENERATIONS[generation])
    thr = next(s for s in read_raw(path).signals if s.source.startswith("CTUN.Th"))
    assert thr.source == ("CTUN.ThO" if generation == "3.4" else "CTUN.ThrOut")
    hover = thr.values[(thr.t > LIFT_T + 1) & (thr.t < DOWN_T - 1)]
    assert np.allclose(hover, 0.5, atol=1e-3)  # 500/1000 up to 3.3, 0.5 from 3.4


def test_land_complete_without_a_take_off_event_is_no_land_detector(tmp_path: Path) -> None:
    """3.1 flown where neither TAKEOFF nor NOT_LANDED is written (LAND_COMPLETE at boot,
    armed, disarmed): before this issue the flight was refused ("no airborne sample"); the
    events are now its armed state and the climb above the arming level finds the flight."""
    path = write_generation(tmp_path / "c31.bin", "3.1",
                            [(1.0, 18), (ARM_T, 10), (DISARM_T, 11)])
    table = read_log(path)
    assert table.attrs["mapping"]["landed"] == "EV.Id (armed)"
    sel = select_flight(table)
    assert sel.method.startswith("armed state")
    t0, t1 = sel.windows[0]
    assert LIFT_T <= t0 <= LIFT_T + 1.5 and DOWN_T - 1.5 <= t1 <= DOWN_T + 0.5


def test_a_detector_that_never_says_airborne_gives_way_to_the_rule(tmp_path: Path) -> None:
    """A land detector that says *landed* wherever it has a value (here the 3.4 log's with
    its take-off event lost) is not trusted: the thrust rule (CTUN.ThO, the only thrust
    command of the log) finds the flight and the method says why."""
    path = write_generation(tmp_path / "cut.bin", "3.4", GENERATIONS["3.4"])
    table = read_log(path)
    assert table.attrs["mapping"]["landed"] == "EV.Id"
    landed = table["landed"].to_numpy(dtype=float)
    table["landed"] = np.where(np.isfinite(landed), 1.0, np.nan)
    sel = select_flight(table)
    assert "never says airborne" in sel.method
    t0, t1 = sel.windows[0]
    assert t0 == pytest.approx(LIFT_T - 0.5, abs=0.3) and t1 == pytest.approx(DOWN_T + 0.5,
                                                                                abs=0.3)
