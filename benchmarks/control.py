"""The eTS-vs-PID table of docs/control.md, and the speed of the control loop.

Run: ``python benchmarks/control.py`` (a few minutes; ``--seeds 0`` for one seed). Every
scenario is flown on the simulated Tarot 680 with the PID baseline, the eTS controller
(learnt inverse feed-forward + the PID's own feedback, the default) and the eTS
controller with a small feedback (a third of the PID's proportional gain), on the same
seeds. Printed per scenario and controller: tracking RMSE after 10 s (mean over seeds
and worst seed), worst max error after 10 s, mean settling time (``step``), control
effort, final rules and rule replacements (seed 0), and whether every flight was stable.
Then the cost of one control period: controller and plant, CPU µs, and the real-time
factor. ``--sensitivity`` instead flies the eTS controller with other forgetting factors
and height radii (seed 0) on the four smooth scenarios.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from etsid.control.ets_controller import ETSController, ETSSettings
from etsid.control.loop import fly
from etsid.control.pid import Gains, PIDController
from etsid.control.run import evaluate
from etsid.control.scenarios import SCENARIOS
from etsid.control.simplant import SimPlant

SMALL = ETSSettings(gains=Gains(kp=0.45, kd=0.27, ki=0.06))
VARIANTS = {
    "pid": lambda p: PIDController(p.dt, p.hover_command),
    "ets": lambda p: ETSController(p.dt, p.hover_command),
    "ets, small fb": lambda p: ETSController(p.dt, p.hover_command, SMALL),
}


def sensitivity() -> None:
    """eTS tracking RMSE (mm, seed 0; final rules) against forgetting and height radius."""
    names = ("sine-altitude", "hover-ige", "ige-sine", "mass-change")
    print("| forgetting | radius h | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    for forgetting in (0.9, 0.95, 0.98, 0.995):
        for rh in (0.1, 0.25):
            settings = dataclasses.replace(ETSSettings(), forgetting=forgetting,
                                           radius=(rh, 0.5, 0.5))
            cells = []
            for name in names:
                plant = SimPlant(seed=0)
                ctrl = ETSController(plant.dt, plant.hover_command, settings)
                m = evaluate(fly(SCENARIOS[name], ctrl, plant))
                cells.append(f"{1e3 * m['tracking_rmse']:.1f} ({m['rules_final']})")
            print(f"| {forgetting} | {rh} | " + " | ".join(cells) + " |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--sensitivity", action="store_true")
    args = ap.parse_args()
    if args.sensitivity:
        sensitivity()
        return
    seeds = args.seeds
    print(f"seeds {seeds}; RMSE and max error after 10 s, true height; effort = RMS du/dt")
    print("| scenario | controller | RMSE mean (worst), mm | max error, mm | settling, s | "
          "effort, 1/s | rules | replacements | stable |")
    print("|---|---|---|---|---|---|---|---|---|")
    timing: dict[str, list[float]] = {k: [] for k in ("ets", "pid", "plant", "rt")}
    for name in ("sine-altitude", "altitude-steps", "hover-ige", "ige-sine", "mass-change"):
        for label, make in VARIANTS.items():
            ms = []
            for seed in seeds:
                plant = SimPlant(seed=seed)
                flight = fly(SCENARIOS[name], make(plant), plant)
                m = evaluate(flight)
                ms.append(m)
                if label in ("ets", "pid"):
                    timing[label].append(m["timing"]["controller_us_per_step"])
                    timing["plant"].append(m["timing"]["plant_us_per_step"])
                    timing["rt"].append(m["timing"]["realtime_factor"])
            rmse = [1e3 * m["tracking_rmse"] for m in ms]
            mx = max(1e3 * m["max_error"] for m in ms)
            st = [m.get("settling_time_mean") for m in ms]
            st_txt = (f"{np.mean([s for s in st if s is not None]):.2f}"
                      if any(s is not None for s in st) else "—")
            eff = np.mean([m["control_effort"] for m in ms])
            rules = ms[0]["rules_final"]
            rep = ms[0]["rule_replacements"]
            print(f"| {name} | {label} | {np.mean(rmse):.1f} ({max(rmse):.1f}) | {mx:.0f} | "
                  f"{st_txt} | {eff:.2f} | {'—' if rules is None else rules} | "
                  f"{'—' if rep is None else rep} | "
                  f"{'yes' if all(m['stable'] for m in ms) else 'NO'} |", flush=True)
    print()
    print(f"CPU per 20 ms control period: eTS {np.median(timing['ets']):.0f} µs, PID "
          f"{np.median(timing['pid']):.0f} µs; plant (20 physics steps) "
          f"{np.median(timing['plant']):.0f} µs; closed loop "
          f"{np.median(timing['rt']):.0f}x real time (medians)")


if __name__ == "__main__":
    main()
