"""Benchmark the ROS bag and MCAP readers: messages/s, MB/s and peak memory of read_log.

Writes large logs with etsid's own writers (MAVROS topics: Imu 100 Hz, RC in/out 25 Hz,
attitude target 50 Hz, range 20 Hz, velocity 30 Hz, battery 2 Hz ≈ 252 messages per
flight second), then reads each one with ``read_log`` in a fresh process (peak RSS is
that process's ``VmHWM``).

Usage::

    python benchmarks/ingest_ros.py                 # ROS 1 bag ≥ 1 M messages, others 1/4
    python benchmarks/ingest_ros.py --messages 200000 --scale 1
    python benchmarks/ingest_ros.py --dir bench_logs    # keep (and reuse) the written logs
    ETSID_ROS_FAST=0 python benchmarks/ingest_ros.py --dir bench_logs   # per-message path only

The load average (``/proc/loadavg``) is printed before and after: the figures are only
comparable at similar load.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

MESSAGES_PER_SECOND = 252.0


def flight_table(seconds: float, rate: float = 250.0) -> pd.DataFrame:
    """A smooth synthetic FlightTable of ``seconds`` s with every column the writers use."""
    t = np.arange(int(seconds * rate)) / rate
    w = 2 * np.pi
    cols = {"p": 0.8 * np.sin(w * 0.7 * t), "q": -0.6 * np.sin(w * 0.5 * t),
            "r": 0.5 * np.cos(w * 0.3 * t), "roll": 0.3 * np.sin(w * 0.2 * t),
            "pitch": -0.2 * np.sin(w * 0.15 * t), "yaw": np.angle(np.exp(1j * 0.3 * t)),
            "u_roll": 0.5 * np.sin(w * 0.2 * t), "u_pitch": -0.4 * np.sin(w * 0.25 * t),
            "u_yaw": 0.3 * np.cos(w * 0.1 * t), "u_thrust": 0.55 + 0.2 * np.sin(w * 0.1 * t),
            "sp_p": 0.5 * np.sin(w * 0.3 * t), "sp_q": -0.4 * np.sin(w * 0.2 * t),
            "sp_r": 0.3 * np.cos(w * 0.25 * t), "alt": 2.0 + np.sin(w * 0.01 * t),
            "vx": np.sin(w * 0.1 * t), "vy": -np.cos(w * 0.12 * t), "vz": 0.1 * t % 1,
            "ax": np.sin(w * 0.4 * t), "ay": -np.cos(w * 0.3 * t), "az": -9.81 + 0 * t,
            "vbat": 16.0 - 1e-4 * t}
    for i in range(1, 7):
        cols[f"m{i}"] = 0.5 + 0.2 * np.sin(w * 0.15 * t + i)
    table = pd.DataFrame(cols, index=pd.Index(t, name="t"))
    table.attrs["start_time"] = 1.7e9
    return table


NAMES = {"ros1": "bench_{n}.bag", "ros2-db3": "bench_{n}_db3", "ros2-mcap": "bench_{n}_mcapbag",
         "mcap": "bench_{n}.mcap"}


def write(fmt: str, table: pd.DataFrame, out: Path, n: int = 0) -> Path:
    """Write ``table`` in ``fmt`` under ``out`` (name tagged with ``n``); returns the path."""
    from etsid.sim.writers.mcapfile import write_mcap
    from etsid.sim.writers.rosbag import write_ros1_bag, write_ros2_bag

    path = out / NAMES[fmt].format(n=n)
    if fmt == "ros1":
        return write_ros1_bag(table, path)
    if fmt in ("ros2-db3", "ros2-mcap"):
        return write_ros2_bag(table, path, storage="sqlite3" if fmt == "ros2-db3" else "mcap")
    return write_mcap(table, path, encoding="ros2")


def measure(path: Path) -> dict[str, float]:
    """Read ``path`` once (run in a child process); time, messages, peak RSS."""
    from etsid.ingest import read_log, read_raw

    base = _peak_rss_mb()
    start = time.perf_counter()
    table = read_log(path)
    seconds = time.perf_counter() - start
    peak = _peak_rss_mb()
    try:
        from etsid.ingest.ros.fast.decode import STATS

        fast = STATS["fast"]
    except ImportError:  # an etsid without the vectorised path
        fast = 0
    raw = read_raw(path)
    size = sum(p.stat().st_size for p in path.iterdir()) if path.is_dir() else path.stat().st_size
    return {"seconds": seconds, "messages": sum(c.count for c in raw.channels),
            "bytes": size, "rows": len(table), "peak_mb": peak, "start_mb": base,
            "fast": fast}


def _load() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def _peak_rss_mb() -> float:
    """Peak resident memory of this process, MB (VmHWM; ru_maxrss survives fork+exec)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=1_000_000,
                        help="messages in the ROS 1 bag (default 1 M)")
    parser.add_argument("--scale", type=float, default=0.25,
                        help="messages in the other formats, as a fraction of --messages")
    parser.add_argument("--dir", type=Path,
                        help="write the logs here and reuse those already there")
    parser.add_argument("--formats", default="ros1,ros2-db3,ros2-mcap,mcap",
                        help="comma-separated subset of ros1,ros2-db3,ros2-mcap,mcap")
    parser.add_argument("--read", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.read:
        print(json.dumps(measure(args.read)))
        return
    rows = []
    print(f"load average before: {_load()}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.dir or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        for fmt in args.formats.split(","):
            n = args.messages if fmt == "ros1" else int(args.messages * args.scale)
            path = out_dir / NAMES[fmt].format(n=n)
            t0 = time.perf_counter()
            if not path.exists():
                path = write(fmt, flight_table(n / MESSAGES_PER_SECOND), out_dir, n)
            wrote = time.perf_counter() - t0
            # a fresh process per log: its VmHWM is this read's peak memory alone
            out = subprocess.run([sys.executable, __file__, "--read", str(path)],
                                 capture_output=True, text=True, check=True)
            res = json.loads(out.stdout)
            rows.append((fmt, res["messages"], res["bytes"] / 1e6, res["seconds"],
                         res["messages"] / res["seconds"], res["bytes"] / 1e6 / res["seconds"],
                         res["peak_mb"], wrote))
            print(f"{fmt:10s} {res['messages']:>9d} msgs {res['bytes'] / 1e6:7.1f} MB  "
                  f"read {res['seconds']:6.2f} s  {rows[-1][4]:9.0f} msg/s  "
                  f"{rows[-1][5]:6.1f} MB/s  peak {res['peak_mb']:6.0f} MB "
                  f"(at start {res['start_mb']:.0f})  vectorised {res['fast']:,} msgs  "
                  f"(write {wrote:.1f} s)", flush=True)
    print(f"load average after: {_load()}")
    print("\n| format | messages | size MB | read s | messages/s | MB/s | peak RSS MB |")
    print("|---|---|---|---|---|---|---|")
    for fmt, n, mb, sec, mps, mbs, peak, _ in rows:
        print(f"| {fmt} | {n:,} | {mb:.1f} | {sec:.2f} | {mps:,.0f} | {mbs:.1f} | {peak:.0f} |")


if __name__ == "__main__":
    main()
