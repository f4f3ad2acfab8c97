"""Armed-state logs (``landed`` = MAVLink HEARTBEAT armed flag): a log that starts already
flying in a low hover keeps its low dwells; a log that shows the arming on the ground, or
starts armed but standing still, keeps the arming-level rule."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.ident.flight import ALT_AIR_M, select_flight, starts_flying
from etsid.sim import simulate

RATE = 250.0


@pytest.fixture(scope="module")
def low_start() -> pd.DataFrame:
    """ige-oge, 32 s at 250 Hz: a 0.25 m hover from the first sample, then the climb to
    1 m and a dwell there."""
    return simulate("ige-oge", duration=32.0, seed=5).table


def _armed_log(flight: pd.DataFrame, before: list[tuple[float, float, float]]
               ) -> tuple[pd.DataFrame, float]:
    """``flight`` preceded by ground pieces (seconds, landed 1/0, thrust) standing still;
    ``landed`` is the armed state (1 disarmed, NaN before the first heartbeat). Returns the
    table and the time the flight starts."""
    rng = np.random.default_rng(3)
    parts = []
    for seconds, landed, thrust in before:
        n = int(seconds * RATE)
        frame = pd.DataFrame({c: np.zeros(n) for c in flight.columns})
        for c in ("p", "q", "r"):
            frame[c] = 0.002 * rng.normal(size=n)  # on its legs: sensor noise only
        frame["az"] = -9.81
        frame["u_thrust"] = thrust
        frame["alt"] = 0.1  # the rangefinder sees the ground
        frame["vbat"] = flight["vbat"].iloc[0]
        frame["landed"] = landed
        parts.append(frame)
    air = flight.reset_index(drop=True).copy()
    air["landed"] = 0.0
    parts.append(air[list(parts[0].columns) if parts else list(air.columns)])
    table = pd.concat(parts, ignore_index=True)
    table.index = pd.Index(np.arange(len(table)) / RATE, name="t")
    table.loc[table.index < 0.3, "landed"] = np.nan  # no heartbeat yet
    table.attrs = dict(flight.attrs)
    table.attrs["mapping"] = {"landed": "HEARTBEAT.base_mode"}
    t_air = sum(p[0] for p in before)
    return table, t_air


def test_log_starting_in_low_hover_keeps_its_low_dwell(low_start: pd.DataFrame) -> None:
    table, _ = _armed_log(low_start, [])
    sel = select_flight(table)
    assert sel.method == "armed state + rule (thrust): log starts flying"
    # every armed row is kept: the 0.25 m hover from 0.3 s on, the climb and the 1 m dwell
    assert len(sel.windows) == 1
    assert sel.windows[0][0] == pytest.approx(0.3, abs=0.01)
    assert sel.windows[0][1] == pytest.approx(table.index[-1])
    low = table["alt"].to_numpy() < 0.4
    assert sel.keep[low & (table.index.to_numpy() >= 0.3)].all()


def test_arming_in_the_log_keeps_the_arming_level_rule(low_start: pd.DataFrame) -> None:
    # disarmed 2 s, armed on its legs at mid-throttle 3 s (an altitude-hold stick), then
    # the same flight: the arming level is the ground, the low hover is below its 0.5 m
    table, t_air = _armed_log(low_start, [(2.0, 1.0, 0.0), (3.0, 0.0, 0.5)])
    armed = np.nan_to_num(table["landed"].to_numpy(), nan=1.0) < 0.5
    assert not starts_flying(table, armed, int(np.flatnonzero(armed)[0]))
    sel = select_flight(table)
    assert sel.method == "armed state + altitude above arming level"
    alt = table["alt"].to_numpy()
    assert not sel.keep[table.index.to_numpy() < t_air].any()
    assert sel.keep[alt > 0.1 + ALT_AIR_M + 0.05].all()


@pytest.mark.parametrize("why", ["still", "idle", "contact"])
def test_log_starting_armed_on_the_ground_is_not_flying(low_start: pd.DataFrame,
                                                        why: str) -> None:
    # armed from the first heartbeat but on the ground for 3 s: standing still at
    # mid-throttle, idling, or moving with the land detector's ground contact set
    thrust = 0.08 if why == "idle" else 0.5
    table, t_air = _armed_log(low_start, [(3.0, 0.0, thrust)])
    t = table.index.to_numpy()
    if why == "contact":
        ground = t < t_air
        table.loc[ground, "p"] = 0.05 * np.sin(2 * np.pi * 3 * t[ground])  # a taxi's bumps
        table["ground_contact"] = (t < t_air).astype(float)
    armed = np.nan_to_num(table["landed"].to_numpy(), nan=1.0) < 0.5
    assert not starts_flying(table, armed, int(np.flatnonzero(armed)[0]))
    sel = select_flight(table)
    assert "log starts flying" not in sel.method
    assert not sel.keep[t < t_air].any()
