"""Regenerate the bundled sample flight in every supported log format.

Run from the repository root::

    python sample_logs/regenerate.py

It flies the ``hover-ige`` scenario (Tarot 680 hexacopter hovering below 40 cm with
roll/pitch/yaw stick excitation, ground effect on) with the project's simulator and writes
it with the project's log writers. Deterministic: the same seed gives the same bytes
(for the formats whose writers do not stamp the wall-clock time).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from etsid.sim import simulate
from etsid.sim.writers import write_log

HERE = Path(__file__).resolve().parent
NAME = "hexa_hover_ige"
SCENARIO = "hover-ige"
DURATION_S = 36.0
SEED = 7

OUTPUTS = {
    f"{NAME}.tlog": None,
    f"{NAME}.bag": None,
    f"{NAME}.mcap": None,
    f"{NAME}_db3.db3": "ros2-db3",
    f"{NAME}_mcap": "ros2-mcap",
}


def main() -> None:
    """Simulate once, write every format, print sizes."""
    flight = simulate(SCENARIO, duration=DURATION_S, seed=SEED)
    for name, fmt in OUTPUTS.items():
        target = HERE / name
        for old in (target, target.with_suffix("")):
            if old.is_dir():
                shutil.rmtree(old)
            elif old.exists() and old.suffix == target.suffix:
                old.unlink()
        table = flight.table
        if target.suffix == ".parquet":
            table = table.join(flight.truth)
            table.attrs = dict(flight.table.attrs)
        written = write_log(table, target, fmt)
        size = sum(p.stat().st_size for p in written.rglob("*")) if written.is_dir() \
            else written.stat().st_size
        print(f"{written.relative_to(HERE)}: {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
