"""Throughput of the tlog, DataFlash and ULog readers (docs/performance.md).

Run::

    python benchmarks/ingest_mavlink.py [--minutes 60] [--workdir bench_logs]

* tlog: a ≥ 1 M-message log written by :func:`etsid.sim.writers.tlog.write_tlog`
  (cached in ``--workdir``); ``read_log`` packets/s and MB/s, peak memory
  (tracemalloc, a separate run), against pymavlink's filtered ``recv_match`` loop over
  the same file (the messages the reader maps).
* DataFlash: a 1 M-message ``.bin`` (RATE 400 Hz, IMU 400 Hz, ATT/RCIN/RCOU 50 Hz)
  built with numpy from FMT definitions.
* ULog: the real tests/data/px4_cubeorange_real.ulg (pyulog has no writer).
"""

from __future__ import annotations

import argparse
import struct
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from etsid.ingest import read_log
from etsid.ingest.mavlink.signals import DECODERS
from etsid.sim.writers.tlog import write_tlog

ROOT = Path(__file__).resolve().parents[1]


def synthetic_table(seconds: float, rate: float = 250.0) -> pd.DataFrame:
    t = np.arange(0.0, seconds, 1.0 / rate)
    cols = {c: 0.5 * np.sin(0.7 * t + k) for k, c in enumerate("pqr")}
    cols |= {"roll": 0.2 * np.sin(0.3 * t), "pitch": 0.1 * np.sin(0.2 * t),
             "yaw": np.angle(np.exp(0.1j * t))}
    cols |= {c: 0.5 * np.sin(0.4 * t + k) for k, c in enumerate(("u_roll", "u_pitch", "u_yaw"))}
    cols |= {c: 0.3 * np.sin(0.5 * t + k) for k, c in enumerate(("sp_p", "sp_q", "sp_r"))}
    cols |= {"u_thrust": 0.5 + 0.1 * np.sin(t), "alt": 2 + np.sin(0.05 * t),
             "vx": np.sin(0.1 * t), "vy": np.cos(0.1 * t), "vz": 0.1 * np.sin(t),
             "ax": np.sin(t), "ay": np.cos(t), "az": -9.8 + 0 * t, "vbat": 16 - 1e-4 * t}
    cols |= {f"m{i}": 0.5 + 0.1 * np.sin(t + i) for i in range(1, 7)}
    return pd.DataFrame(cols, index=pd.Index(t, name="t"))


def measure(label: str, fn: Callable[[], object], nbytes: int, count: int) -> dict[str, float]:
    fn()  # warm up (numba compile / page cache)
    start = time.perf_counter()
    fn()
    wall = time.perf_counter() - start
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    row = {"wall_s": wall, "msgs_per_s": count / wall, "mb_per_s": nbytes / 1e6 / wall,
           "peak_mb": peak / 1e6}
    print(f"{label:<34} {count:>9} msgs {nbytes / 1e6:8.1f} MB {wall:7.2f} s "
          f"{row['msgs_per_s'] / 1e3:9.0f} k msg/s {row['mb_per_s']:7.1f} MB/s "
          f"peak {row['peak_mb']:7.1f} MB")
    return row


def tlog_count(path: Path) -> int:
    from etsid.ingest.mavlink.dtypes import crc_extra_table
    from etsid.ingest.mavlink.scan import scan_frames

    buf = np.fromfile(path, np.uint8)
    return int(scan_frames(buf, crc_extra_table(), True).offset.size)


def pymavlink_loop(path: Path, limit: int) -> tuple[int, float]:
    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    wanted = list(DECODERS)
    n = 0
    start = time.perf_counter()
    while n < limit and conn.recv_match(type=wanted) is not None:
        n += 1
    return n, time.perf_counter() - start


def build_bin(path: Path, seconds: float) -> int:
    """A DataFlash log of RATE and IMU at 400 Hz, ATT/RCIN/RCOU at 50 Hz; message count."""
    defs = {
        130: ("RATE", "Qffffffffffff", "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut,ADes,A,AOut",
              400),
        131: ("IMU", "QffffffIIfBBHH",
              "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz", 400),
        132: ("ATT", "Qccccchh", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP", 50),
        133: ("RCIN", "QHHHHHHHHHHHHHH", "TimeUS," + ",".join(f"C{i}" for i in range(1, 15)),
              50),
        134: ("RCOU", "QHHHHHHHHHHHHHH", "TimeUS," + ",".join(f"C{i}" for i in range(1, 15)),
              50),
    }
    struct_of = {"Q": "Q", "f": "f", "I": "I", "B": "B", "H": "H", "h": "h", "c": "h"}
    head = bytearray()
    blocks = []
    for mtype, (name, fmt, cols, rate) in defs.items():
        sfmt = "<" + "".join(struct_of[c] for c in fmt)
        length = 3 + struct.calcsize(sfmt)
        head += b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", mtype, length, name.encode(),
                                              fmt.encode(), cols.encode())
        n = int(seconds * rate)
        us = (np.arange(n) * (1e6 / rate)).astype(np.uint64) + 1_000_000
        body = np.zeros((n, length), np.uint8)
        body[:, 0], body[:, 1], body[:, 2] = 0xA3, 0x95, mtype
        body[:, 3:11] = us.view(np.uint8).reshape(n, 8)
        fill = np.random.default_rng(mtype).integers(0, 255, (n, length - 11), dtype=np.uint8)
        body[:, 11:] = fill
        blocks.append((us, body))
    us = np.concatenate([b[0] for b in blocks])
    rows = np.concatenate([b[1].reshape(-1) for b in blocks])
    sizes = np.concatenate([np.full(b[0].size, b[1].shape[1]) for b in blocks])
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    order = np.argsort(us, kind="stable")
    z = sizes[order]
    out_starts = np.cumsum(z) - z
    idx = np.arange(z.sum()) - np.repeat(out_starts, z) + np.repeat(starts[order], z)
    path.write_bytes(bytes(head) + rows[idx].tobytes())
    return int(us.size)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=61.0, help="length of the tlog")
    parser.add_argument("--workdir", type=Path, default=Path(tempfile.gettempdir()) / "etsid_bench",
                        help="where the benchmark logs are written and kept")
    parser.add_argument("--pymavlink-limit", type=int, default=100_000,
                        help="packets read by the pymavlink loop (it is slow)")
    args = parser.parse_args()
    args.workdir.mkdir(parents=True, exist_ok=True)
    tlog = args.workdir / f"bench_{args.minutes:g}min.tlog"
    if not tlog.exists():
        start = time.perf_counter()
        write_tlog(synthetic_table(args.minutes * 60.0), tlog)
        print(f"wrote {tlog} in {time.perf_counter() - start:.1f} s")
    size = tlog.stat().st_size
    frames = tlog_count(tlog)
    print(f"tlog: {frames} frames, {size / 1e6:.1f} MB")
    measure("tlog read_log (etsid)", lambda: read_log(tlog), size, frames)
    n, wall = pymavlink_loop(tlog, args.pymavlink_limit)
    print(f"{'tlog pymavlink recv_match(type=…)':<34} {n:>9} msgs {'':>11} {wall:7.2f} s "
          f"{n / wall / 1e3:9.0f} k msg/s")

    dfile = args.workdir / "bench.bin"
    count = build_bin(dfile, seconds=1100.0)
    measure("DataFlash read_log (etsid)", lambda: read_log(dfile), dfile.stat().st_size, count)

    from pyulog import ULog

    ulg = ROOT / "tests" / "data" / "px4_cubeorange_real.ulg"
    msgs = sum(len(d.data["timestamp"]) for d in ULog(str(ulg)).data_list)
    measure("ULog read_log (etsid, real 0.9 MB)", lambda: read_log(ulg), ulg.stat().st_size,
            msgs)


if __name__ == "__main__":
    main()
