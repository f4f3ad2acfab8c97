"""Simulated fleet for ``etsid batch fit`` (issue 40): 3 airframes × 20 flights, one motor
of one airframe weakening progressively from flight 10.

    python benchmarks/fit_fleet.py DIR            # writes DIR/airframe_*/flight_NN.parquet
    etsid batch fit DIR -o DIR/fleet              # fits, flags, fleet.png

Airframes (quad250 variants; folders name them, the tables carry no identity): A and C
unchanged; B's motor 2 gives 2 % less thrust per flight from flight 10 on
(``effects.weak_motor`` = [2, 1 − 0.02 (k − 9)] for flight k ≥ 10: 0.98 at flight 10,
0.80 at flight 19). Every flight is 30 s of hover-oge with stick excitation, its own seed
and its own battery charge (0.75–0.95). Expected: a flag on B's motor-2 share at flights
10–13, no flag elsewhere.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from etsid.sim import simulate

AIRFRAMES = {"airframe_A": {"vehicle.mass": 0.55}, "airframe_B": {"vehicle.mass": 0.58},
             "airframe_C": {"vehicle.mass": 0.53, "vehicle.motor.time_constant": 0.025}}
N_FLIGHTS = 20
WEAK_FROM = 10
WEAK_STEP = 0.02


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--seed", type=int, default=300)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    for a, (name, settings) in enumerate(AIRFRAMES.items()):
        folder = args.out / name
        folder.mkdir(parents=True, exist_ok=True)
        for k in range(1, N_FLIGHTS + 1):
            path = folder / f"flight_{k:02d}.parquet"
            if path.exists():
                continue
            s = dict(settings)
            s["vehicle.battery.soc0"] = float(rng.uniform(0.75, 0.95))
            if name == "airframe_B" and k >= WEAK_FROM:
                s["vehicle.weak_motor"] = [2, 1.0 - WEAK_STEP * (k - WEAK_FROM + 1)]
            flight = simulate("hover-oge", vehicle="quad250", duration=30,
                              seed=args.seed + 100 * a + k, settings=s)
            flight.table.to_parquet(path)
            print(f"{path}: {s}", flush=True)


if __name__ == "__main__":
    main()
