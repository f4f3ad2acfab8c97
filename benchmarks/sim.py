"""Speed of the physics simulator: simulated seconds per wall-clock second.

Run:  python benchmarks/sim.py [--duration 300] [--repeat 3]

Prints one line per vehicle/scenario: physics rate, CPU time of ``simulate()`` (the whole
call: references, noise, compiled flight loop, DataFrames) and of the compiled loop alone,
as multiples of real time (wall-clock too; on a shared machine trust the CPU figure). The
first call compiles (or loads the numba cache) and is not timed.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from etsid.sim import simulate


def _timed_kernel() -> list[float]:
    """Wrap the compiled loop to record its own wall time."""
    times: list[float] = []
    import etsid.sim.flight as flight_mod

    inner = flight_mod.run_flight

    def wrapper(*args):
        t0 = time.process_time()
        out = inner(*args)
        times.append(time.process_time() - t0)
        return out

    flight_mod.run_flight = wrapper
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=300.0, help="simulated seconds per run")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    kernel_times = _timed_kernel()
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cpus, "
          f"python {platform.python_version()}, duration {args.duration:g} s")
    for vehicle, scenario in [("tarot680", "hover-ige"), ("tarot680", "forward-flight"),
                              ("quad250", "hover-oge")]:
        simulate(scenario, vehicle=vehicle, duration=2.0)  # compile / load cache
        walls, cpus = [], []
        kernel_times.clear()
        for seed in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            flight = simulate(scenario, vehicle=vehicle, duration=args.duration, seed=seed)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        wall, cpu = float(np.median(walls)), float(np.median(cpus))
        kern = float(np.median(kernel_times))
        hz = flight.table.attrs["physics_hz"]
        print(f"{vehicle:9s} {scenario:15s} RK4 {hz:5.0f} Hz | simulate() cpu {cpu:5.2f} s "
              f"= {args.duration / cpu:4.0f}x real time (wall {args.duration / wall:4.0f}x) | "
              f"compiled loop {args.duration / kern:4.0f}x")


if __name__ == "__main__":
    main()
