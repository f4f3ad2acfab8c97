"""Identification rate: block-mean decimation, segments, angles and σ accounting."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify
from etsid.ident.resample import decimate, factor_for


def _noise_table(n: int, rate: float, sigma: float, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame({"p": rng.normal(0.0, sigma, n), "yaw": np.full(n, np.pi - 0.01)},
                         index=pd.Index(np.arange(n) / rate, name="t"))
    frame.loc[frame.index[1::2], "yaw"] = -np.pi + 0.01  # wraps between samples
    frame["segment"] = np.zeros(n, dtype=np.int64)
    frame.attrs = {"rate_hz": rate, "noise": {"gyro_std": sigma, "gyro_bias_std": 0.005}}
    return frame


@pytest.mark.parametrize(("native", "wanted", "k"), [
    (250.0, 50.0, 5), (409.0, 50.0, 8), (278.7, 50.0, 6), (50.0, 50.0, 1), (30.0, 50.0, 1),
    (250.0, None, 1), (100.0, 40.0, 3), (100.0, 45.0, 2)])
def test_integer_factor_nearest_the_wanted_rate(native: float, wanted: float | None,
                                                k: int) -> None:
    assert factor_for(native, wanted) == k


def test_block_mean_scales_white_noise_by_root_k() -> None:
    sigma = 0.02
    out = decimate(_noise_table(100_000, 250.0, sigma), 50.0)
    assert len(out) == 20_000
    assert out.attrs["rate_hz"] == 50.0
    assert out.attrs["decimation"] == {"factor": 5, "native_rate_hz": 250.0, "rate_hz": 50.0,
                                       "method": "block mean", "requested_hz": 50.0}
    assert out.attrs["noise"]["gyro_std"] == pytest.approx(sigma / np.sqrt(5))
    assert out.attrs["noise"]["gyro_std_native"] == sigma
    assert out.attrs["noise"]["gyro_bias_std"] == 0.005  # a bias does not average out
    # the measured σ of the averaged noise is what the metrics report as the floor
    assert np.std(out["p"]) == pytest.approx(sigma / np.sqrt(5), rel=0.02)
    # block time is the mean of the block's times; angles use the circular mean
    assert out.index[0] == pytest.approx(2 / 250)
    assert np.all(np.abs(np.abs(out["yaw"]) - np.pi) < 0.01)


def test_blocks_stay_inside_segments_and_nan_spreads() -> None:
    frame = _noise_table(23, 250.0, 0.0)
    frame["p"] = np.arange(23.0)
    frame["segment"] = np.r_[np.zeros(12), np.ones(11)].astype(np.int64)
    frame.loc[frame.index[20], "p"] = np.nan
    out = decimate(frame, 50.0)
    # segment 0: rows 0-4, 5-9 (10, 11 dropped); segment 1: rows 12-16, 17-21 (22 dropped)
    assert out["p"].tolist()[:3] == [2.0, 7.0, 14.0] and np.isnan(out["p"].iloc[3])
    assert out["segment"].tolist() == [0, 0, 1, 1]


def test_identify_reports_rate_and_refuses_negative(tmp_path: object) -> None:
    frame = _noise_table(10, 250.0, 0.01)
    with pytest.raises(IdentError, match="--ident-rate"):
        identify(frame, IdentConfig(ident_rate=-1.0))
    with pytest.raises(IdentError, match="too short to decimate"):
        decimate(frame.iloc[:3], 50.0)


def test_block_mean_has_the_bits_of_numpys_row_mean() -> None:
    from etsid.ident.resample import SEQUENTIAL_MAX, block_mean

    rng = np.random.default_rng(3)
    for k in range(1, SEQUENTIAL_MAX + 4):  # column sums up to SEQUENTIAL_MAX, then numpy's
        v = rng.normal(size=20000) * 10.0 ** rng.integers(-8, 8, size=20000)
        v[rng.random(v.size) < 0.01] = np.nan
        scattered = np.sort(rng.choice(v.size - k, 3000, replace=False))
        adjacent = 7 + k * np.arange((v.size - 7) // k)  # one run: strided slices
        for starts in (scattered, adjacent):
            rows = starts[:, None] + np.arange(k)
            for fn in (None, np.sin, np.cos):
                want = (v[rows] if fn is None else fn(v[rows])).mean(axis=1)
                got = block_mean(v, starts, k, fn)
                assert got.tobytes() == want.tobytes()
