"""Tune the PID baseline of ``etsid control`` on the nominal Tarot 680 (grid search).

Run: ``python benchmarks/control_pid_tune.py`` (a few minutes: 120 gain sets). For every gain
set on a grid it flies the nominal ``sine`` and ``step`` scenarios (seed 0) and prints the sine
tracking RMSE after 10 s, the step scenario's mean settling time and largest overshoot,
and the sine's control effort. The chosen gains (``etsid.control.pid.PID_GAINS``) are the
best sine RMSE among gain sets whose steps overshoot by at most 10 %, settle every time,
and whose control effort on the sine stays below 1 /s (motor-command noise).
"""

from __future__ import annotations

import itertools

import numpy as np

from etsid.control.loop import fly
from etsid.control.metrics import flight_metrics
from etsid.control.pid import Gains, PIDController
from etsid.control.scenarios import SCENARIOS
from etsid.control.simplant import SimPlant

KP = (0.4, 0.6, 0.9, 1.35, 2.0, 3.0)
KD = (0.18, 0.27, 0.4, 0.5)
KI = (0.06, 0.24, 0.48, 0.96, 1.92)
MAX_OVERSHOOT = 0.10
MAX_EFFORT = 1.0


def overshoot(flight, step_times: list[float]) -> float:
    """Largest overshoot over the steps, as a fraction of the step size."""
    tb = flight.table
    t = tb.index.to_numpy()
    r, h = tb["alt_ref"].to_numpy(), tb["true_alt"].to_numpy()
    worst = 0.0
    ends = [*step_times[1:], np.inf]
    for when, end in zip(step_times, ends, strict=True):
        sel = (t >= when) & (t < end)
        i0 = int(np.argmax(sel))
        size = r[i0] - r[i0 - 1]
        over = np.max((h[sel] - r[sel]) * np.sign(size)) / abs(size)
        worst = max(worst, over)
    return worst


def main() -> None:
    rows = []
    for kp, kd, ki in itertools.product(KP, KD, KI):
        gains = Gains(kp=kp, kd=kd, ki=ki)
        res = {}
        for name in ("sine-altitude", "altitude-steps"):
            sc = SCENARIOS[name]
            plant = SimPlant(seed=0)
            f = fly(sc, PIDController(plant.dt, plant.hover_command, gains), plant)
            res[name] = (f, flight_metrics(f.table, sc.step_times() or None))
        ms, mt = res["sine-altitude"][1], res["altitude-steps"][1]
        os_ = overshoot(res["altitude-steps"][0], SCENARIOS["altitude-steps"].step_times())
        ok = (not res["sine-altitude"][0].diverged and not res["altitude-steps"][0].diverged
              and mt["settling_time_max"] is not None and os_ <= MAX_OVERSHOOT
              and ms["control_effort"] <= MAX_EFFORT)
        rows.append((ms["tracking_rmse"], kp, kd, ki, mt["settling_time_mean"], os_,
                     ms["control_effort"], ok))
        print(f"kp {kp:5.2f} kd {kd:5.2f} ki {ki:5.2f}  sine RMSE {ms['tracking_rmse']:.4f} m  "
              f"step settle {mt['settling_time_mean'] or float('nan'):5.2f} s  overshoot "
              f"{100 * os_:5.1f} %  effort {ms['control_effort']:.3f} /s  "
              f"{'ok' if ok else '--'}", flush=True)
    best = min((r for r in rows if r[-1]), default=None)
    if best is None:
        print("no gain set meets the constraints")
    else:
        print(f"chosen: kp {best[1]} kd {best[2]} ki {best[3]} (sine RMSE {best[0]:.4f} m, "
              f"settling {best[4]:.2f} s, overshoot {100 * best[5]:.1f} %, effort "
              f"{best[6]:.3f} /s)")


if __name__ == "__main__":
    main()
