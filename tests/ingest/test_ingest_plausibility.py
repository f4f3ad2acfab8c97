"""Physical plausibility on ingest, missing core columns, robust inspect rates."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from etsid.ingest import inspect_log, read_log
from etsid.ingest.base import Channel, Issue, Signal
from etsid.ingest.plausibility import (
    LIMITS,
    check_signals,
    pooled_quantiles,
    table_violations,
)

ROOT = Path(__file__).resolve().parents[2]


def _sig(column: str, values: list[float], t: list[float] | None = None) -> Signal:
    t = t if t is not None else [0.01 * i for i in range(len(values))]
    return Signal(column, np.array(t, dtype=float), np.array(values, dtype=float), f"X.{column}")


def test_implausible_values_are_dropped_counted_and_said() -> None:
    dropped: list[Issue] = []
    chosen = {"p": _sig("p", [0.1, 2.6e131, -0.2, 36.0, 34.9]),
              "vbat": _sig("vbat", [16.0, 0.006, 15.9, 16.1, 101.0])}
    out, note = check_signals(chosen, dropped)
    assert out["p"].values.tolist() == [0.1, -0.2, 34.9]
    assert out["vbat"].values.tolist() == [16.0, 15.9, 16.1]
    assert {(i.signal, i.count) for i in dropped} == {("X.p", 2), ("X.vbat", 2)}
    assert note is not None and "dropped 4 physically implausible" in note


def test_plausible_data_pass_untouched() -> None:
    dropped: list[Issue] = []
    sig = _sig("roll", [-np.pi, 0.0, np.pi])
    out, note = check_signals({"roll": sig}, dropped)
    assert out["roll"] is sig and note is None and not dropped


def test_specific_force_vector_beyond_16_g_is_dropped() -> None:
    dropped: list[Issue] = []
    chosen = {c: _sig(c, [0.0, 151.0, 0.0]) for c in ("ax", "ay", "az")}
    chosen["az"] = _sig("az", [-9.8, -153.0, -9.8])
    out, _ = check_signals(chosen, dropped)
    assert [s.values.size for s in out.values()] == [2, 2, 2]  # each axis alone is < 16 g


def test_stray_timestamp_is_dropped() -> None:
    dropped: list[Issue] = []
    t = [0.01 * i for i in range(1000)] + [4e10]
    out, note = check_signals({"p": _sig("p", [0.0] * 1001, t)}, dropped)
    assert out["p"].t.max() < 10.0
    assert dropped[0].reason == "timestamp outside the log's span" and dropped[0].count == 1
    assert note is not None and "1 X.p" in note


def test_every_written_table_respects_the_limits() -> None:
    # the real logs of tests/data stay within the limits after ingest
    for log in ("px4_cubeorange_real.ulg", "arduplane_truncated.BIN",
                "ardupilot_sitl_quadplane.tlog"):
        table = read_log(ROOT / "tests" / "data" / log)
        assert table_violations(table) == {}
    assert set(LIMITS) >= {"p", "q", "r", "ax", "ay", "az", "vbat", "roll", "pitch", "yaw"}


def test_damaged_imu_type_name_is_reported(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    shutil.copytree(ROOT / "sample_logs" / "hexa_ige_oge_db3", bag)
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("sensor_msgs/msg/Imu", "sensor_msgs/msg/Imq"))
    table = read_log(bag)
    assert "p" not in table.columns
    notes = [w for w in table.attrs["warnings"] if "no p q r roll pitch yaw" in w]
    assert notes and "/mavros/imu/data (sensor_msgs/msg/Imq" in notes[0]


def test_inspect_rate_is_not_a_burst_artefact() -> None:
    from etsid.ingest import robust_rate

    burst = Channel("CMD", "CMD", 300, t_first=1.0, t_last=1.01)
    rate, why = robust_rate(burst, [], 0.0, 100.0)
    assert rate == 3.0 and "burst" in why
    steady = Channel("IMU", "IMU", 1001, t_first=0.0, t_last=100.0)
    assert robust_rate(steady, [], 0.0, 100.0) == (10.0, "")
    info = inspect_log(ROOT / "sample_logs" / "hexa_ige_oge.tlog")
    rates = {c["name"]: c["rate_hz"] for c in info["channels"]}
    assert abs(rates["ATTITUDE"] - 50.0) < 1.0


def test_pooled_quantiles_equal_numpys_quantile_of_the_pooled_times() -> None:
    """The bisection over ordered arrays (shared arrays counted per use) gives
    np.quantile's numbers bit for bit; unordered arrays take numpy's path."""
    rng = np.random.default_rng(3)
    for case in range(120):
        arrays: list[np.ndarray] = []
        for _ in range(int(rng.integers(1, 5))):
            n = int(rng.integers(0, 200))
            kind = case % 4
            a = (np.sort(rng.normal(size=n)) if kind == 0 else
                 np.sort(rng.integers(0, 4, n).astype(float)) if kind == 1 else
                 rng.normal(size=n) if kind == 2 else np.cumsum(rng.random(n)))
            arrays.append(a)
            if rng.random() < 0.4:
                arrays.append(arrays[int(rng.integers(0, len(arrays)))])
        if not sum(a.size for a in arrays):
            continue
        qs = (0.001, 0.999, float(rng.random()), 0.0, 1.0)
        want = np.quantile(np.concatenate(arrays), list(qs)).tolist()
        assert pooled_quantiles(arrays, qs) == want
