"""Cut and damaged MCAP files (plain, and the storage of ROS 2 bags) keep every record that
decodes, before and after the damage, and say how many seconds are lost.

Files are written by the real writers (mcap-ros2-support for plain MCAP with zstd chunks,
rosbags for ROS 2 bags with uncompressed 1 MiB chunks); the truth for the lost seconds is
the gap the damage leaves in the IMU stream, compared with the pristine file.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.ingest import read_log, read_raw
from etsid.sim.writers.mcapfile import write_mcap
from etsid.sim.writers.rosbag import write_ros2_bag

DURATION_S = 24.0


def _table(rate: float = 250.0) -> pd.DataFrame:
    t = np.arange(int(DURATION_S * rate)) / rate
    w = 2 * np.pi
    cols = {"p": 0.8 * np.sin(w * 0.7 * t) + 0.1, "q": -0.6 * np.sin(w * 0.5 * t),
            "r": 0.5 * np.cos(w * 0.3 * t), "roll": 0.3 * np.sin(w * 0.2 * t),
            "pitch": -0.2 * np.sin(w * 0.15 * t), "yaw": np.angle(np.exp(1j * 0.5 * t)),
            "u_roll": 0.5 * np.sin(w * 0.2 * t), "u_pitch": -0.4 * np.sin(w * 0.25 * t),
            "u_yaw": 0.3 * np.cos(w * 0.1 * t), "u_thrust": 0.55 + 0.2 * np.sin(w * 0.1 * t),
            "ax": 0.2 + 0 * t, "ay": -0.3 + 0 * t, "az": -9.81 + 0.5 * np.sin(w * 0.2 * t),
            "vbat": 16.0 - 0.02 * t}
    table = pd.DataFrame(cols, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = 1.7e9
    return table


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("mcapdamage")
    table = _table()
    return {"plain": write_mcap(table, out / "plain.mcap", encoding="ros2"),
            "bag": write_ros2_bag(table, out / "bag", storage="mcap")}


def _storage(path: Path) -> Path:
    return next(path.glob("*.mcap")) if path.is_dir() else path


def _copy(src: Path, dst: Path) -> Path:
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copyfile(src, dst)
    return dst


def _imu_times(path: Path) -> np.ndarray:
    raw = read_raw(path)
    sig = min((s for s in raw.signals if s.column == "p"), key=lambda s: s.priority)
    return np.asarray(sig.t, dtype=float)


def _seconds(pattern: str, text: str) -> float:
    found = re.search(pattern, text)
    assert found is not None, text
    return float(found.group(1))


@pytest.mark.parametrize("kind", ["plain", "bag"])
@pytest.mark.parametrize("fraction", [0.3, 0.55, 0.8])
def test_cut_mcap_keeps_its_valid_part(files: dict[str, Path], tmp_path: Path, kind: str,
                                       fraction: float) -> None:
    cut = _copy(files[kind], tmp_path / f"cut_{kind}{'' if kind == 'bag' else '.mcap'}")
    storage = _storage(cut)
    data = storage.read_bytes()
    storage.write_bytes(data[: int(len(data) * fraction)])
    full, part = read_log(files[kind]), read_log(cut)
    assert 0.5 * fraction * len(full) < len(part) < len(full)
    np.testing.assert_allclose(part["p"].to_numpy(), full["p"].to_numpy()[: len(part)],
                               atol=1e-12)
    note = next(w for w in part.attrs["warnings"] if "truncated" in w)
    kept_s = _seconds(r"kept \d+ message\(s\), ([\d.]+) s", note)
    assert kept_s == pytest.approx(part.index[-1] - part.index[0], abs=0.15)
    if kind == "bag":  # metadata.yaml still says how long the recording was
        assert _seconds(r" s of ([\d.]+) s", note) == pytest.approx(DURATION_S, abs=0.1)
    else:
        assert "the rest of the recording is lost" in note


@pytest.mark.parametrize("kind", ["plain", "bag"])
def test_zeroed_page_keeps_both_sides_and_says_the_seconds(
        files: dict[str, Path], tmp_path: Path, kind: str) -> None:
    bad = _copy(files[kind], tmp_path / f"zero_{kind}{'' if kind == 'bag' else '.mcap'}")
    storage = _storage(bad)
    data = bytearray(storage.read_bytes())
    mid = len(data) // 2
    data[mid:mid + 4096] = bytes(4096)
    storage.write_bytes(bytes(data))
    full, part = read_log(files[kind]), read_log(bad)
    # data from both sides of the damage
    assert part.index[0] == pytest.approx(full.index[0], abs=0.05)
    assert part.index[-1] == pytest.approx(full.index[-1], abs=0.05)
    t_full, t_part = _imu_times(files[kind]), _imu_times(bad)
    missing = np.setdiff1d(np.round(t_full, 6), np.round(t_part, 6))
    assert missing.size > 0
    before = t_part[t_part < missing.min()].max()
    after = t_part[t_part > missing.max()].min()
    truth = after - before
    note = next(w for w in part.attrs["warnings"] if "damaged stretch" in w)
    lost = _seconds(r"; ([\d.]+) s missing", note)
    assert lost == pytest.approx(truth, abs=0.06)
    cover = _seconds(r"data cover ([\d.]+) s", note)
    assert cover == pytest.approx(DURATION_S - truth, abs=0.1)
    if kind == "bag":  # uncompressed chunk: only the records inside the page are lost
        assert truth < 0.5
