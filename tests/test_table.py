"""The FlightTable contract: validation, storage round trips, alignment rules."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from etsid.errors import IngestError, TableError
from etsid.frames import (
    enu_flu_quat_to_ned_frd_euler,
    matrix_to_euler,
    ned_frd_euler_to_enu_flu_quat,
    quat_to_euler,
    quat_to_matrix,
)
from etsid.ingest.align import (
    build_table,
    find_gaps,
    hold_index,
    interpolation,
    native_period,
    resample,
)
from etsid.ingest.base import Override, RawLog, Signal, get_field
from etsid.ingest.mapping import choose_signals, load_mapping_file, parse_override
from etsid.table import load_table, save_table, validate


def frame(t: list[float], **cols: list[float]) -> pd.DataFrame:
    return pd.DataFrame(cols, index=pd.Index(t, name="t", dtype=float))


def test_validate_rejects_bad_index() -> None:
    with pytest.raises(TableError, match="strictly increasing"):
        validate(frame([0.0, 0.0, 1.0], p=[0.0, 1.0, 2.0]))
    bad = frame([0.0, 1.0], p=[0.0, 1.0]).rename_axis("time")
    with pytest.raises(TableError, match="named 't'"):
        validate(bad)
    with pytest.raises(TableError, match="inf"):
        validate(frame([0.0, 1.0], p=[0.0, np.inf]))


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_save_load_round_trip_keeps_values_and_attrs(tmp_path: Path, suffix: str) -> None:
    table = frame([0.0, 0.004, 0.008], p=[0.1, -0.2, 0.3], u_roll=[0.0, 0.5, -1.0])
    table["segment"] = np.array([0, 0, 1], dtype=np.int64)
    table.attrs = {"source": "x.tlog", "format": "tlog", "mapping": {"p": "ATTITUDE.rollspeed"},
                   "dropped": [{"reason": "duplicate timestamp", "count": 2, "signal": "A"}]}
    back = load_table(save_table(table, tmp_path / f"flight{suffix}"))
    pd.testing.assert_frame_equal(back, table, check_exact=False, rtol=1e-8)
    assert back.attrs["mapping"] == {"p": "ATTITUDE.rollspeed"}
    assert back.attrs["dropped"][0]["count"] == 2


def test_load_table_errors_name_the_file(tmp_path: Path) -> None:
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"not parquet at all")
    with pytest.raises(TableError, match="junk.parquet"):
        load_table(junk)
    with pytest.raises(TableError, match="no such file"):
        load_table(tmp_path / "missing.csv")


def test_csv_without_t_uses_row_number_and_says_so(tmp_path: Path) -> None:
    path = tmp_path / "plain.csv"
    path.write_text("co2,input_gas_rate\n53.8,-0.109\n53.6,0.0\n")
    table = load_table(path)
    assert table.index.tolist() == [0.0, 1.0]
    assert any("row number" in w for w in table.attrs["warnings"])


def sig(column: str, t: np.ndarray, v: np.ndarray, source: str, priority: int = 10) -> Signal:
    return Signal(column, np.asarray(t, float), np.asarray(v, float), source, priority)


def test_resample_linear_hold_and_angle() -> None:
    t = np.array([0.0, 1.0, 2.0])
    grid = np.array([0.0, 0.5, 1.5, 2.0])
    assert np.allclose(resample(sig("p", t, [0, 2, 4], "A.p"), grid), [0, 1, 3, 4])
    assert np.allclose(resample(sig("u_roll", t, [0, 2, 4], "A.u"), grid), [0, 0, 2, 4])
    # yaw crossing ±π interpolates the short way round
    yaw = resample(sig("yaw", t, [3.0, -3.0, -2.9], "A.yaw"), np.array([0.5]))
    assert abs(abs(yaw[0]) - np.pi) < 0.05


def test_resample_with_the_callers_period_and_hold_index_is_unchanged() -> None:
    # build_table passes the native period and hold index once per time array (a
    # message's fields share theirs): the values must be those resample finds itself
    t = np.concatenate([np.arange(0, 1, 0.01), np.arange(2, 3, 0.01), [3.5]])
    grid = np.arange(-0.05, 3.7, 0.004)
    for column in ("p", "u_roll", "yaw"):
        s = sig(column, t, np.sin(3 * t), "A.x")
        own = resample(s, grid)
        held = hold_index(t, grid) if interpolation(column) == "hold" else None
        given = resample(s, grid, native_period(t), held)
        assert np.isnan(own).any() and np.isfinite(own).any()
        np.testing.assert_array_equal(given, own)
        gaps = find_gaps(t, native_period(t))
        assert gaps  # the 1–2 s hole: its grid points are NaN either way
        np.testing.assert_array_equal(resample(s, grid, native_period(t), held, gaps), own)
    assert interpolation("u_roll") == "hold" and interpolation("p") == "linear"


def test_gaps_split_segments_and_never_interpolate() -> None:
    t = np.concatenate([np.arange(0, 1, 0.01), np.arange(2, 3, 0.01)])
    raw = RawLog(Path("x.log"), "test", signals=[])
    p = sig("p", t, np.sin(t), "IMU.p")
    u = sig("u_roll", np.arange(0, 3, 0.02), np.ones(150), "RC.u")
    table = build_table(raw, {"p": p, "u_roll": u})
    assert table["segment"].nunique() == 2
    inside = (table.index > 1.0) & (table.index < 2.0)
    assert not inside.any(), "no grid points inside the body-rate gap"
    assert find_gaps(t) == [(pytest.approx(0.99), pytest.approx(2.0))]
    assert table.attrs["gaps"][0]["signal"] == "IMU.p"


def test_no_data_warnings_count_the_columns_missing_values() -> None:
    """Each column's "grid points have no data" warning counts what ``isna`` counts in the
    table (counted on the resampled arrays): a gap, a short span, a held command."""
    t = np.arange(0, 3, 0.01)
    raw = RawLog(Path("x.log"), "test", signals=[])
    chosen = {"p": sig("p", t, np.sin(t), "IMU.p"),
              "q": sig("q", np.concatenate([t[:100], t[150:]]), np.cos(t[:250]), "IMU.q"),
              "alt": sig("alt", t[50:200], t[50:200], "RNG.alt"),
              "u_roll": sig("u_roll", np.arange(0.5, 3, 0.02), np.ones(125), "RC.u")}
    table = build_table(raw, chosen)
    said = {}
    for line in raw.warnings:
        if "grid points have no data" in line:
            column, rest = line.split(": ", 1)
            said[column] = int(rest.split(" of ")[0])
    want = {c: int(table[c].isna().sum()) for c in chosen if table[c].isna().any()}
    assert said == want and {"q", "alt", "u_roll"} <= set(said)


def test_dirty_timestamps_are_repaired_and_counted() -> None:
    t = np.array([0.0, 0.01, 0.02, 0.02, 0.04, 0.03, 0.05, 0.06])
    v = np.array([0.0, 1.0, 2.0, 2.0, 4.0, 3.0, np.nan, 6.0])
    raw = RawLog(Path("x.log"), "test")
    table = build_table(raw, {"p": sig("p", t, v, "IMU.p")}, rate_hz=100.0)
    reasons = {d["reason"]: d["count"] for d in table.attrs["dropped"]}
    assert reasons == {"NaN or inf sample": 1, "duplicate timestamp": 1}
    assert table.attrs["repaired"][0]["count"] == 2
    assert np.allclose(table["p"].to_numpy(), [0, 1, 2, 3, 4, 5, 6])


def test_clean_signal_with_known_clean_times_is_unchanged() -> None:
    """Signals that share time arrays, cleaned with the set of time arrays found clean,
    give what each gives alone (arrays, issues), and keep a clean time array itself:
    clean and dirty times (NaN, unordered, repeated), values with NaN."""
    from etsid.ingest.align import clean_signal

    rng = np.random.default_rng(2)
    clean = np.sort(rng.uniform(0, 10, 500))
    unordered = clean.copy()
    unordered[[3, 7]] = unordered[[7, 3]]
    repeated = clean.copy()
    repeated[10] = repeated[9]
    holed = clean.copy()
    holed[4] = np.nan
    times = [clean, unordered, repeated, holed, clean, clean, holed, repeated]
    signals = []
    for k, t in enumerate(times):
        v = rng.normal(size=t.size)
        if k == 5:
            v[17] = np.nan
        signals.append(Signal("p", t, v, f"M{k}.p", 0))
    known: set[int] = set()
    d1: list = []
    r1: list = []
    got = [clean_signal(s, d1, r1, known) for s in signals]
    d2: list = []
    r2: list = []
    want = [clean_signal(s, d2, r2) for s in signals]
    assert d1 == d2 and r1 == r2 and len(d1) >= 4 and r1
    assert known == {id(clean)}
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g.t, w.t)
        np.testing.assert_array_equal(g.values, w.values)
    assert got[0].t is clean and got[4].t is clean


def test_choose_signals_priority_rate_and_override() -> None:
    t1, t2 = np.arange(0, 1, 0.01), np.arange(0, 1, 0.004)
    fused = sig("p", t1, t1, "/mavros/imu/data.angular_velocity.x", priority=1)
    raw_imu = sig("p", t2, t2, "/mavros/imu/data_raw.angular_velocity.x", priority=2)
    chosen, notes = choose_signals([raw_imu, fused], [], Path("b.bag"))
    assert chosen["p"] is fused and "also found" in notes[0]
    forced = parse_override("p=/mavros/imu/data_raw")
    chosen, _ = choose_signals([raw_imu, fused], [forced], Path("b.bag"))
    assert chosen["p"] is raw_imu
    with pytest.raises(IngestError, match="candidates: /mavros"):
        choose_signals([raw_imu, fused], [parse_override("p=/other")], Path("b.bag"))


def test_mapping_file(tmp_path: Path) -> None:
    path = tmp_path / "map.toml"
    path.write_text('[map]\np = "/imu.angular_velocity.x"\n[rc]\nu_yaw = 5\n')
    overrides, rc = load_mapping_file(path)
    assert overrides == [Override("p", "/imu", "angular_velocity.x")]
    assert rc["u_yaw"] == 5 and rc["u_roll"] == 1
    path.write_text("[rc]\nu_yaw = 'five'\n")
    with pytest.raises(IngestError, match="map.toml"):
        load_mapping_file(path)


def test_get_field_paths() -> None:
    msg = {"channels": [1100, 1500], "pose": {"position": {"z": 2.5}}}
    assert get_field(msg, "channels[1]") == 1500.0
    assert get_field(msg, "pose.position.z") == 2.5


angles = st.floats(-3.0, 3.0)


@settings(max_examples=60, deadline=None)
@given(angles, st.floats(-1.4, 1.4), angles)
def test_ros_orientation_round_trip(roll: float, pitch: float, yaw: float) -> None:
    """NED/FRD Euler → ENU/FLU quaternion (as MAVROS publishes) → back gives the same angles."""
    q = ned_frd_euler_to_enu_flu_quat(np.array([roll]), np.array([pitch]), np.array([yaw]))
    back = enu_flu_quat_to_ned_frd_euler(*q)
    assert np.allclose(np.angle(np.exp(1j * (np.concatenate(back) - [roll, pitch, yaw]))), 0,
                       atol=1e-9)


def test_enu_flu_identity_faces_east() -> None:
    """A ROS identity orientation (body x along ENU east) is yaw +90° in NED, level."""
    roll, pitch, yaw = enu_flu_quat_to_ned_frd_euler(*(np.array([v]) for v in (1.0, 0, 0, 0)))
    assert np.allclose([roll[0], pitch[0], yaw[0]], [0.0, 0.0, np.pi / 2])
    assert np.allclose(np.concatenate(quat_to_euler(*(np.array([v]) for v in (1.0, 0, 0, 0)))),
                       0.0)


def test_quat_to_euler_equals_the_angles_of_the_whole_matrix() -> None:
    """The five matrix entries computed alone give the angles of the whole matrix, bit for
    bit (sign bits too): random, unnormalised, near-gimbal-lock, zero, huge, infinite and
    NaN quaternions, as strided rows of one array (as the tlog reader passes them)."""
    rng = np.random.default_rng(5)
    q = rng.normal(size=(4000, 4)) * rng.choice([1e-3, 1.0, 3.0], size=(4000, 1))
    q[:50] = [np.cos(0.785398), 0.0, np.sin(0.785398), 0.0]  # pitch ±90°, rounding past 1
    q[50:60, 2] *= -1
    q[60] = 0.0
    q[61] = [1e200, 1e200, 0.0, 0.0]
    q[62] = [np.inf, 0.0, 0.0, 0.0]
    q[63] = [np.nan, 0.5, 0.5, 0.5]
    q[64] = [-1.0, 0.0, 0.0, 0.0]
    got = quat_to_euler(*q.T)
    want = matrix_to_euler(quat_to_matrix(*q.T))
    for a, b in zip(got, want, strict=True):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
        assert np.array_equal(np.signbit(a), np.signbit(b))


def test_default_rate_is_the_mean_rate_of_a_bursty_stream() -> None:
    """Samples arriving in pairs (1 ms, 6 ms apart) run at 2 per 7 ms, not at 1/median."""
    t = np.cumsum(np.tile([0.001, 0.006], 200))
    raw = RawLog(Path("x.ulg"), "test")
    table = build_table(raw, {"p": sig("p", t, np.sin(t), "rates.x")})
    assert table.attrs["rate_hz"] == pytest.approx(2 / 0.007, rel=5e-3)
    assert table["segment"].nunique() == 1 and not table.attrs["gaps"]


def test_compiled_unwrap_equals_numpys_unwrap() -> None:
    """The one-pass unwrap (numba loaded, finite float arrays) gives ``np.unwrap``'s bits,
    sign bits included: random walks of every step size, wrapped angles, steps of exactly
    ±π and multiples of it; arrays with a NaN or an infinity go to ``np.unwrap`` itself."""
    import numba  # noqa: F401  (the compiled pass runs once numba is loaded)

    from etsid.ingest.align import HOLD_MERGE_MIN, unwrap

    rng = np.random.default_rng(3)
    for case in range(120):
        n = HOLD_MERGE_MIN + int(rng.integers(1, 3000))
        x = np.cumsum(rng.normal(0.0, rng.choice([0.01, 1.0, 3.0, 10.0]), n))
        if case % 3 == 0:
            x = np.angle(np.exp(1j * x))
        if case % 5 == 0:
            x[rng.integers(0, n, 20)] = np.pi * rng.choice([-3, -2, -1, 1, 2, 3], 20)
        if case % 7 == 0:
            x[1], x[2], x[3] = x[0] + np.pi, x[0], x[0] - np.pi
        if case % 11 == 0:
            x[int(rng.integers(0, n))] = rng.choice([np.nan, np.inf, -np.inf])
        with np.errstate(invalid="ignore"):
            want = np.unwrap(x)
            got = unwrap(x)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))


def test_compiled_interp_equals_numpys_interp() -> None:
    """The merge walk (numba loaded, ordered float arrays) gives ``np.interp``'s bits, sign
    bits included: repeated sample times, grid points on samples and outside their span,
    huge, infinite and NaN values (numpy's retry from the right end of a step); unordered
    or NaN times go to ``np.interp`` itself."""
    import numba  # noqa: F401  (the walk runs once numba is loaded)

    from etsid.ingest.align import HOLD_MERGE_MIN, interp_linear

    rng = np.random.default_rng(9)
    for case in range(150):
        n = int(rng.integers(2, 3000))
        xp = np.sort(rng.normal(size=n) * 10)
        if case % 3 == 0:
            xp = np.round(xp)  # repeated times
        fp = rng.normal(size=n) * rng.choice([1.0, 1e300])
        if case % 5 == 0:
            fp[rng.integers(0, n, 5)] = rng.choice([np.nan, np.inf, -np.inf], 5)
        x = np.sort(rng.normal(size=HOLD_MERGE_MIN + int(rng.integers(1, 3000))) * 12)
        if case % 4 == 0:
            x = np.round(x)
        if case % 7 == 0:
            x = np.sort(np.concatenate([xp[:50], x]))  # on the samples
        if case % 11 == 0:
            xp[int(rng.integers(0, n))] = np.nan
        if case % 13 == 0:
            xp = rng.normal(size=n)
        got, want = interp_linear(x, xp, fp), np.interp(x, xp, fp)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))


def test_compiled_hold_equals_numpys_hold(monkeypatch: pytest.MonkeyPatch) -> None:
    """A held column resampled in one compiled pass (numba loaded) equals numpy's gather and
    masks: grid points before the first sample, past the hold of the last one, values with
    NaN and -0."""
    import sys

    import numba  # noqa: F401  (the compiled pass runs once numba is loaded)

    from etsid.ingest.align import HOLD_MERGE_MIN

    rng = np.random.default_rng(6)
    for _case in range(30):
        n = int(rng.integers(2, 3000))
        t = np.sort(rng.uniform(0.0, 50.0, n))
        v = rng.normal(size=n)
        v[rng.integers(0, n, 3)] = rng.choice([np.nan, -0.0, np.inf], 3)
        grid = np.sort(rng.uniform(-5.0, 60.0, HOLD_MERGE_MIN + int(rng.integers(1, 3000))))
        s = Signal("u_roll", t, v, "RC.u", 0)
        period = float(rng.choice([0.01, 0.5, 3.0]))
        got = resample(s, grid, period)
        with monkeypatch.context() as patch:
            patch.delitem(sys.modules, "numba")
            want = resample(s, grid, period)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))


def test_hold_index_merge_walk_equals_searchsorted() -> None:
    """The merge walk (numba loaded, ordered float arrays) gives searchsorted's indices;
    a NaN or an unordered time array falls back to searchsorted itself."""
    import numba  # noqa: F401  (the walk runs once numba is loaded)

    from etsid.ingest.align import HOLD_MERGE_MIN, HOLD_TOLERANCE_S, hold_index

    rng = np.random.default_rng(5)
    for case in range(60):
        t = np.sort(rng.normal(size=int(rng.integers(0, 2000))) * 10)
        if case % 3 == 0:
            t = np.round(t)  # repeated times
        if case % 7 == 0 and t.size:
            t[int(rng.integers(0, t.size))] = np.nan
        if case % 11 == 0:
            t = rng.normal(size=t.size)
        grid = np.sort(rng.normal(size=HOLD_MERGE_MIN + int(rng.integers(1, 2000))) * 12)
        if case % 5 == 0:
            grid = np.round(grid)
        want = np.searchsorted(t, grid + HOLD_TOLERANCE_S, side="right") - 1
        got = hold_index(t, grid)
        assert got.dtype == want.dtype and np.array_equal(got, want)


@pytest.mark.parametrize("n", [1000, 2340, 2488, 3000])
def test_hold_takes_a_sample_stamped_at_the_grid_point(n: int) -> None:
    """A motor stream stamped at the reference stream's instants (one in µs, one in ms, as
    MAVLink's SERVO_OUTPUT_RAW and ATTITUDE are) is held from its own instant on the grid
    built from the reference's estimated period: floating-point rounding of that grid put
    8-37 % of the points a hair before their sample, which was then held one period late."""
    from etsid.ingest.align import hold_index, native_period

    ref = np.rint((np.arange(n) * 0.02 + 30.0) * 1e3) / 1e3
    servo = np.rint((np.arange(n) * 0.02 + 30.0) * 1e6) / 1e6
    grid = ref[0] + np.arange(n) / (1.0 / native_period(ref))
    assert np.mean(np.searchsorted(servo, grid, side="right") - 1 != np.arange(n)) > 0.05
    assert np.array_equal(hold_index(servo, grid), np.arange(n))
    late = servo + 0.004  # a stream 4 ms behind is still held from its own samples
    assert np.array_equal(hold_index(late, grid)[1:], np.arange(n - 1))
