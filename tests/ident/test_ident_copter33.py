"""The real ArduCopter 3.3 flight (tests/data/ardupilot_copter33_loiter_acro_flips_real.bin):
an older DataFlash generation read for identification — untimed EV events, GPS time of
week, RATE in centidegrees/s, RCOU ``Ch1…``, altitude only in CTUN.BarAlt/BARO — and a
flight that ends with an upset (the vehicle on its back from ~229.5 s)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from etsid.ident import IdentConfig, identify
from etsid.ident.flight import select_flight
from etsid.ingest import read_log, read_raw

LOG = Path(__file__).parents[1] / "data" / "ardupilot_copter33_loiter_acro_flips_real.bin"


@pytest.fixture(scope="module")
def table():
    return read_log(LOG)


def test_old_generation_signals_are_read(table) -> None:
    mapping = table.attrs["mapping"]
    assert mapping["alt"] == "CTUN.BarAlt"
    assert mapping["landed"] == "EV.Id"  # land detector (NOT_LANDED event), not armed state
    assert [mapping[f"m{i}"] for i in range(1, 5)] == [f"RCOU.Ch{i}" for i in range(1, 5)]
    t = np.asarray(table.index, dtype=float)
    assert t[-1] - t[0] == pytest.approx(242.6, abs=0.5)  # GPS time of week no longer a time
    landed = table["landed"].to_numpy()
    lift = t[np.flatnonzero(np.nan_to_num(landed, nan=1.0) < 0.5)[0]]
    assert 70.0 < lift < 72.5  # EV NOT_LANDED, timed by its place in the file


def test_rate_message_in_centidegrees_matches_the_gyro() -> None:
    raw = read_raw(LOG)
    sig = {s.source: s for s in raw.signals if s.column == "p"}
    rate, imu = sig["RATE.R"], sig["IMU.GyrX"]
    gyro = np.interp(rate.t, imu.t, imu.values)
    inside = (rate.t > 75) & (rate.t < 220)
    ratio = np.std(rate.values[inside]) / np.std(gyro[inside])
    assert 0.7 < ratio < 1.4  # deg/s would be 100× off


def test_flight_ends_before_the_upset(table) -> None:
    sel = select_flight(table)
    assert "upset cut" in sel.method
    (t0, t1), = sel.windows
    assert 72.0 < t0 < 73.0 and 225.0 < t1 < 227.5


def test_identify_beats_no_change_and_matches_arx_on_informative_axes(table) -> None:
    run = identify(table, IdentConfig())
    for out in ("p", "q", "r"):
        block = run.metrics["outputs"][out]
        one = block["validation"]["one_step"]
        if one.get("informative", True):
            assert one["rmse"] <= block["persistence"]["validation"]["rmse"]
            assert one["rmse"] <= 1.02 * block["arx"]["validation"]["one_step"]["rmse"]


def test_without_altitude_the_events_still_find_the_flight_and_no_schedule_is_offered(
        table) -> None:
    bare = table.drop(columns=["alt"])
    bare.attrs = dict(table.attrs)
    sel = select_flight(bare)
    assert sel.windows == select_flight(table).windows  # EV land detector + upset, no alt
    run = identify(bare, IdentConfig())
    block = run.metrics["structure"]
    assert block["chosen"] in ("arx", "unscheduled")
    assert "eTS scheduled" not in block["validation"]
    assert {"eTS one rule", "eTS unscheduled", "ARX", "no-change"} <= set(block["validation"])
