"""Cost of the plausibility checks of rule 5 (etsid/ingest/source_consistency.py) on ingest.

Run:  python benchmarks/source_consistency.py [--duration 600]

For each real log of ../shared/data/logs (those present) and a ``--duration`` s simulated
hover-ige flight written as a 250 Hz tlog (the log of ``benchmarks/identify.py --phases``):
CPU time of ``choose_signals`` with the checks and with a referee that judges nothing,
interleaved in one process (best of 7), and of ``read_log`` (best of 3) for scale.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from etsid.ingest import read_log, read_raw
from etsid.ingest.mapping import choose_signals
from etsid.ingest.source_consistency import Referee
from etsid.sim import simulate
from etsid.sim.writers.tlog import RATES, write_tlog

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "logs"
REAL = ("ardupilot_copter33_loiter_acro_flips_real.bin", "px4_coaxocto_stabilized_real.ulg",
        "px4_cubeorange_real.ulg", "px4_v6c_quad_lowhover_real.ulg",
        "ardupilot_sitl_quadplane.tlog", "mavros_from_sitl/mavros_vtol.bag")


def best(fn: Callable[[], object], repeats: int) -> float:
    """Least CPU seconds of ``repeats`` calls of ``fn``."""
    out = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        out = min(out, time.process_time() - t0)
    return out


def measure(path: Path) -> str:
    """One line: choose_signals without → with the checks, and read_log."""
    raw = read_raw(path)
    judge = Referee.judge
    on = off = float("inf")
    try:
        for _ in range(7):
            Referee.judge = judge  # type: ignore[method-assign]
            on = min(on, best(lambda: choose_signals(raw.signals, [], raw.path), 1))
            Referee.judge = lambda self, column, sig: None  # type: ignore[method-assign]
            off = min(off, best(lambda: choose_signals(raw.signals, [], raw.path), 1))
    finally:
        Referee.judge = judge  # type: ignore[method-assign]
    whole = best(lambda: read_log(path), 3)
    return (f"| {path.name} | {1e3 * off:.1f} | {1e3 * on:.1f} | {1e3 * (on - off):+.1f} | "
            f"{1e3 * whole:.0f} | {100 * (on - off) / whole:+.1f} % |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=600.0,
                        help="simulated flight, s (default 600)")
    args = parser.parse_args()
    print("| log | choose_signals ms, no checks | with | added ms | read_log ms | added |")
    print("|---|---|---|---|---|---|")
    for name in REAL:
        if (SHARED / name).exists():
            print(measure(SHARED / name))
    rates = {name: (rate if rate < 10.0 else 250.0) for name, rate in RATES.items()}
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / f"hover_ige_{args.duration:g}s_250hz.tlog"
        write_tlog(simulate("hover-ige", duration=args.duration, seed=5).table, log,
                   rates=rates)
        print(measure(log))


if __name__ == "__main__":
    main()
