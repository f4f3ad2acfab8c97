"""Airborne segments, validation inside excited flight, free-run divergence: a simulated
flight with take-off, a low pass (in ground effect), a high pass and landing, assembled
from the simulator's scenarios with ground time around and between them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify
from etsid.ident.flight import (
    LAND_MARGIN_S,
    apply_selection,
    clean_mask,
    parse_windows,
    select_flight,
    trim_edges,
)
from etsid.ident.regressors import RegressorSpec, build
from etsid.ident.simulate import envelope, free_run
from etsid.sim import simulate

RATE = 250.0


def _ground(seconds: float, rng: np.random.Generator, like: pd.DataFrame) -> pd.DataFrame:
    n = int(seconds * RATE)
    frame = pd.DataFrame({c: np.zeros(n) for c in like.columns})
    for c in ("p", "q", "r"):
        frame[c] = 0.002 * rng.normal(size=n)  # still on the ground: sensor noise only
    frame["az"] = -9.81
    frame["vbat"] = like["vbat"].iloc[0]
    return frame


def flight_with_ground(landed_column: bool) -> tuple[pd.DataFrame, list[tuple[float, float]]]:
    """ground 4 s, low pass 20 s, ground 3 s, high pass 20 s, ground 4 s (250 Hz)."""
    rng = np.random.default_rng(7)
    low = simulate("hover-ige", duration=20.0, seed=31).table
    high = simulate("hover-oge", duration=20.0, seed=32).table
    parts, air, landed = [], [], []
    for piece, is_air in ((_ground(4, rng, low), False), (low, True), (_ground(3, rng, low), False),
                          (high, True), (_ground(4, rng, low), False)):
        frame = piece.reset_index(drop=True)[list(low.columns)]
        parts.append(frame)
        landed.append(np.full(len(frame), 0.0 if is_air else 1.0))
    table = pd.concat(parts, ignore_index=True)
    t = np.arange(len(table)) / RATE
    table.index = pd.Index(t, name="t")
    if landed_column:
        table["landed"] = np.concatenate(landed)
    edges = np.cumsum([0] + [len(p) for p in parts]) / RATE
    air = [(edges[1], edges[2]), (edges[3], edges[4])]
    table.attrs = dict(low.attrs)
    return table, air


@pytest.fixture(scope="module")
def flight() -> tuple[pd.DataFrame, list[tuple[float, float]]]:
    return flight_with_ground(landed_column=True)


@pytest.mark.parametrize("landed_column", [True, False], ids=["detector", "thrust-rule"])
def test_airborne_segments_found(landed_column: bool) -> None:
    table, air = flight_with_ground(landed_column)
    sel = select_flight(table, "auto")
    # a land detector without its touch-down stages loses LAND_MARGIN_S at each edge
    margin = LAND_MARGIN_S if landed_column else 0.0
    assert sel.method == ("land detector, 1 s margins" if landed_column else "rule (thrust)")
    assert len(sel.windows) == 2
    for (a, b), (t0, t1) in zip(sel.windows, air, strict=True):
        assert a == pytest.approx(t0 + margin, abs=0.05)
        assert b == pytest.approx(t1 - margin, abs=0.05)
    kept = apply_selection(table, sel)
    assert kept["segment"].unique().tolist() == [0, 1]


def test_ground_contact_stages_are_ground() -> None:
    # PX4's detector: "airborne" while still on the legs after throttle-up (0.8 s here), and
    # ground contact, a flicker back to flying and maybe-landed before "landed" (1.6 s)
    table, air = flight_with_ground(landed_column=True)
    t = table.index.to_numpy()
    contact = np.zeros(len(t))
    for t0, t1 in air:
        contact[(t >= t0) & (t < t0 + 0.8)] = 1.0
        contact[(t >= t1 - 1.6) & (t < t1)] = 1.0
        contact[(t >= t1 - 1.3) & (t < t1 - 1.1)] = 0.0  # 0.2 s flicker: not filled
    table["ground_contact"] = contact
    sel = select_flight(table, "auto")
    assert sel.method == "land detector + ground contact"
    for (a, b), (t0, t1) in zip(sel.windows, air, strict=True):
        assert a == pytest.approx(t0 + 0.8, abs=0.01)
        assert b == pytest.approx(t1 - 1.6, abs=0.01)


def test_trim_edges_keeps_the_log_ends() -> None:
    t = np.arange(1000) / 100.0  # 10 s
    mask = np.zeros(1000, dtype=bool)
    mask[:300] = True  # airborne from the log start: only its landing edge is trimmed
    mask[500:] = True  # airborne until the log end: only its take-off edge
    out = trim_edges(mask, t, 1.0)
    assert np.flatnonzero(out[:500]).max() == 199
    assert np.flatnonzero(out).min() == 0 and out[-1]
    assert np.flatnonzero(out[500:]).min() + 500 == 600


def test_identify_learns_and_validates_on_airborne_rows_only(flight) -> None:
    table, air = flight
    run = identify(table, IdentConfig())
    pred = run.predictions
    inside = np.zeros(len(pred), dtype=bool)
    for t0, t1 in air:
        inside |= (pred["t"] >= t0) & (pred["t"] <= t1)
    assert inside.all()  # no learning or validation sample on the ground
    m = run.metrics
    assert m["flight"]["airborne_s"] == pytest.approx(40.0 - 4 * LAND_MARGIN_S, abs=0.2)
    assert m["flight"]["excited_s"] > 25.0
    # validation starts inside the second pass and holds 30 % of the excited time
    assert air[1][0] < m["validation"]["t_start"] < air[1][1]
    assert m["validation"]["excited_s"] == pytest.approx(0.3 * m["flight"]["excited_s"],
                                                         rel=0.05)
    for y in ("p", "q", "r"):
        out = m["outputs"][y]
        assert out["validation"]["one_step"]["rmse"] < out["persistence"]["validation"]["rmse"]
        free = out["validation"]["free_run"]
        assert free["diverged"] is False
        assert [s["segment"] for s in free["segments"]] == [1]
        assert free["segments"][0]["fit"] > 50.0
    # with --segments all the ground time is learned too and the airborne note disappears
    every = identify(table, IdentConfig(segments="all"))
    assert every.metrics["flight"]["airborne_s"] > 50.0


def test_predict_uses_the_same_airborne_rows(flight, tmp_path: Path) -> None:
    from etsid.ident import predict
    from etsid.ident.rundir import write_run

    table, air = flight
    run = identify(table, IdentConfig())
    write_run(run, tmp_path / "run")
    t_start = run.metrics["validation"]["t_start"]
    again = predict(table, tmp_path / "run", sim_from=t_start)
    pred = again.predictions
    inside = np.zeros(len(pred), dtype=bool)
    for t0, t1 in air:
        inside |= (pred["t"] >= t0) & (pred["t"] <= t1)
    assert inside.all()
    assert again.metrics["flight"]["method"] == run.metrics["flight"]["method"]
    np.testing.assert_array_equal(pred["t"], run.predictions["t"])
    val = pred["part"] == "validation"
    np.testing.assert_allclose(pred.loc[val, "p_val"], run.predictions.loc[val, "p_val"],
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(pred.loc[val, "q_sim"], run.predictions.loc[val, "q_sim"],
                               rtol=1e-9, atol=1e-12)
    every = predict(table, tmp_path / "run", segments="all")
    assert (~np.isin(every.predictions["t"], pred["t"])).sum() > 500  # ground rows too
    window = predict(table, tmp_path / "run", segments=f"{air[1][0]}:{air[1][1]}")
    assert window.predictions["t"].min() >= air[1][0]
    with pytest.raises(IdentError, match="no airborne"):
        predict(table[table.index < air[0][0]], tmp_path / "run")


def test_ground_only_log_is_refused_in_one_line(flight) -> None:
    table, air = flight
    ground = table[table.index < air[0][0]]
    with pytest.raises(IdentError, match="no airborne sample"):
        identify(ground, IdentConfig())


def test_segment_windows_and_cleaning() -> None:
    assert parse_windows("1:2, 3.5:7") == [(1.0, 2.0), (3.5, 7.0)]
    with pytest.raises(IdentError, match="T0:T1"):
        parse_windows("3-4")
    with pytest.raises(IdentError, match="after the start"):
        parse_windows("4:3")
    t = np.arange(1000) / 100.0
    mask = (t > 1) & (t < 8)
    mask[300:320] = False  # 0.2 s ground blip inside the flight: filled
    mask[950:] = True  # 0.5 s hop at the end: dropped
    cleaned = clean_mask(mask, t)
    assert cleaned[300:320].all() and not cleaned[950:].any()


def test_free_run_stops_at_divergence_and_says_when() -> None:
    # y_k = 0.5 y_{k-1} + u_{k-1}; a model with pole 1.3 explodes in free run
    n = 300
    u = np.sin(0.3 * np.arange(n))
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + u[k - 1]
    seg = np.r_[np.zeros(150, dtype=int), np.ones(150, dtype=int)]
    frame = pd.DataFrame({"y": y, "u": u, "segment": seg},
                         index=pd.Index(np.arange(n) * 0.1, name="t"))
    spec = RegressorSpec.parse("y[k-1],u[k-1]", ["y"])
    reg = build(frame, spec)
    unstable = lambda x: np.array([1.3 * x[0] + x[1]])  # noqa: E731
    diverged: list[float] = []
    sim = free_run(unstable, reg, spec, 10, n, envelope(reg.Y), diverged)
    assert len(diverged) == 2  # once per segment, each restarted from measured values
    lo, hi = envelope(reg.Y)
    assert np.nanmax(sim) <= hi[0] and np.nanmin(sim) >= lo[0]
    first = int(np.searchsorted(reg.t[10:], diverged[0]))
    assert np.isfinite(sim[first - 1, 0]) and np.isnan(sim[first:first + 5, 0]).all()
    assert diverged[0] < 15.0 < diverged[1]


def test_coarse_log_is_refused_in_one_line() -> None:
    table = simulate("hover-oge", duration=20.0, seed=33).table.iloc[::50].copy()  # 5 Hz
    table.attrs["rate_hz"] = 5.0
    with pytest.raises(IdentError, match=r"body rates at 5 Hz .*too coarse for the rate loop"):
        identify(table, IdentConfig())


LOWRATE = Path(__file__).parents[1] / "data" / "px4_quad_mission_lowrate_real.ulg"


def test_real_low_rate_px4_log_is_refused() -> None:
    from etsid.ident.inputs import load_for_ident

    with pytest.raises(IdentError, match=r"8.6 Hz \(sensor_combined.gyro_rad\[0\]\)"):
        identify(load_for_ident(LOWRATE), IdentConfig())
