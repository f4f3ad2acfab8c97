"""Speed of ``etsid gap`` on two 90 s flights and on two 1-hour flights, one core.

Two 90 s flights of etsid's simulator (quad250, hover with altitude wander; REAL with a
10 % thrust loss) are analysed as they are; the 1-hour pair is each flight repeated end to
end for an hour (times shifted; a log of that length, not new physics). Prints the CPU
time of the analysis and the process's peak resident memory, after the analysis and before
it (the two input tables of an hour at 250 Hz hold ≈ 190 MB each).

Run::

    python benchmarks/gap_speed.py
    python benchmarks/gap_speed.py --hours 0.05        # a shorter long pair, for repeats
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np
import pandas as pd

from etsid.gap.run import analyse
from etsid.sim import simulate


def tiled(table: pd.DataFrame, seconds: float) -> pd.DataFrame:
    """``table`` repeated end to end until it lasts ``seconds`` (tiled at once: no list of
    copies held while they are joined)."""
    span = float(table.index[-1] - table.index[0]) + 1.0 / 50.0
    k = max(math.ceil(seconds / span), 1)
    t = table.index.to_numpy()
    index = pd.Index(np.concatenate([t + i * span for i in range(k)]), name=table.index.name)
    if all(table.dtypes == np.float64):  # one block, not joined from columns
        out = pd.DataFrame(np.tile(table.to_numpy(), (k, 1)), columns=table.columns,
                           index=index, copy=False)
    else:
        out = pd.DataFrame({c: np.tile(table[c].to_numpy(), k) for c in table.columns},
                           index=index)
    out.attrs = dict(table.attrs)
    return out


def peak_mb() -> float:
    """The process's peak resident memory so far, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run(sim: pd.DataFrame, real: pd.DataFrame, label: str) -> None:
    before = peak_mb()
    t0 = time.process_time()
    data = analyse(sim, real, "SIM", "REAL").data
    cpu = time.process_time() - t0
    named = [e["name"] for e in data["effects"]]
    print(f"{label:28s} CPU {cpu:6.1f} s  peak RSS {peak_mb():6.0f} MB "
          f"(before the analysis {before:4.0f} MB)  {data['verdict']} {named}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    args = ap.parse_args()
    kw = {"alt_wander": 0.3, "amplitude": 0.4}
    sim = simulate("hover-oge", "quad250", duration=90.0, seed=1, **kw).table
    real = simulate("hover-oge", "quad250", duration=90.0, seed=2,
                    settings={"vehicle.thrust_scale": 0.9}, **kw).table
    run(sim, real, "two 90 s flights")
    hours = 3600.0 * args.hours
    run(tiled(sim, hours), tiled(real, hours),
        f"two {args.hours:g}-hour flights")


if __name__ == "__main__":
    main()
