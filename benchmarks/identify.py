"""Identification: throughput of a full identify run, and the quality table.

Run:  python benchmarks/identify.py [--duration 600] [--seeds 21,22,23]
      python benchmarks/identify.py --phases [--duration 600] [--keep-logs DIR]  # CPU

1. Throughput: ``etsid.ident.identify`` (defaults: 50 Hz, lags 4/6 and the roll/pitch
   states with their inner-split check, rules scheduled on ``inv_alt[k-1]`` (radius 0.3,
   evq) since the simulated log has altitude, ranges from the learning part) on a
   ``--duration`` s simulated hover-ige flight at 250 Hz. One warm-up run on a short flight
   first (numba compilation / cache load is start-up, not timed). Reports table samples/s
   (250 Hz rows in) and identification samples/s (50 Hz rows learned), CPU and wall time.
2. Quality: defaults on 60 s hover-ige flights with ``--seeds`` (not the seeds 1–3 used to
   choose the lags), validation part (last 30 %): one-step RMSE / σ (σ = the floor after
   decimation, σ_gyro/√5), free-run fit % for eTS and ARX, rules; then the same for
   forward-flight and for identification at the native 250 Hz (``ident_rate=0``).
3. ``--lag-study``: the ARX lag/rate table of docs/identify.md (seeds 1, 2, 3).
4. ``--normalise-study``: ``--normalise learn|running|apriori`` at radius 2 and ``learn``
   at radii 1.0–1.75 on hover-ige and forward-flight ``--seeds`` (online RMSE of eTS and
   ARX, validation one-step RMSE, free-run fit, rules; means over seeds), rules on the
   regressors (``--antecedent none``, the model that study chose the radius for).

5. ``--targets``: the ige-oge targets of issue 11 (``benchmarks/scheduled.py --seeds 4``:
   eTS against ARX free-run on held-out seeds, rules and their focal altitudes).

6. ``--phases``: CPU time of each phase of ``etsid identify`` on a ``--duration`` s
   simulated hover-ige flight written as a 250 Hz tlog (ingest, segmenting and decimation,
   regressor build, structure choice, learning, validation, writing RUN_DIR), measured by
   timing the functions ``etsid.ident.run.identify`` calls (exclusive: a phase's time does
   not include the phases it calls), after a warm-up run (imports, numba cache).

Regime scheduling (the oracle ceiling and the study that chose ``--antecedent auto``) is
``benchmarks/scheduled.py``.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from etsid.ident import IdentConfig, identify
from etsid.sim import simulate


def throughput(duration: float) -> None:
    identify(simulate("hover-ige", duration=20.0, seed=99).table)  # warm-up
    table = simulate("hover-ige", duration=duration, seed=5).table
    cpu, wall = time.process_time(), time.perf_counter()
    run = identify(table)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    n = run.metrics["n_samples"]
    print(f"throughput: {duration:g} s hover-ige, {len(table)} rows at 250 Hz -> {n} at "
          f"{run.metrics['sample_rate']['rate_hz']:g} Hz, rules peak "
          f"{run.metrics['rules']['peak']}")
    print(f"  wall {wall:.2f} s, CPU {cpu:.2f} s: {len(table) / wall:,.0f} table rows/s, "
          f"{n / wall:,.0f} identification samples/s (wall)")


#: phases of identify and the functions of ``etsid.ident.run`` that make them up
PHASES = {
    "segmenting, decimation": ("add_motor_commands", "select_flight", "apply_selection",
                               "decimate", "excited_mask", "split_excited", "noise_std",
                               "refuse_coarse"),
    "regressor build": ("build",),
    "structure choice": ("choose_model", "check_attitude_states", "_structure"),
    "learning": ("learn_online", "_new_model", "fixed_ranges", "schedule_range"),
    "validation": ("prediction_columns", "history_frames", "output_metrics", "tail_informs",
                   "blocked_validation", "still_tail_lines", "not_validated_line",
                   "validation_table", "regime_summary_of", "rate_info", "predictions_frame",
                   "rules_json"),
}


def phases(duration: float, keep: str | None = None) -> None:
    """CPU seconds per identify phase on a ``duration`` s 250 Hz log (see the docstring);
    with ``keep`` (a directory) the two tlogs are written there once and reused."""
    import tempfile
    from pathlib import Path

    import etsid.ident.run as run_module
    from etsid.ident import write_run
    from etsid.ident.inputs import load_for_ident
    from etsid.sim.writers.tlog import RATES, write_tlog

    spent: dict[str, float] = {}
    by_name: dict[str, float] = {}
    stack: list[float] = []  # CPU time of the nested timed calls, to keep phases exclusive

    def timed(phase: str, fn):  # type: ignore[no-untyped-def]
        def wrapper(*args, **kwargs):  # type: ignore[no-untyped-def]
            t0 = time.process_time()
            stack.append(0.0)
            try:
                return fn(*args, **kwargs)
            finally:
                inner = stack.pop()
                dt = time.process_time() - t0
                spent[phase] = spent.get(phase, 0.0) + dt - inner
                by_name[fn.__name__] = by_name.get(fn.__name__, 0.0) + dt - inner
                if stack:
                    stack[-1] += dt
        return wrapper

    for phase, names in PHASES.items():
        for name in names:
            if hasattr(run_module, name):  # (older code may lack some of them)
                setattr(run_module, name, timed(phase, getattr(run_module, name)))
    # every stream at the 250 Hz of the simulation (status and heartbeat at their own rates)
    rates = {name: (rate if rate < 10.0 else 250.0) for name, rate in RATES.items()}
    with tempfile.TemporaryDirectory() as tmp:
        logs = Path(keep) if keep else Path(tmp)
        logs.mkdir(parents=True, exist_ok=True)
        warm = logs / "warm.tlog"
        if not (keep and warm.exists()):
            write_tlog(simulate("hover-ige", duration=20.0, seed=99).table, warm, rates=rates)
        write_run(identify(load_for_ident(warm)), Path(tmp) / "warm_run")  # warm-up
        log = logs / f"flight_{duration:g}s.tlog"
        if not (keep and log.exists()):
            write_tlog(simulate("hover-ige", duration=duration, seed=5).table, log,
                       rates=rates)
        load_for_ident(log)  # warm-up of the tlog kernels (a 20 s log is read without them)
        spent.clear()
        by_name.clear()
        total0 = time.process_time()
        t0 = time.process_time()
        table = load_for_ident(log)
        spent["ingest (read the tlog)"] = time.process_time() - t0
        t0 = time.process_time()
        run = identify(table)
        body = time.process_time() - t0
        t0 = time.process_time()
        write_run(run, Path(tmp) / "run")
        spent["writing RUN_DIR"] = time.process_time() - t0
        total = time.process_time() - total0
    spent["identify, rest"] = body - sum(spent[p] for p in PHASES if p in spent)
    print(f"phases of identify, {duration:g} s hover-ige tlog, {len(table)} rows at 250 Hz "
          f"({run.metrics['n_samples']} at {run.metrics['sample_rate']['rate_hz']:g} Hz), "
          f"CPU s after the imports:")
    print("| phase | CPU s | share |\n|---|---|---|")
    for phase in ["ingest (read the tlog)", *PHASES, "identify, rest", "writing RUN_DIR"]:
        v = spent.get(phase, 0.0)
        print(f"| {phase} | {v:.3f} | {100 * v / total:.0f} % |")
    print(f"| total | {total:.3f} | |")
    top = sorted(by_name.items(), key=lambda kv: -kv[1])[:6]
    print("largest calls: " + ", ".join(f"{name} {v:.3f} s" for name, v in top))


def quality(scenario: str, seeds: list[int], config: IdentConfig, label: str) -> None:
    rows = []
    for seed in seeds:
        run = identify(simulate(scenario, duration=60.0, seed=seed).table, config)
        out = run.metrics["outputs"]
        rows.append([[out[y]["validation"]["one_step"]["rmse_over_noise"],
                      out[y]["arx"]["validation"]["one_step"]["rmse_over_noise"],
                      out[y]["validation"]["free_run"]["fit"],
                      out[y]["arx"]["validation"]["free_run"]["fit"],
                      out[y]["validation"]["one_step"]["rmse"],
                      out[y]["online"]["rmse_over_noise"],
                      out[y]["arx"]["online"]["rmse_over_noise"]] for y in "pqr"]
                    + [[run.metrics["rules"]["peak"], run.metrics["rules"]["frozen"],
                        out["p"]["noise_std"], 0, 0, 0, 0]])
    mean = np.mean(np.array(rows, dtype=float), axis=0)
    low = np.min(np.array(rows, dtype=float), axis=0)
    print(f"\n{label}: {scenario}, seeds {seeds}, σ = {mean[3, 2]:.5f} rad/s, rules peak "
          f"{mean[3, 0]:.1f}, frozen {mean[3, 1]:.1f} (means over seeds; free-run min)")
    print("| output | eTS 1-step RMSE/σ | ARX 1-step RMSE/σ | eTS 1-step RMSE (rad/s) | "
          "eTS free-run fit % (min) | ARX free-run fit % (min) | eTS online RMSE/σ | "
          "ARX online RMSE/σ |")
    print("|---|---|---|---|---|---|---|---|")
    for i, y in enumerate("pqr"):
        print(f"| {y} | {mean[i, 0]:.2f} | {mean[i, 1]:.2f} | {mean[i, 4]:.4f} | "
              f"{mean[i, 2]:.1f} ({low[i, 2]:.1f}) | {mean[i, 3]:.1f} ({low[i, 3]:.1f}) | "
              f"{mean[i, 5]:.2f} | {mean[i, 6]:.2f} |")


def normalise_study(seeds: list[int]) -> None:
    """eTS normalisation modes and, for ``learn``, radii (docs/identify.md)."""
    print(f"\nnormalisation study, seeds {seeds}: online RMSE eTS / ARX, validation one-step "
          "RMSE eTS / ARX, free-run fit % eTS (min) / ARX, rules peak / frozen (rad/s; "
          "means over seeds)")
    print("| normalise, radius | flight | output | online eTS / ARX | val 1-step eTS / ARX | "
          "free-run fit % eTS (min) / ARX | rules peak / frozen |")
    print("|---|---|---|---|---|---|---|")
    settings = [("learn", 2.0), ("running", 2.0), ("apriori", 2.0), ("learn", 1.75),
                ("learn", 1.5), ("learn", 1.25), ("learn", 1.0)]
    for scenario in ("hover-ige", "forward-flight"):
        tables = [simulate(scenario, duration=60.0, seed=s).table for s in seeds]
        for mode, radius in settings:
            rows = []
            for table in tables:
                run = identify(table, IdentConfig(normalise=mode, radius=radius,
                                                  antecedent="none"))
                out = run.metrics["outputs"]
                rows.append([[out[y]["online"]["rmse"], out[y]["arx"]["online"]["rmse"],
                              out[y]["validation"]["one_step"]["rmse"],
                              out[y]["arx"]["validation"]["one_step"]["rmse"],
                              out[y]["validation"]["free_run"]["fit"],
                              out[y]["arx"]["validation"]["free_run"]["fit"],
                              run.metrics["rules"]["peak"], run.metrics["rules"]["frozen"]]
                             for y in "pqr"])
            a = np.array(rows, dtype=float)
            mean, low = a.mean(axis=0), a.min(axis=0)
            for i, y in enumerate("pqr"):
                print(f"| {mode}, {radius:g} | {scenario} | {y} | {mean[i, 0]:.4f} / "
                      f"{mean[i, 1]:.4f} | {mean[i, 2]:.4f} / {mean[i, 3]:.4f} | "
                      f"{mean[i, 4]:.1f} ({low[i, 4]:.1f}) / {mean[i, 5]:.1f} | "
                      f"{mean[i, 6]:.1f} / {mean[i, 7]:.1f} |", flush=True)


def lag_study(seeds: list[int]) -> None:
    """ARX free-run fit and one-step RMSE/σ over identification rates and lags."""
    from etsid.ident.arx import ARX
    from etsid.ident.metrics import fit_percent, rmse
    from etsid.ident.regressors import RegressorSpec, build
    from etsid.ident.resample import decimate
    from etsid.ident.simulate import free_run

    tables = [simulate("hover-ige", duration=60.0, seed=s).table for s in seeds]
    print(f"\nlag study (ARX), hover-ige seeds {seeds}: free-run fit % p/q/r, "
          "one-step RMSE/σ p/q/r")
    for rate in (250.0, 125.0, 62.5, 50.0, 41.67, 31.25):
        for ny, nu in ((1, 1), (2, 2), (2, 6), (3, 3), (4, 2), (4, 4), (4, 6), (6, 6)):
            terms = [f"{y}[k-1..k-{ny}]" for y in "pqr"]
            terms += [f"{u}[k-1..k-{nu}]" for u in ("u_roll", "u_pitch", "u_yaw", "u_thrust")]
            spec = RegressorSpec.parse(",".join(terms), ["p", "q", "r"])
            fits, errs = [], []
            for table in tables:
                d = decimate(table, rate)
                reg = build(d, spec)
                split = round(0.7 * len(reg.X))
                model = ARX.fit(reg.X[:split], reg.Y[:split])
                sim = free_run(model, reg, spec, split, len(d))
                one = model.predict(reg.X[split:])
                y = reg.Y[split:]
                sigma = d.attrs["noise"]["gyro_std"]
                fits.append([fit_percent(y[:, o], sim[:, o]) for o in range(3)])
                errs.append([rmse(y[:, o], one[:, o]) / sigma for o in range(3)])
            f, e = np.mean(fits, axis=0), np.mean(errs, axis=0)
            print(f"| {rate:g} | {ny}/{nu} | {f[0]:.1f} / {f[1]:.1f} / {f[2]:.1f} | "
                  f"{e[0]:.2f} / {e[1]:.2f} / {e[2]:.2f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=600.0)
    parser.add_argument("--seeds", default="21,22,23")
    parser.add_argument("--skip-quality", action="store_true")
    parser.add_argument("--lag-study", action="store_true",
                        help="only the ARX lag study on seeds 1, 2, 3")
    parser.add_argument("--targets", action="store_true",
                        help="only the ige-oge targets of issue 11 (benchmarks/scheduled.py)")
    parser.add_argument("--normalise-study", action="store_true",
                        help="only the --normalise / radius study on --seeds")
    parser.add_argument("--phases", action="store_true",
                        help="only the CPU time per identify phase on a --duration s tlog")
    parser.add_argument("--keep-logs", metavar="DIR",
                        help="with --phases: write the tlogs to DIR once and reuse them "
                             "(runs without the minute of simulation)")
    args = parser.parse_args()
    if args.phases:
        phases(args.duration, args.keep_logs)
        return
    if args.lag_study:
        lag_study([1, 2, 3])
        return
    if args.targets:
        import sys

        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from scheduled import benchmark

        benchmark(4)
        return
    if args.normalise_study:
        normalise_study([int(s) for s in args.seeds.split(",")])
        return
    print(f"python {platform.python_version()}, {platform.machine()}, "
          f"{os.cpu_count()} CPUs")
    throughput(args.duration)
    if args.skip_quality:
        return
    seeds = [int(s) for s in args.seeds.split(",")]
    label = ("defaults (50 Hz, lags 4/6 + roll, pitch states, rules on inv_alt[k-1] "
             "radius 0.3 evq, --normalise learn)")
    quality("hover-ige", seeds, IdentConfig(), label)
    quality("forward-flight", seeds, IdentConfig(), label)
    quality("hover-ige", seeds, IdentConfig(normalise="running"),
            "running ranges (--normalise running)")
    quality("hover-ige", seeds, IdentConfig(ident_rate=0, input_lags=2, radius=1.5,
                                            normalise="running", antecedent="none"),
            "previous defaults (250 Hz, lags 4/2, radius 1.5)")


if __name__ == "__main__":
    main()
