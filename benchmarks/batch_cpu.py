"""CPU time of a whole ``etsid batch identify`` — every process — per job count (Linux).

Run:  python benchmarks/batch.py --fleet FLEET        (once: makes the simulated fleet)
      python benchmarks/batch_cpu.py FLEET [--jobs 1,2] [--repeat 2]

Wall-time efficiency needs a quiet machine; CPU time does not. Each batch runs in a child
process (``run_batch`` as ``etsid batch identify`` calls it); this process makes itself the
"child subreaper", so the fork server and the pool workers, orphaned when the batch ends,
are reaped here and their CPU time counted. Prints per job count the total CPU time (user +
system) of every process, the CPU per log, and CPU efficiency = CPU of ``--jobs 1`` / CPU
of ``--jobs N`` (what parallel running costs in extra work: fork server start, imports,
numba loading, pool renewals, the parent's bookkeeping). The child's own start (Python,
imports) is in both counts alike.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

PR_SET_CHILD_SUBREAPER = 36

CHILD = """
import sys, time
from etsid.batch import BatchSpec, find_inputs, run_batch
from etsid.ident import IdentConfig
from etsid.ingest import ReadOptions
if __name__ == "__main__":
    logs = find_inputs([sys.argv[1]])
    spec = BatchSpec("identify", read_options=ReadOptions(), ident_config=IdentConfig())
    start = time.perf_counter()
    run_batch(logs, spec, sys.argv[2], jobs=int(sys.argv[3]))
    print(len(logs), time.perf_counter() - start)
"""


def tree_cpu(fleet: Path, jobs: int, work: Path) -> tuple[int, float, float]:
    """Logs, batch wall time (s) and CPU time of every process of one batch (s)."""
    script = work / "child.py"
    script.write_text(CHILD)
    out = work / f"out-{jobs}-{time.monotonic_ns()}"
    proc = subprocess.Popen([sys.executable, str(script), str(fleet), str(out), str(jobs)],
                            stdout=subprocess.PIPE, text=True)
    cpu = 0.0
    stdout = ""
    while True:  # the child, then the orphans (fork server, workers) it leaves
        try:
            pid, status, usage = os.wait4(-1, 0)
        except ChildProcessError:
            break
        cpu += usage.ru_utime + usage.ru_stime
        if pid == proc.pid:
            stdout = proc.stdout.read() if proc.stdout else ""
            if os.waitstatus_to_exitcode(status) != 0:
                raise SystemExit(f"batch with --jobs {jobs} failed")
    n, wall = stdout.split()
    return int(n), float(wall), cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fleet", type=Path, help="fleet directory (benchmarks/batch.py --fleet)")
    parser.add_argument("--jobs", default="1,2", help="comma-separated job counts")
    parser.add_argument("--repeat", type=int, default=2, help="rounds of every job count")
    args = parser.parse_args()
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        raise SystemExit("needs Linux (prctl PR_SET_CHILD_SUBREAPER)")
    jobs = [int(j) for j in args.jobs.split(",")]
    cpus: dict[int, list[float]] = {j: [] for j in jobs}
    print(f"# {os.cpu_count()} cpus, load {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory(prefix="etsid-batch-cpu-") as tmp:
        for _ in range(args.repeat):
            for j in jobs:
                n, wall, cpu = tree_cpu(args.fleet, j, Path(tmp))
                cpus[j].append(cpu)
                print(f"jobs {j}: {n} logs, CPU {cpu:6.1f} s all processes "
                      f"({cpu / n * 1000:5.0f} ms per log), batch wall {wall:6.1f} s, "
                      f"load {os.getloadavg()[0]:.1f}", flush=True)
    base = float(np.median(cpus[jobs[0]]))
    for j in jobs:
        cpu = float(np.median(cpus[j]))
        print(f"median: jobs {j}: CPU {cpu:6.1f} s, CPU efficiency against jobs {jobs[0]} "
              f"{base / cpu * 100:5.1f} %")


if __name__ == "__main__":
    main()
