"""Where a Dask batch's time goes, against the local pool on the same worker count.

Run:  python benchmarks/batch.py --logs 100 --broken 4 --fleet FLEET   (once: the fleet)
      python benchmarks/batch_dask.py FLEET [--jobs 2] [--repeat 2] [--before DIR]
          [--schedulers local,processes,cli,cli-host]

Each batch (``run_batch`` of ``etsid batch identify``, as the CLI calls it) runs in a child
process, local pool and Dask LocalCluster back to back in each round. For Dask the child
loads a scheduler plugin (``distributed.scheduler.preload``: Dask's own task transitions,
with each task's compute and transfer start/stop times as the workers report them) and
prints the breakdown of the batch's wall time:

* ``start``: batch start → the first worker registered (cluster start: processes,
  imports; 0 for the command-line cluster, ``cli``, which is up before the batch starts:
  ``dask scheduler`` and ``--jobs`` ``dask worker --nthreads 1`` processes, as a user
  runs them);
* ``warm``: → the first log task starts (warming the workers, submitting);
* ``compute``: the logs' compute time (sum over tasks / workers);
* ``gaps``: worker idle time between its tasks (scheduling, argument and result
  transfer, the client's bookkeeping), summed / workers;
* ``transfer``: the part of the gaps the workers report as data transfer;
* ``tail``: the last task's end → the batch's end (closing the cluster).

Also per-log CPU (the worker's CPU time during each log, median) and peak worker memory
(VmHWM per log; max and median). ``--before DIR`` runs the same on another etsid checkout
(``git archive REV | tar -x -C DIR``) so a change is measured back to back with it.

Memory, compared fairly: a pool worker is forked from a server and shares its pages, so
its resident memory (RSS) counts only the shared pages it touched, while a process started
on its own counts every page of the libraries it loaded. The child samples every process
it started (not the scheduler) every second with psutil's ``memory_full_info`` and
reports, per worker process (median over the workers), the peak RSS, USS (pages only it
holds: what it costs on its own) and PSS (RSS with each shared page divided among the
processes sharing it), and the peak of the summed PSS of all of them (workers, fork
server, nannies) per worker. ``cli-host`` is the command-line cluster started as
docs/batch.md recommends: one ``dask worker --nworkers JOBS --preload-nanny
etsid.batch.dask_host``.

The 1-min load average before and after each run is printed with it: on a shared machine
a round whose load is far above the batch's own ``jobs`` compares the engines under an
unknown share of the cores. The summary gives each Dask run against the pool of the same
round (throughput = pool wall / Dask wall), median and range over the rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from itertools import pairwise
from pathlib import Path

import numpy as np

PLUGIN = '''
import json, os, time
from distributed.diagnostics.plugin import SchedulerPlugin

class Breakdown(SchedulerPlugin):
    name = "etsid-bench-breakdown"

    def __init__(self):
        self.t0 = time.time()
        self.workers = []
        self.tasks = []

    def add_worker(self, scheduler=None, worker=None, **kwargs):
        self.workers.append(time.time())

    def transition(self, key, start, finish, *args, **kwargs):
        if finish == "memory" and "run_" in str(key):
            self.tasks.append({"worker": kwargs.get("worker"),
                               "startstops": kwargs.get("startstops") or []})

    def close(self):
        with open(os.environ["ETSID_BENCH_BREAKDOWN"], "w") as handle:
            json.dump({"t0": self.t0, "workers": self.workers, "tasks": self.tasks}, handle)

def dask_setup(scheduler):
    scheduler.add_plugin(Breakdown())
'''

CHILD = '''
import json, os, sys, threading, time
import dask
import psutil
from etsid.batch import BatchSpec, find_inputs, read_results, run_batch
from etsid.ident import IdentConfig
from etsid.ingest import ReadOptions

def cli_cluster(jobs, plugin, host_preload):
    """`dask scheduler` (with the breakdown plugin) and the workers: `jobs` `dask worker
    --nthreads 1` commands (each with its nanny), or with `host_preload` one `dask worker
    --nworkers jobs --preload-nanny etsid.batch.dask_host` (workers forked from a warm
    server)."""
    import socket, subprocess
    from pathlib import Path
    from dask.distributed import Client
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    dask_cli = str(Path(sys.executable).with_name("dask"))
    procs = [subprocess.Popen([dask_cli, "scheduler", "--host", "127.0.0.1", "--port",
                               str(port), "--no-dashboard", "--preload", plugin],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    worker = [dask_cli, "worker", address, "--nthreads", "1", "--no-dashboard", "--host",
              "127.0.0.1"]
    if host_preload:
        worker += ["--nworkers", str(jobs), "--preload-nanny", "etsid.batch.dask_host"]
    procs += [subprocess.Popen(worker, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
              for _ in range(1 if host_preload else jobs)]
    with Client(address, timeout="60s") as client:
        client.wait_for_workers(jobs, timeout=300)
    return address, procs


class Memory(threading.Thread):
    """Peak RSS, USS and PSS of every process this one started (but the scheduler),
    sampled every second, and the peak of their summed PSS."""

    def __init__(self, skip):
        super().__init__(daemon=True)
        self.skip, self.peak, self.total, self.running = skip, {}, 0.0, True

    def run(self):
        me = psutil.Process()
        while self.running:
            total = 0.0
            for proc in me.children(recursive=True):
                if proc.pid in self.skip:
                    continue
                try:
                    mem = proc.memory_full_info()
                except psutil.Error:
                    continue
                old = self.peak.get(proc.pid, (0, 0, 0))
                self.peak[proc.pid] = (max(old[0], mem.rss), max(old[1], mem.uss),
                                       max(old[2], mem.pss))
                total += mem.pss
            self.total = max(self.total, total)
            time.sleep(1.0)


if __name__ == "__main__":
    fleet, out, jobs, scheduler, plugin = sys.argv[1:6]
    procs = []
    if scheduler in ("cli", "cli-host"):
        scheduler, procs = cli_cluster(int(jobs), plugin, scheduler == "cli-host")
    else:
        dask.config.set({"distributed.scheduler.preload": [plugin]})
    memory = Memory({p.pid for p in procs[:1]})
    memory.start()
    logs = find_inputs([fleet])
    spec = BatchSpec("identify", read_options=ReadOptions(), ident_config=IdentConfig())
    start = time.time()
    run_batch(logs, spec, out, jobs=int(jobs), scheduler=scheduler)
    end = time.time()
    memory.running = False
    memory.join()
    for proc in procs[1:] + procs[:1]:  # workers first, then the scheduler (its plugin)
        proc.terminate()
        proc.wait(timeout=60)
    rows = read_results(out)
    workers = {int(w.rsplit(":", 1)[1]) for w in rows["worker"].dropna()}
    mb = 2 ** 20
    print(json.dumps({"start": start, "end": end, "logs": len(logs),
                      "cpu": rows["cpu_s"].tolist(), "wall": rows["wall_s"].tolist(),
                      "rss": rows["peak_rss_mb"].tolist(),
                      "workers": [[v / mb for v in m] for pid, m in memory.peak.items()
                                  if pid in workers],
                      "others": [[v / mb for v in m] for pid, m in memory.peak.items()
                                 if pid not in workers],
                      "pss_total": memory.total / mb}))
'''


def breakdown(run: dict, trace: dict, jobs: int) -> dict[str, float]:
    """Phases of one Dask batch, s (see the module docstring)."""
    starts, stops, compute, transfer = [], [], 0.0, 0.0
    per_worker: dict[str, list[tuple[float, float]]] = {}
    for task in trace["tasks"]:
        for part in task["startstops"]:
            span = part["stop"] - part["start"]
            if part["action"] == "compute":
                compute += span
                starts.append(part["start"])
                stops.append(part["stop"])
                per_worker.setdefault(task["worker"], []).append((part["start"], part["stop"]))
            elif part["action"] == "transfer":
                transfer += span
    gaps = 0.0
    for spans in per_worker.values():
        spans.sort()
        gaps += sum(max(0.0, b[0] - a[1]) for a, b in pairwise(spans))
    # a command-line cluster is up before the batch: its start is 0
    first_worker = max(min(trace["workers"]), run["start"]) if trace["workers"] \
        else run["start"]
    return {"wall": run["end"] - run["start"], "start": first_worker - run["start"],
            "warm": min(starts) - first_worker, "compute": compute / jobs,
            "gaps": gaps / jobs, "transfer": transfer / jobs,
            "tail": run["end"] - max(stops), "tasks": len(starts)}


def run_child(code: Path, fleet: Path, jobs: int, scheduler: str, work: Path) -> dict:
    out = work / f"out-{scheduler}"
    trace = work / "trace.json"
    trace.unlink(missing_ok=True)
    env = {**os.environ, "PYTHONPATH": str(code), "ETSID_BENCH_BREAKDOWN": str(trace)}
    done = subprocess.run([sys.executable, str(work / "child.py"), str(fleet), str(out),
                           str(jobs), scheduler, str(work / "plugin.py")], env=env,
                          capture_output=True, text=True, cwd=work, timeout=3600)
    if done.returncode != 0:
        raise SystemExit(done.stderr[-3000:])
    run = json.loads(done.stdout.strip().splitlines()[-1])
    result = {"wall": run["end"] - run["start"], "logs/min": run["logs"] / (
        run["end"] - run["start"]) * 60, "cpu/log": float(np.median(run["cpu"])),
        "busy": sum(run["wall"]) / (jobs * (run["end"] - run["start"])),
        "rss max": max(run["rss"]), "rss median": float(np.median(run["rss"]))}
    # sampled every second by the child: per worker process (median over the workers),
    # and the sum of PSS over every process the run started (workers, fork server,
    # nannies; not the scheduler, not the batch process) per worker
    for i, name in enumerate(("rss", "uss", "pss")):
        result[f"worker {name}"] = float(np.median([m[i] for m in run["workers"]])) \
            if run["workers"] else float("nan")
    result["others pss"] = sum(m[2] for m in run["others"])
    result["host pss/worker"] = run["pss_total"] / jobs
    if scheduler != "local" and trace.exists():
        result.update(breakdown(run, json.loads(trace.read_text()), jobs))
    import shutil

    shutil.rmtree(out, ignore_errors=True)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fleet", type=Path)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--schedulers", default="local,processes,cli",
                        help="local (the pool), processes (LocalCluster), cli (dask "
                             "scheduler + one dask worker command per worker, up before "
                             "the batch), cli-host (one dask worker --nworkers JOBS "
                             "--preload-nanny etsid.batch.dask_host)")
    parser.add_argument("--before", type=Path, default=None,
                        help="another etsid checkout, measured back to back")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="etsid-batch-dask-"))
    (work / "child.py").write_text(CHILD)
    (work / "plugin.py").write_text(PLUGIN)
    here = Path(__file__).resolve().parents[1]
    codes = [("before", args.before.resolve())] if args.before else []
    codes.append(("now", here))
    print(f"# {os.cpu_count()} cpus, load {os.getloadavg()[0]:.1f}; fleet {args.fleet}; "
          f"{args.jobs} workers")
    results: dict[tuple[str, str], list[dict]] = {}
    for round_ in range(args.repeat):
        for label, code in codes:
            for scheduler in args.schedulers.split(","):
                if scheduler == "cli-host" and not (code / "etsid/batch/dask_host.py").exists():
                    continue  # a checkout from before the host preload
                t0, load = time.perf_counter(), os.getloadavg()[0]
                got = run_child(code, args.fleet, args.jobs, scheduler, work)
                # the 1-min load average before and after (the batch itself adds ~jobs)
                got["load"] = max(load, os.getloadavg()[0])
                results.setdefault((label, scheduler), []).append(got)
                print(f"round {round_ + 1} {label:>6} {scheduler:>9}: "
                      + ", ".join(f"{k} {v:.3g}" for k, v in got.items())
                      + f" (child {time.perf_counter() - t0:.0f} s)", flush=True)
    print("\nmedians over the rounds; Dask against the local pool of the same round "
          "(throughput = pool wall / Dask wall), median [min–max]:")
    for (label, scheduler), runs in results.items():
        med = {k: float(np.median([r[k] for r in runs])) for k in runs[0]}
        print(f"{label:>6} {scheduler:>9}: " + ", ".join(f"{k} {v:.3g}" for k, v in med.items()))
        if scheduler == "local":
            continue
        local = results[(label, "local")]
        for key, name in (("wall", "throughput"), ("cpu/log", "per-log CPU"),
                          ("rss max", "peak RSS (VmHWM)"), ("worker rss", "worker RSS"),
                          ("worker uss", "worker USS"), ("worker pss", "worker PSS"),
                          ("host pss/worker", "all processes' PSS per worker")):
            pairs = [(a[key], b[key]) for a, b in zip(local, runs, strict=False)]
            ratios = [pool / dask if key == "wall" else dask / pool for pool, dask in pairs]
            unit, scale = ("%", 100) if key == "wall" else ("x", 1)
            print(f"{'':>17}{name}: {np.median(ratios) * scale:.3g} {unit} of the pool's "
                  f"[{min(ratios) * scale:.3g}–{max(ratios) * scale:.3g}]")

if __name__ == "__main__":
    main()
