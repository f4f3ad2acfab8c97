"""Benchmark the ROS bag and MCAP readers: messages/s, MB/s and peak memory of read_log.

Writes large logs with etsid's own writers (MAVROS topics: Imu 100 Hz, RC in/out 25 Hz,
attitude target 50 Hz, range 20 Hz, velocity 30 Hz, battery 2 Hz ≈ 252 messages per
flight second), then reads each one with ``read_log`` in a fresh process (peak RSS is
that process's ``VmHWM``).

Usage::

    python benchmarks/ingest_ros.py                 # ROS 1 bag ≥ 1 M messages, others 1/4
    python benchmarks/ingest_ros.py --messages 200000 --scale 1
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


def write(fmt: str, table: pd.DataFrame, out: Path) -> Path:
    """Write ``table`` in ``fmt`` under ``out``; returns the log path."""
    from etsid.sim.writers.mcapfile import write_mcap
    from etsid.sim.writers.rosbag import write_ros1_bag, write_ros2_bag

    if fmt == "ros1":
        return write_ros1_bag(table, out / "bench.bag")
    if fmt == "ros2-db3":
        return write_ros2_bag(table, out / "bench_db3", storage="sqlite3")
    if fmt == "ros2-mcap":
        return write_ros2_bag(table, out / "bench_mcapbag", storage="mcap")
    return write_mcap(table, out / "bench.mcap", encoding="ros2")


def measure(path: Path) -> dict[str, float]:
    """Read ``path`` once (run in a child process); time, messages, peak RSS."""
    from etsid.ingest import read_log, read_raw

    start = time.perf_counter()
    table = read_log(path)
    seconds = time.perf_counter() - start
    peak = _peak_rss_mb()
    raw = read_raw(path)
    size = sum(p.stat().st_size for p in path.iterdir()) if path.is_dir() else path.stat().st_size
    return {"seconds": seconds, "messages": sum(c.count for c in raw.channels),
            "bytes": size, "rows": len(table),
            "peak_mb": peak}


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
    parser.add_argument("--read", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.read:
        print(json.dumps(measure(args.read)))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("ros1", "ros2-db3", "ros2-mcap", "mcap"):
            n = args.messages if fmt == "ros1" else int(args.messages * args.scale)
            table = flight_table(n / MESSAGES_PER_SECOND)
            t0 = time.perf_counter()
            path = write(fmt, table, Path(tmp))
            wrote = time.perf_counter() - t0
            out = subprocess.run([sys.executable, __file__, "--read", str(path)],
                                 capture_output=True, text=True, check=True)
            res = json.loads(out.stdout)
            rows.append((fmt, res["messages"], res["bytes"] / 1e6, res["seconds"],
                         res["messages"] / res["seconds"], res["bytes"] / 1e6 / res["seconds"],
                         res["peak_mb"], wrote))
            print(f"{fmt:10s} {res['messages']:>9d} msgs {res['bytes'] / 1e6:7.1f} MB  "
                  f"read {res['seconds']:6.2f} s  {rows[-1][4]:9.0f} msg/s  "
                  f"{rows[-1][5]:6.1f} MB/s  peak {res['peak_mb']:6.0f} MB  "
                  f"(write {wrote:.1f} s)", flush=True)
    print("\n| format | messages | size MB | read s | messages/s | MB/s | peak RSS MB |")
    print("|---|---|---|---|---|---|---|")
    for fmt, n, mb, sec, mps, mbs, peak, _ in rows:
        print(f"| {fmt} | {n:,} | {mb:.1f} | {sec:.2f} | {mps:,.0f} | {mbs:.1f} | {peak:.0f} |")


if __name__ == "__main__":
    main()
