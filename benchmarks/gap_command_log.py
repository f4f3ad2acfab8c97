"""The time delay ``etsid gap`` fits to etsid's own no-effect pairs, by how the motor
outputs are logged and by one changed factor of the pair (session 13 diagnosis).

Each pair is ``gap_concealed.make_pair`` (id ``etsid-<seed*100+j>``, as in
``gap_calibrate.py``); a factor changes one argument of its two ``simulate`` calls::

    python benchmarks/gap_command_log.py                       # the 7 named pairs, both logs
    python benchmarks/gap_command_log.py --ids 84000 --factors noise,swap,gyro_off,rate1000
    python benchmarks/gap_command_log.py --ids 84000 --log sample --factors all
    python benchmarks/gap_command_log.py --share       # jitter over manoeuvre, per flight

Prints per pair and variant the fitted ``time_delay`` (ms), its held-out gain per REAL
sample (nats) and that gain over its standard error over blocks.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

import gap_concealed
import numpy as np

from etsid.gap.run import analyse

NAMED = (84000, 74011, 76111, 78000, 78211, 81000, 73311)
"""The no-effect pairs with a 0.9–2 ms delay in the gap_r4h records."""


def _drop_noise(kw: dict[str, Any], n: int) -> None:
    if n == 1:  # REAL's sensor noise at SIM's level
        kw["settings"] = {k: v for k, v in kw["settings"].items()
                          if not k.startswith("vehicle.sensors.")}


def _gyro_off(kw: dict[str, Any], n: int) -> None:
    kw["settings"] = dict(kw["settings"], **{"vehicle.sensors.gyro_std": 0.0})


def _rate(hz: float) -> Callable[[dict[str, Any], int], None]:
    def change(kw: dict[str, Any], n: int) -> None:
        kw["rate_hz"] = hz
    return change


FACTORS: dict[str, Callable[[dict[str, Any], int], None] | None] = {
    "noise": _drop_noise,
    "gyro_off": _gyro_off,
    "rate500": _rate(500.0),
    "rate1000": _rate(1000.0),
    "swap": None,  # handled on the pair
    "same_seed": None,
    "same_duration": None,
}


def pair(pid: int, command_log: str, factor: str | None) -> tuple[Any, Any]:
    """The no-effect pair ``pid`` with ``factor`` changed (None: as drawn)."""
    calls: list[dict[str, Any]] = []
    plain = gap_concealed.simulate

    def wrapped(*args: Any, **kw: Any) -> Any:
        n = len(calls)
        calls.append(kw)
        kw["command_log"] = command_log
        change = FACTORS.get(factor or "")
        if change is not None:
            change(kw, n)
        if n == 1 and factor == "same_seed":
            kw["seed"] = calls[0]["seed"]
        if n == 1 and factor == "same_duration":
            kw["duration"] = calls[0]["duration"]
        return plain(*args, **kw)

    gap_concealed.simulate = wrapped
    try:
        sim, real, _ = gap_concealed.make_pair("none", pid)
    finally:
        gap_concealed.simulate = plain
    return (real, sim) if factor == "swap" else (sim, real)


def delay_fit(sim: Any, real: Any) -> dict[str, Any]:
    """The criterion's time_delay model: delay (ms), gain per sample (nats), z; verdict."""
    data = analyse(sim, real, "SIM", "REAL").data
    models = {m["name"]: m for m in (data.get("criterion") or {}).get("models", [])}
    m = models.get("time_delay")
    if m is None:
        return {"verdict": data["verdict"]}
    z = m["gain"] / m["gain_se"] if m["gain_se"] else float("nan")
    return {"delay_ms": 1e3 * m["theta"][0], "per_sample": m["per_sample"], "z": z,
            "verdict": data["verdict"]}


def jitter_share(pid: int) -> tuple[float, float]:
    """SIM's and REAL's in-period jitter share: the variance of the differential motor
    commands' snapshot minus their period mean, over the variance of the mean's 0.3–8 Hz
    part (the flight is the same under both logs)."""
    from scipy.signal import butter, sosfiltfilt

    snap, mean = pair(pid, "sample", None), pair(pid, "mean", None)
    out = []
    for a, b in zip(snap, mean, strict=True):
        cols = [c for c in a.columns if c[0] == "m" and c[1:].isdigit()]
        x, y = a[cols].to_numpy(), b[cols].to_numpy()
        x, y = x - x.mean(1, keepdims=True), y - y.mean(1, keepdims=True)
        sos = butter(2, [0.3, 8.0], "bandpass", fs=float(a.attrs["rate_hz"]), output="sos")
        out.append(float(np.var(x - y) / np.var(sosfiltfilt(sos, y, axis=0))))
    return out[0], out[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ids", default=",".join(map(str, NAMED)),
                    help="comma-separated pair numbers (seed*100+j, a no-effect j)")
    ap.add_argument("--log", default="sample,mean", help="command logs to compare")
    ap.add_argument("--factors", default="",
                    help=f"comma-separated factors ({', '.join(FACTORS)}) or 'all'")
    ap.add_argument("--share", action="store_true",
                    help="print each flight's in-period jitter share instead")
    args = ap.parse_args()
    if args.share:
        for pid in (int(i) for i in args.ids.split(",")):
            a, b = jitter_share(pid)
            print(f"etsid-{pid} jitter share SIM {a:.3f} REAL {b:.3f} REAL/SIM {b / a:.2f}")
        return
    factors: list[str | None] = [None]
    if args.factors:
        factors += list(FACTORS) if args.factors == "all" else args.factors.split(",")
    for pid in (int(i) for i in args.ids.split(",")):
        for log in args.log.split(","):
            for factor in factors:
                r = delay_fit(*pair(pid, log, factor))
                print(f"etsid-{pid} {log:6s} {factor or 'as drawn':14s} "
                      f"delay {r.get('delay_ms', np.nan):5.2f} ms  "
                      f"gain {r.get('per_sample', np.nan):+.4f}/sample  "
                      f"z {r.get('z', np.nan):+5.1f}  {r['verdict']}", flush=True)


if __name__ == "__main__":
    main()
