"""Regime-scheduled eTS against ARX on simulated flights (issue 11).

Prints, per flight, the free-run fit % on the validation part (last 30 %) of eTS with the
rules firing on the regressors (today's default), eTS scheduled on altitude and thrust
(``--antecedent "alt[k-1],u_thrust[k-1]"``) and ARX, per axis, and the rule count.
Seeds 101.. (ige-oge) and 201.. (hover-oge) were never used for any choice.

    python benchmarks/scheduled.py [--seeds 3]
"""

from __future__ import annotations

import argparse

from etsid.ident import IdentConfig, identify
from etsid.sim import simulate

ANTECEDENT = "alt[k-1],u_thrust[k-1]"
SCHED_RADIUS = 0.3  # a single trial on seed 3, not a selection study (docs/identify.md)


def one(scenario: str, seed: int, duration: float) -> None:
    table = simulate(scenario, duration=duration, seed=seed).table
    rows = []
    for label, config in (("eTS", IdentConfig()),
                          ("eTS-sched", IdentConfig(antecedent=ANTECEDENT,
                                                    radius=SCHED_RADIUS))):
        m = identify(table, config).metrics
        out = m["outputs"]
        rows.append((label, [out[a]["validation"]["free_run"]["fit"] for a in "pqr"],
                     m["rules"]["frozen"]))
    arx = [out[a]["arx"]["validation"]["free_run"]["fit"] for a in "pqr"]
    rows.append(("ARX", arx, "-"))
    for label, fits, rules in rows:
        print(f"| {scenario} | {seed} | {label} | "
              + " | ".join(f"{f:.1f}" for f in fits) + f" | {rules} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    print("| flight | seed | model | fit p % | fit q % | fit r % | rules (frozen) |")
    print("|---|---|---|---|---|---|---|")
    for i in range(args.seeds):
        one("ige-oge", 101 + i, 150.0)
    for i in range(max(1, args.seeds - 1)):
        one("hover-oge", 201 + i, 60.0)


if __name__ == "__main__":
    main()
