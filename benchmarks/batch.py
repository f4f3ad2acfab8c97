"""``etsid batch identify`` over a simulated fleet: throughput, CPU efficiency, determinism.

Run:  python benchmarks/batch.py [--logs 200] [--duration 25] [--jobs 1,2] [--repeat 3] [--dask]
      python benchmarks/batch.py --logs 2000 --duration 8 --jobs 2 --report   (a fleet at scale)
      python benchmarks/batch.py --report-only DIR   (etsid report on a kept batch directory)

1. Writes a fleet of ``--logs`` simulated flights (``etsid.sim.simulate`` +
   ``etsid.sim.writers.write_log``) in mixed formats — tlog, ROS 1 bag, ROS 2 bag directory
   (sqlite3), MCAP — and scenarios, ``--duration`` s ±20 % each, plus ``--broken`` broken
   logs (garbage, an empty file, a truncated bag, a flight too short to identify). The
   fleet is kept in ``--fleet`` (default: a temporary directory) and reused when it exists.
2. Runs ``run_batch`` (what ``etsid batch identify`` calls) once per ``--jobs`` value on the
   local process pool, and with ``--dask`` on a Dask LocalCluster (``--scheduler
   processes``) with the largest job count; ``--repeat`` times, the job counts back to
   back in each round (on a shared machine, compare medians).
3. Prints throughput in logs/min, the speed-up and the CPU efficiency against ``--jobs 1``
   (efficiency = speed-up / jobs; "workers busy" = summed per-log wall time / (jobs × batch
   wall time); per-log CPU = the worker's CPU time per log, median; parent CPU = CPU time of
   the submitting process, all its threads, and the cores it kept busy on average — with
   ``--jobs 1`` that is the whole batch, and more than one core when BLAS runs threads),
   medians over the rounds, the peak memory per worker against
   the largest log, and
   checks that every run gives the same rows bit for bit (all columns but wall time, peak
   memory, worker and finish time) and that every broken log is an error row.
4. Prints the peak memory of this (the submitting) process, the results dataset's file
   count and size, and with ``--report`` the time of ``etsid report`` on the last batch
   (from scratch: the ten best and worst flights' own reports are written too).
   ``--report-only DIR`` times only ``etsid report DIR`` on a batch directory kept from an
   earlier run, from scratch and then again (the flights' reports reused).
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from etsid.batch import VOLATILE, BatchSpec, default_jobs, find_inputs, read_results, run_batch
from etsid.batch.worker import peak_memory_mb, reset_peak_memory
from etsid.ident import IdentConfig
from etsid.ingest import ReadOptions

FORMATS = (".tlog", ".bag", ".db3", ".mcap")
SCENARIOS = ("hover-ige", "steps", "forward-flight", "sine-altitude", "hover-oge")


def _write_one(args: tuple[Path, int, float]) -> str:
    from etsid.sim import simulate
    from etsid.sim.writers import write_log

    root, index, duration = args
    scenario = SCENARIOS[index % len(SCENARIOS)]
    suffix = FORMATS[(index // len(SCENARIOS)) % len(FORMATS)]
    flight = simulate(scenario, duration=duration, seed=index)
    return str(write_log(flight.table, root / f"flight{index:04d}-{scenario}{suffix}"))


def make_fleet(root: Path, n: int, duration: float, broken: int, jobs: int) -> list[str]:
    """Simulated fleet in ``root`` (made once; reused when ``root/done`` exists)."""
    if (root / "done").exists():
        return find_inputs([root])
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    durations = duration * rng.uniform(0.8, 1.2, n - broken)
    with ProcessPoolExecutor(jobs) as pool:
        written = list(pool.map(_write_one, [(root, i, float(d))
                                             for i, d in enumerate(durations)]))
    bad = root / "broken"
    bad.mkdir(exist_ok=True)
    makers = [
        lambda i: (bad / f"garbage{i}.tlog").write_bytes(b"\xfe\x09" + bytes(range(200))),
        lambda i: (bad / f"empty{i}.ulg").write_bytes(b""),
        lambda i: (bad / f"truncated{i}.bag").write_bytes(
            Path(next(w for w in written if w.endswith(".bag"))).read_bytes()[:3000]),
        lambda i: _short_flight(bad / f"short{i}.tlog"),
    ]
    for i in range(broken):
        makers[i % len(makers)](i)
    (root / "done").write_text("")
    return find_inputs([root])


def _short_flight(path: Path) -> None:
    from etsid.sim import simulate
    from etsid.sim.writers import write_log

    write_log(simulate("steps", duration=0.3, seed=1).table, path)


START_MB = 0.0
PARENT_PEAK_MB: list[float] = []
"""Peak resident memory of this process (the batch's parent) during each batch, MB."""


def timed_batch(logs: list[str], out: Path, jobs: int, scheduler: str) -> tuple[float, float]:
    """Wall time and this process's CPU time of one batch into ``out`` (fresh), s."""
    shutil.rmtree(out, ignore_errors=True)
    spec = BatchSpec("identify", read_options=ReadOptions(), ident_config=IdentConfig())
    reset_peak_memory()
    wall, cpu = time.perf_counter(), time.process_time()
    run_batch(logs, spec, out, jobs=jobs, scheduler=scheduler)
    PARENT_PEAK_MB.append(peak_memory_mb())
    return time.perf_counter() - wall, time.process_time() - cpu


def time_report(batch_dir: Path, fresh: bool) -> None:
    """Time ``etsid report DIR`` in a child process; ``fresh``: without the fleet report
    and the ranked flights' own reports of an earlier run (they are written again)."""
    if fresh:
        shutil.rmtree(batch_dir / "report", ignore_errors=True)
        for old in (batch_dir / "runs").glob("*/*/report"):
            shutil.rmtree(old)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    # PYTHONSAFEPATH: `python -m` would put the current directory first on sys.path, and
    # run from a checkout the report would be that checkout's, not PYTHONPATH's etsid
    done = subprocess.run([sys.executable, "-m", "etsid", "report", str(batch_dir)],
                          capture_output=True, text=True,
                          env={**os.environ, "PYTHONSAFEPATH": "1"})
    wall = time.perf_counter() - t0
    flights = len(list((batch_dir / "runs").glob("*/*/report/index.html")))
    print(f"etsid report {batch_dir.name} ({'from scratch' if fresh else 'again'}): "
          f"{wall:.1f} s, exit {done.returncode}, {flights} flight reports, load "
          f"{load:.1f} -> {os.getloadavg()[0]:.1f} {done.stderr.strip()[-300:]}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=int, default=200, help="fleet size (with the broken)")
    parser.add_argument("--duration", type=float, default=25.0, help="mean flight, s")
    parser.add_argument("--broken", type=int, default=6, help="broken logs in the fleet")
    parser.add_argument("--jobs", default=None, help="comma-separated job counts "
                        "(default: 1 and every core)")
    parser.add_argument("--repeat", type=int, default=1, help="rounds of every job count")
    parser.add_argument("--dask", action="store_true", help="also a Dask LocalCluster run")
    parser.add_argument("--fleet", type=Path, default=None, help="fleet directory (kept)")
    parser.add_argument("--report", action="store_true",
                        help="time `etsid report` on the last batch directory")
    parser.add_argument("--report-only", type=Path, default=None, metavar="DIR",
                        help="only time `etsid report` on this existing batch directory "
                             "(e.g. kept from an earlier run), from scratch and again")
    args = parser.parse_args()
    if args.report_only is not None:
        time_report(args.report_only, fresh=True)
        time_report(args.report_only, fresh=False)
        return
    cores = default_jobs()
    jobs = sorted({int(j) for j in args.jobs.split(",")} if args.jobs else {1, cores})
    work = Path(tempfile.mkdtemp(prefix="etsid-batch-bench-"))
    fleet = args.fleet or work / "fleet"
    t0 = time.perf_counter()
    logs = make_fleet(fleet, args.logs, args.duration, args.broken, cores)
    sizes = {p: sum(f.stat().st_size for f in Path(p).rglob("*") if f.is_file())
             if Path(p).is_dir() else Path(p).stat().st_size for p in logs}
    print(f"# {platform.machine()}, {os.cpu_count()} cpus ({cores} usable), python "
          f"{platform.python_version()}, load {os.getloadavg()[0]:.1f}")
    print(f"fleet: {len(logs)} logs ({args.broken} broken), {sum(sizes.values()) / 2**20:.0f} "
          f"MB, largest {max(sizes.values()) / 2**20:.1f} MB, made in "
          f"{time.perf_counter() - t0:.0f} s ({fleet})")
    global START_MB
    reset_peak_memory()
    START_MB = peak_memory_mb()  # resident now
    runs = [(j, "local") for j in jobs] + ([(max(jobs), "processes")] if args.dask else [])
    results = {}
    walls: dict[tuple[int, str], list[float]] = {run: [] for run in runs}
    for round_ in range(args.repeat):
        for j, scheduler in runs:
            out = work / f"out-{scheduler}-{j}"
            wall, parent_cpu = timed_batch(logs, out, j, scheduler)
            frame = read_results(out)
            results[(j, scheduler, round_)] = frame
            walls[(j, scheduler)].append(wall)
            base = walls.get((1, "local"), [])
            speedup = base[-1] / wall if base else float("nan")
            busy = frame["wall_s"].sum() / (j * wall) * 100
            print(f"{scheduler:>9} jobs {j}: {wall:7.1f} s wall, "
                  f"{len(logs) / wall * 60:6.1f} logs/min, speed-up {speedup:4.2f}, "
                  f"efficiency {speedup / j * 100:5.1f} % of linear, workers busy "
                  f"{busy:4.1f} %; per-log CPU {frame['cpu_s'].median():.3f} s, parent CPU "
                  f"{parent_cpu:.1f} s ({parent_cpu / wall:.2f} cores); peak memory per "
                  "worker max "
                  f"{frame['peak_rss_mb'].max():.0f} MB, median "
                  f"{frame['peak_rss_mb'].median():.0f} MB; load {os.getloadavg()[0]:.1f}",
                  flush=True)
    if args.repeat > 1 and (1, "local") in walls:
        base = float(np.median(walls[(1, "local")]))
        for (j, scheduler), values in walls.items():
            wall = float(np.median(values))
            print(f"median of {args.repeat}: {scheduler:>9} jobs {j}: {wall:7.1f} s wall, "
                  f"{len(logs) / wall * 60:6.1f} logs/min, speed-up {base / wall:4.2f}, "
                  f"efficiency {base / wall / j * 100:5.1f} % of linear")
    last = work / f"out-{runs[-1][1]}-{runs[-1][0]}"
    files = list((last / "results").rglob("*.parquet"))
    print(f"parent peak memory during the batches {max(PARENT_PEAK_MB):.0f} MB (resident "
          f"before the first {START_MB:.0f} MB); results dataset {len(files)} files, "
          f"{sum(f.stat().st_size for f in files) / 2**20:.1f} MB ({last / 'results'})")
    if args.report:
        time_report(last, fresh=True)
    frames = [f.drop(columns=list(VOLATILE)) for f in results.values()]
    same = all(f.equals(frames[0]) for f in frames[1:])
    print(f"rows identical bit for bit across {len(frames)} runs (all but "
          f"{', '.join(VOLATILE)}): {same}")
    first = next(iter(results.values()))
    failed = first[first["status"] == "error"]
    broken = [p for p in logs if "/broken/" in p]
    print(f"error rows: {len(failed)} (broken logs {len(broken)}, all rows: "
          f"{set(broken) <= set(failed['input'])})")
    for _, row in failed.iterrows():
        print(f"  {Path(row['input']).name}: {row['error_kind']}: {row['error'][:110]}")
    shutil.rmtree(work / "out-local-1", ignore_errors=True)
    if not same or not set(broken) <= set(failed["input"]):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
