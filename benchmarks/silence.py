"""The longest silent stretch of each long etsid command, output not on a terminal.

Runs the README's commands on the bundled samples with stdout and stderr piped (as in a CI
log or ``| tee``), stamps every line on arrival and prints, per command, its wall time and
the longest time without a line (from the start, between lines, and up to the end).
Progress lines come from etsid.progress: a step still running after 2 s says so.

    python benchmarks/silence.py [--out DIR] [--only identify,report,...]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from itertools import pairwise
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def commands(out: Path) -> dict[str, list[str]]:
    """The README's commands (and simulate, control, batch) on the bundled samples."""
    bag = str(ROOT / "sample_logs" / "hexa_ige_oge.bag")
    return {
        "inspect": ["inspect", bag],
        "identify": ["identify", bag, "--out", str(out / "demo"), "--vehicle", "tarot680"],
        "report": ["report", str(out / "demo")],
        "gap": ["gap", str(ROOT / "sample_logs" / "low_hover_1.parquet"),
                str(ROOT / "sample_logs" / "low_hover_2.parquet"), "--out", str(out / "gap")],
        "simulate": ["simulate", "steps", "-o", str(out / "sim.tlog"), "--duration", "30"],
        "control": ["control", "sine-altitude", "--out", str(out / "control")],
        "batch": ["batch", "identify", bag, str(ROOT / "sample_logs" / "hexa_ige_oge.tlog"),
                  "--out", str(out / "fleet"), "-j", "2"],
        "fleet report": ["report", str(out / "fleet")],
    }


def stamped(args: list[str]) -> tuple[float, float, list[tuple[float, str]]]:
    """Run ``etsid ARGS`` piped; return wall time, longest silence and the stamped lines."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "etsid", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    lines: list[tuple[float, str]] = []
    lock = threading.Lock()

    def pump(stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            with lock:
                lines.append((time.monotonic() - start, line.rstrip("\n")))

    threads = [threading.Thread(target=pump, args=(s,)) for s in (proc.stdout, proc.stderr)]
    for thread in threads:
        thread.start()
    proc.wait()
    for thread in threads:
        thread.join()
    wall = time.monotonic() - start
    times = [0.0, *sorted(t for t, _ in lines), wall]
    longest = max(b - a for a, b in pairwise(times))
    if proc.returncode:
        print(f"  exit code {proc.returncode}", file=sys.stderr)
    return wall, longest, sorted(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="Work folder (default: temp).")
    parser.add_argument("--only", default="", help="Comma-separated command names.")
    parser.add_argument("--lines", action="store_true", help="Print every stamped line.")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="etsid-silence-"))
    only = {s.strip() for s in args.only.split(",") if s.strip()}
    print(f"{'command':<14} {'wall s':>7} {'longest silence s':>18}")
    for name, argv in commands(out).items():
        if only and name not in only:
            continue
        wall, longest, lines = stamped(argv)
        print(f"{name:<14} {wall:>7.1f} {longest:>18.1f}", flush=True)
        if args.lines:
            for t, line in lines:
                print(f"    {t:6.1f}  {line[:110]}")


if __name__ == "__main__":
    main()
