"""Ingest throughput for every format: runs the MAVLink-family and ROS/MCAP benchmarks.

Usage::

    python benchmarks/ingest.py            # both, default sizes (≥ 1 M messages)
    python benchmarks/ingest.py --quick    # smaller logs, for a smoke check

The figures are recorded in docs/performance.md.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    """Run both ingest benchmarks in fresh processes (so peak memory is each one's own)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller logs")
    args = parser.parse_args()
    runs = [
        [sys.executable, str(HERE / "ingest_mavlink.py")],
        [sys.executable, str(HERE / "ingest_ros.py")],
    ]
    if args.quick:
        runs[0] += ["--minutes", "2"]
        runs[1] += ["--messages", "50000"]
    status = 0
    for command in runs:
        print("$", " ".join(command[1:]), flush=True)
        status |= subprocess.call(command)
    return status


if __name__ == "__main__":
    raise SystemExit(main())
