"""Scoring ``etsid fit`` against a third-party simulator's known parameters (shared by
``benchmarks/fit_pyflyt.py`` and ``benchmarks/fit_multirotor.py``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from etsid.fit import fit_tables
from etsid.fit.result import ABS_TOLERANCE, TOLERANCE

SCORED = ("hover_command", "thrust_to_weight", "idle_ratio", "motor_time_constant",
          "time_delay", "roll_effectiveness", "pitch_effectiveness", "yaw_effectiveness",
          "inertia_ratio_yx", "roll_accel_per_command", "pitch_accel_per_command",
          "yaw_accel_per_command")
"""The fitted quantities compared with the simulator's truth."""

Fly = Callable[[int], tuple[Any, dict[str, Any]]]
Truth = Callable[[dict[str, Any], float], dict[str, float]]


def score(seed: int, fly: Fly, truth_of: Truth) -> list[dict[str, Any]]:
    """One row per scored parameter of the flight ``fly(seed)``: value, standard error,
    truth, verdict, truth inside the 95 % interval, within its accuracy class."""
    table, t_in = fly(seed)
    result = fit_tables([table])
    truth = truth_of(t_in, float(result.layout["v0"]))
    rows = []
    for key in SCORED:
        p = result.params.get(key)
        if p is None:
            continue
        tv = truth[key]
        lo, hi = p.interval
        tol = ABS_TOLERANCE.get(key)
        within = abs(p.value - tv) <= (tol if tol is not None else
                                       TOLERANCE.get(key, 0.2) * abs(tv) if tv else 0.02)
        rows.append({"seed": seed, "param": key, "value": p.value, "se": p.se, "truth": tv,
                     "verdict": p.verdict, "in_interval": bool(lo <= tv <= hi),
                     "within_class": bool(within)})
    return rows


def main(description: str, fly: Fly, truth_of: Truth, seeds: list[int]) -> None:
    """The benchmark's command line: ``--seeds``, a line per parameter, one summary line."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--seeds", type=int, nargs="*", default=seeds)
    args = ap.parse_args()
    rows: list[dict[str, Any]] = []
    for seed in args.seeds:
        part = score(seed, fly, truth_of)
        rows += part
        for r in part:
            print(f"seed {seed} {r['param']:24s} {r['value']:10.4g} ± {r['se']:8.2g} truth "
                  f"{r['truth']:10.4g}  {r['verdict']:15s} in interval {r['in_interval']!s:5s} "
                  f"in class {r['within_class']}", flush=True)
    ident = [r for r in rows if r["verdict"] == "identified"]
    print(f"identified {len(ident)}/{len(rows)}; in their 95 % interval "
          f"{sum(r['in_interval'] for r in ident)}/{len(ident)}; within class "
          f"{sum(r['within_class'] for r in ident)}/{len(ident)}; every verdict in interval "
          f"{sum(r['in_interval'] for r in rows)}/{len(rows)}")
