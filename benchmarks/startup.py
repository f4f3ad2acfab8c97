"""Whole-process time of commands that should start at once: ``etsid --help``, every
``etsid COMMAND --help`` and ``etsid inspect`` on small logs of each format (imports, numba
cache loading and the work).

Run from the repository root::

    python benchmarks/startup.py                       # this code
    python benchmarks/startup.py --baseline ../old     # and another checkout, alternating
    python benchmarks/startup.py --only help           # the helps only (or: --only inspect)
    python benchmarks/startup.py --bytecode            # etsid's .pyc written first

Each command runs ``--repeats`` times in a fresh ``python -m etsid`` process (this code and,
with ``--baseline DIR``, the code in DIR through ``PYTHONPATH``, alternating); printed are
the best and median wall time and the best CPU time (user + system of the child). The
machine's load inflates wall times; the CPU column is the steadier figure.

With ``PYTHONDONTWRITEBYTECODE`` set (as in the sessions' shell), a checkout has no
``__pycache__`` and every run compiles etsid's modules from source (0.02–0.15 s per
command); ``--bytecode`` first runs ``python -m compileall`` on each checkout's ``etsid/``,
as an installed package has it.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LOGS = ROOT / "sample_logs"
DATA = ROOT / "tests" / "data"  # real ULog (1.9 MB) and DataFlash (1.3 MB) logs
HELPS = ["identify", "predict", "rules", "simulate", "inspect", "ingest", "report", "gap", "fit",
         "batch", "batch identify", "control"]
"""Commands whose ``--help`` is timed (``etsid batch identify`` borrows identify's options)."""

COMMANDS = [
    ["--help"],
    *([*name.split(), "--help"] for name in HELPS),
    ["inspect", "--quiet", str(LOGS / "hexa_ige_oge.tlog")],
    ["inspect", "--quiet", str(LOGS / "hexa_ige_oge.bag")],
    ["inspect", "--quiet", str(LOGS / "hexa_ige_oge.mcap")],
    ["inspect", "--quiet", str(DATA / "px4_sitl_tagged.ulg")],
    ["inspect", "--quiet", str(DATA / "ardupilot_copter403_hexa_loiter_real.bin")],
]


def once(root: Path, args: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of one ``python -m etsid ARGS`` with ``root`` on PYTHONPATH (and
    as the working directory, which ``python -m`` puts first on the path)."""
    env = dict(os.environ, PYTHONPATH=str(root))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "etsid", *args], cwd=root, env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--baseline", metavar="DIR", help="another checkout, timed alternately")
    ap.add_argument("--only", choices=("help", "inspect"), default=None,
                    help="time only the helps or only the inspects")
    ap.add_argument("--bytecode", action="store_true",
                    help="compile each checkout's etsid/ to .pyc first (as installed)")
    args = ap.parse_args()
    commands = [c for c in COMMANDS if args.only is None or (c[-1] == "--help") == (
        args.only == "help")]
    roots = {"this": ROOT}
    if args.baseline:
        roots = {"before": Path(args.baseline).resolve(), "after": ROOT}
    if args.bytecode:
        for root in roots.values():
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(root / "etsid")],
                           check=True, stdout=subprocess.DEVNULL)
    for root in roots.values():  # warm the numba caches and the OS file cache
        for cmd in commands:
            once(root, cmd)
    print("| command | code | wall best (s) | wall median (s) | CPU best (s) |")
    print("|---|---|---|---|---|")
    for cmd in commands:
        runs: dict[str, list[tuple[float, float]]] = {tag: [] for tag in roots}
        for _ in range(args.repeats):
            for tag, root in roots.items():
                runs[tag].append(once(root, cmd))
        for tag, values in runs.items():
            walls = [w for w, _ in values]
            cpu = min(c for _, c in values)
            print(f"| etsid {' '.join(cmd)} | {tag} | {min(walls):.2f} | "
                  f"{statistics.median(walls):.2f} | {cpu:.2f} |", flush=True)


if __name__ == "__main__":
    main()
