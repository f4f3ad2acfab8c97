"""Speed of replay and of the stepping API: simulated seconds per CPU second.

Run:  python benchmarks/replay.py [--duration 30] [--repeat 3] [--accuracy]

Prints, for the Tarot hexacopter (RK4 at 1000 Hz, 250 Hz log): ``replay()`` of a recorded
flight in loop mode and in motor mode (1 s horizons), ``replay_many()`` with 8 candidate
vehicles in one parallel call, and ``Simulator.step()`` called every 20 ms (an outer loop
at 50 Hz) and every 1 ms. Medians of ``--repeat`` runs, CPU time (``time.process_time``,
which adds up both cores for the parallel call) and wall time. Compilation (or the numba
cache load) happens in an untimed warm-up. ``--accuracy`` prints instead how well replay
gives back simulated flights (twin − flight, RMSE / std of the flight, per channel).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from etsid.sim import Simulator, replay, replay_many, simulate


def timed(func, repeat: int) -> tuple[float, float]:
    """Median CPU and wall seconds of ``func()``."""
    cpu, wall = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        func()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return float(np.median(cpu)), float(np.median(wall))


def line(label: str, sim_seconds: float, cpu: float, wall: float) -> None:
    print(f"{label:<44} cpu {cpu:6.3f} s = {sim_seconds / cpu:6.0f}x real time "
          f"(wall {sim_seconds / wall:6.0f}x)")


def rel(twin, flight, name: str) -> float:
    """RMSE of the twin's true signal against the flight's, over the flight's std."""
    d = twin[f"true_{name}"] - flight[f"true_{name}"]
    return float(np.sqrt(np.mean(d**2)) / np.std(flight[f"true_{name}"]))


def accuracy(duration: float) -> None:
    """Replay simulated hover-ige flights (seed 1) and print the twin's errors."""
    print(f"# twin - flight, true signals, RMSE/std; hover-ige {duration:g} s, seed 1")
    print(f"{'log rate':>8} {'mode':<28} {'p':>6} {'q':>6} {'r':>6} {'alt max err m':>14}"
          f"  {'p,q,r vs measured log':>22}")
    for rate in (250.0, 1000.0):
        flight = simulate("hover-ige", duration=duration, seed=1, rate_hz=rate)
        runs = [("loop, u_thrust", {}), ("loop, altitude hold", {"thrust": "alt_hold"}),
                ("loop, rate setpoints", {"loop_input": "rates"}),
                ("motors, 1 s horizons", {"mode": "motors", "horizon": 1.0}),
                ("motors, 0.5 s horizons", {"mode": "motors", "horizon": 0.5})]
        for label, kw in runs:
            twin = replay(flight.table, **kw)
            alt = float(np.max(np.abs(twin.truth["true_alt"] - flight.truth["true_alt"])))
            vs_log = ", ".join(f"{twin.errors[a]['ratio']:.2f}" for a in "pqr")
            print(f"{rate:>6g}Hz {label:<28} "
                  + " ".join(f"{rel(twin.truth, flight.truth, a):6.3f}" for a in "pqr")
                  + f" {alt:14.3f}  {vs_log:>22}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=30.0, help="length of the log, s")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--accuracy", action="store_true", help="print replay accuracy instead")
    args = ap.parse_args()
    if args.accuracy:
        accuracy(args.duration)
        return
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cpus, "
          f"python {platform.python_version()}, log {args.duration:g} s at 250 Hz")
    log = simulate("hover-ige", duration=args.duration, seed=1).table
    dur = args.duration
    replay(log.iloc[:500])  # warm-up
    replay(log.iloc[:500], mode="motors")
    replay_many(log.iloc[:500], [{}, {"time_delay": 0.01}])
    line("replay loop (sticks + u_thrust)", dur, *timed(lambda: replay(log), args.repeat))
    line("replay motors (1 s horizons)", dur,
         *timed(lambda: replay(log, mode="motors", horizon=1.0), args.repeat))
    cands = [{"time_delay": d} for d in np.linspace(0.0, 0.035, 8)]
    cpu, wall = timed(lambda: replay_many(log, cands), args.repeat)
    line("replay_many loop, 8 candidates (total)", 8 * dur, cpu, wall)
    sim = Simulator("tarot680", alt_hold=False)
    state = sim.hover(1.0)
    sim.step(state, 20)  # warm-up

    def outer(n_per_call: int) -> None:
        s = sim.hover(1.0)
        for _ in range(round(dur / (n_per_call * sim.dt))):
            s, _ = sim.step(s, n_per_call, thrust=0.55, record_every=n_per_call)

    for n in (20, 1):
        cpu, wall = timed(lambda n=n: outer(n), args.repeat)
        calls = round(dur / (n * sim.dt))
        line(f"Simulator.step every {n * 1000 * sim.dt:g} ms "
             f"({1e6 * cpu / calls:.0f} us/call)", dur, cpu, wall)


if __name__ == "__main__":
    main()
