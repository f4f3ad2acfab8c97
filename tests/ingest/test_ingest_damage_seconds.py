"""Every reader that skips damaged data says how many seconds it lost, in one wording
(:mod:`etsid.ingest.damage`): "… N s missing (t = a–b s); data cover X s of the Y s
between first and last message".

Files: tlog and ROS 1 bags from the real writers (pymavlink, rosbags), ULog and DataFlash
from real flights (tests/data). The damage is a zeroed 4 KiB page (or a cut, or a zeroed
index); the truth is the gap it leaves in the densest stream, found by comparing with the
pristine file.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.ingest import read_log, read_raw
from etsid.ingest.damage import cut_note, data_gaps, gap_note
from etsid.sim.writers.rosbag import write_ros1_bag
from etsid.sim.writers.tlog import write_tlog

DATA = Path(__file__).resolve().parents[1] / "data"


def _table(duration: float = 30.0, rate: float = 100.0) -> pd.DataFrame:
    t = np.arange(int(duration * rate)) / rate
    w = 2 * np.pi
    cols = {"p": 0.8 * np.sin(w * 0.7 * t), "q": -0.6 * np.sin(w * 0.5 * t),
            "r": 0.5 * np.cos(w * 0.3 * t), "roll": 0.3 * np.sin(w * 0.2 * t),
            "pitch": -0.2 * np.sin(w * 0.15 * t), "yaw": np.angle(np.exp(1j * 0.5 * t)),
            "u_roll": 0.5 * np.sin(w * 0.2 * t), "u_pitch": -0.4 * np.sin(w * 0.25 * t),
            "u_yaw": 0.3 * np.cos(w * 0.1 * t), "u_thrust": 0.55 + 0.2 * np.sin(w * 0.1 * t),
            "ax": 0.2 + 0 * t, "ay": -0.3 + 0 * t, "az": -9.81 + 0 * t, "vbat": 16.0 - 0.02 * t}
    table = pd.DataFrame(cols, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = 1.7e9
    return table


def _zero_page(src: Path, dst: Path, at: float = 0.5, size: int = 4096) -> Path:
    data = bytearray(src.read_bytes())
    pos = int(len(data) * at)
    data[pos:pos + size] = bytes(size)
    dst.write_bytes(bytes(data))
    return dst


def _dense_times(path: Path) -> dict[tuple[str, str], np.ndarray]:
    return {(s.topic, s.column): np.asarray(s.t, dtype=float) for s in read_raw(path).signals}


def _truth_gap(pristine: Path, damaged: Path) -> float:
    """Seconds from the last sample kept before the damage to the first kept after it, in
    the densest stream that lost samples."""
    full, part = _dense_times(pristine), _dense_times(damaged)
    best = None
    for key, ta in full.items():
        tb = part.get(key)
        if tb is None:
            continue
        missing = np.setdiff1d(np.round(ta, 6), np.round(tb, 6))
        if missing.size and (best is None or ta.size > best[0]):
            before, after = tb[tb < missing.min()], tb[tb > missing.max()]
            if before.size and after.size:
                best = (ta.size, after.min() - before.max())
    assert best is not None, "the damage removed no sample"
    return float(best[1])


def _lost(note: str) -> float:
    found = re.search(r"; ([\d.]+) s missing \(t = ", note)
    assert found is not None, note
    return float(found.group(1))


def _note(warnings: list[str], word: str) -> str:
    return next(w for w in warnings if word in w)


def test_note_wording_is_shared() -> None:
    note = gap_note("f.bin", "skipped 3 damaged chunk(s)", [(2.0, 3.5), (7.0, 7.5)], 0.0, 10.0)
    assert note == ("f.bin: skipped 3 damaged chunk(s); 2.0 s missing (t = 2.0–3.5 s, "
                    "7.0–7.5 s); data cover 8.0 s of the 10.0 s between first and last message")
    assert cut_note("b", "truncated", 12, 1.0, 11.5, 30.0) == \
        "b: truncated: kept 12 message(s), 10.5 s of 30.0 s (19.5 s lost at the end)"
    t = np.concatenate((np.arange(0, 5, 0.01), np.arange(6, 9, 0.01)))
    assert data_gaps(t) == [(pytest.approx(4.99), 6.0)]


def test_tlog_zeroed_page_gap_in_seconds(tmp_path: Path) -> None:
    clean = write_tlog(_table(), tmp_path / "clean.tlog")
    bad = _zero_page(clean, tmp_path / "bad.tlog")
    truth = _truth_gap(clean, bad)
    note = _note(read_log(bad).attrs["warnings"], "no valid tlog record")
    assert _lost(note) == pytest.approx(truth, abs=0.06)
    assert "data cover" in note


def test_ros1_zeroed_page_and_index(tmp_path: Path) -> None:
    clean = write_ros1_bag(_table(), tmp_path / "clean.bag")
    bad = _zero_page(clean, tmp_path / "bad.bag", at=0.4)
    truth = _truth_gap(clean, bad)
    warnings = read_log(bad).attrs["warnings"]
    assert _lost(_note(warnings, "damaged")) == pytest.approx(truth, abs=0.06)
    # a damaged index alone loses nothing: every chunk is found by scanning
    tail = tmp_path / "tail.bag"
    data = bytearray(clean.read_bytes())
    data[-600:-100] = bytes(500)
    tail.write_bytes(bytes(data))
    table = read_log(tail)
    note = _note(table.attrs["warnings"], "index unreadable")
    assert "every chunk read" in note and "lost" not in note
    assert table.index[-1] == pytest.approx(read_log(clean).index[-1], abs=0.02)
    # cut short: kept seconds = what the table holds
    cut = tmp_path / "cut.bag"
    cut.write_bytes(clean.read_bytes()[: int(clean.stat().st_size * 0.5)])
    part = read_log(cut)
    note = _note(part.attrs["warnings"], "truncated bag")
    kept = float(re.search(r"message\(s\), ([\d.]+) s", note).group(1))
    assert kept == pytest.approx(part.index[-1] - part.index[0], abs=0.1)


@pytest.mark.parametrize(("name", "at"), [("px4_sitl_tagged.ulg", 0.5),
                                          ("px4_cubeorange_real.ulg", 0.5)])
def test_ulog_damaged_section_in_seconds(tmp_path: Path, name: str, at: float) -> None:
    bad = _zero_page(DATA / name, tmp_path / name, at=at)
    truth = _truth_gap(DATA / name, bad)
    note = _note(read_raw(bad).warnings, "file is corrupt")
    assert _lost(note) == pytest.approx(truth, abs=0.1)


def test_dataflash_damage_in_seconds(tmp_path: Path) -> None:
    src = DATA / "arduplane_truncated.BIN"
    bad = _zero_page(src, tmp_path / "bad.BIN", size=8192)
    truth = _truth_gap(src, bad)
    note = _note(read_raw(bad).warnings, "no valid DataFlash message")
    assert _lost(note) == pytest.approx(truth, abs=0.03)


def test_clean_copies_have_no_damage_note(tmp_path: Path) -> None:
    copy = tmp_path / "copy.ulg"
    shutil.copyfile(DATA / "px4_sitl_tagged.ulg", copy)
    assert not [w for w in read_raw(copy).warnings if "missing" in w]
