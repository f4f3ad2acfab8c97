"""Flights without a regime change: how many rules the default identify keeps, and how its
validation one-step error compares with ARX (issue 24's target: 1–2 rules, within 1 %).

Flights (etsid's simulator, seeds 401–403, never used for any choice): hover-oge at 3 m
with a ±0.6 m altitude wander (altitude varies, physics does not: every height is out of
ground effect), on the tarot680 and on the quad250; forward flight at 6 m/s (tarot680).

    python benchmarks/ets_no_regime.py [--seeds 401,402,403] [--duration 60]
"""

from __future__ import annotations

import argparse

import numpy as np

from etsid.ident import IdentConfig, identify
from etsid.sim import simulate

FLIGHTS = (("hover-oge", "tarot680", {"alt_wander": 0.6}),
           ("hover-oge", "quad250", {"alt_wander": 0.6}),
           ("forward-flight", "tarot680", {}))


def run(flight: str, vehicle: str, params: dict, seed: int, duration: float) -> dict:
    table = simulate(flight, vehicle=vehicle, seed=seed, duration=duration, **params).table
    res = identify(table, IdentConfig())
    out = res.metrics["outputs"]
    ratio = {y: out[y]["validation"]["one_step"]["rmse"]
             / out[y]["arx"]["validation"]["one_step"]["rmse"] for y in "pqr"}
    alt = table["alt"].to_numpy()
    return {"flight": flight, "vehicle": vehicle, "seed": seed,
            "alt": (float(np.nanmin(alt)), float(np.nanmax(alt))),
            "chosen": res.metrics.get("structure", {}).get("chosen"),
            "rules": res.metrics["rules"], "ratio": ratio}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="401,402,403")
    ap.add_argument("--duration", type=float, default=60.0)
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    print("| flight | vehicle | seed | alt range m | structure chosen | rules peak / frozen |"
          " eTS / ARX val 1-step RMSE p / q / r |")
    print("|---|---|---|---|---|---|---|")
    worst = 0.0
    for flight, vehicle, params in FLIGHTS:
        for seed in seeds:
            r = run(flight, vehicle, params, seed, args.duration)
            worst = max(worst, *r["ratio"].values())
            print(f"| {flight} | {vehicle} | {seed} | {r['alt'][0]:.2f}–{r['alt'][1]:.2f} | "
                  f"{r['chosen']} | {r['rules']['peak']} / {r['rules']['frozen']} | "
                  + " / ".join(f"{r['ratio'][y]:.4f}" for y in "pqr") + " |", flush=True)
    print(f"worst eTS / ARX one-step ratio: {worst:.4f}")


if __name__ == "__main__":
    main()
