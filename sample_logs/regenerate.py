"""Regenerate the bundled sample flight in every supported log format.

Run from the repository root::

    python sample_logs/regenerate.py          # the sample flight in every format
    python sample_logs/regenerate.py --gap    # the pair for `etsid gap` (low_hover_*.parquet)

It flies the ``ige-oge`` scenario (the chapter's regime-change flight: the Tarot 680
hexacopter dwells in ground effect at 0.25 m and out of it at 1-2.5 m, joined by climbs and
descents, with roll/pitch/yaw stick excitation throughout) for 120 s with the project's
simulator and writes it with the project's log writers, each stream at the rate of
:data:`RATES` (sample_logs/README.md says why and what the rates cost). Deterministic: the
same seed gives the same bytes (for the formats whose writers do not stamp the wall-clock
time). Every file must stay below :data:`MAX_BYTES`.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from etsid.sim import simulate
from etsid.sim.writers import write_log
from etsid.table import save_table

HERE = Path(__file__).resolve().parent
NAME = "hexa_ige_oge"
SCENARIO = "ige-oge"
DURATION_S = 120.0
SEED = 7
MAX_BYTES = 2_000_000
"""Size cap of each sample (a file, or a ROS 2 bag directory)."""
GAP_SCENARIO = "hover-ige"

OUTPUTS = {
    f"{NAME}.tlog": None,
    f"{NAME}.bag": None,
    f"{NAME}.mcap": None,
    f"{NAME}_db3.db3": "ros2-db3",
    f"{NAME}_mcap": "ros2-mcap",
}

_MAVROS_FULL = {"imu": 100.0, "rc_in": 50.0, "rc_out": 5.0, "target": 10.0, "range": 20.0,
                "velocity": 5.0, "battery": 1.0}
_MAVROS_LOW = {"imu": 25.0, "rc_in": 25.0, "rc_out": 5.0, "target": 10.0, "range": 10.0,
               "velocity": 5.0, "battery": 1.0}
RATES: dict[str, dict[str, float]] = {
    f"{NAME}.tlog": {"HIGHRES_IMU": 50.0, "RC_CHANNELS": 50.0, "ATTITUDE": 50.0,
                     "SERVO_OUTPUT_RAW": 10.0, "ATTITUDE_TARGET": 25.0,
                     "DISTANCE_SENSOR": 20.0, "LOCAL_POSITION_NED": 10.0},
    f"{NAME}.bag": _MAVROS_FULL,
    f"{NAME}.mcap": _MAVROS_FULL,
    f"{NAME}_db3.db3": _MAVROS_LOW,
    f"{NAME}_mcap": _MAVROS_LOW,
}
"""Stream rates per sample, Hz: gyro 100 Hz and sticks 50 Hz (at or above the 50 Hz
identification rate) where the format's encoding lets 120 s fit in :data:`MAX_BYTES`; the
uncompressed ROS 2 bags (CDR Imu messages carry 216 bytes of covariance each) only fit at
25 Hz."""


GAP_PAIR = ("low_hover_1.parquet", "low_hover_2.parquet")
"""The gap-analysis pair (``etsid gap``): the same hexacopter hovering low, twice, with
different pilots' inputs and lengths. One is a simulation without ground effect, the other
the "recording" with it; the names do not say which is which (the README does)."""


def gap_pair() -> None:
    """Write the concealed ground-effect pair (``python sample_logs/regenerate.py --gap``)."""
    sim = simulate(GAP_SCENARIO, duration=40.0, seed=21, ground_effect=False, altitude=0.36,
                   alt_wander=0.10, amplitude=0.3)
    rec = simulate(GAP_SCENARIO, duration=34.0, seed=22, ground_effect=True, altitude=0.34,
                   alt_wander=0.13, amplitude=0.35,
                   settings={"vehicle.sensors.gyro_std": 0.024,
                             "vehicle.sensors.accel_std": 0.3})
    for name, flight in zip(GAP_PAIR, (sim, rec), strict=True):
        table = flight.table.iloc[::2].copy()  # 125 Hz, like a typical flight-log stream
        table.attrs = {"source": name, "format": "table"}
        save_table(table, HERE / name)
        print(f"{name}: {(HERE / name).stat().st_size / 1e6:.2f} MB")


def main() -> None:
    """Simulate once, write every format, print sizes."""
    if "--gap" in sys.argv[1:]:
        gap_pair()
        return
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
        written = write_log(table, target, fmt, rates=RATES[name])
        size = sum(p.stat().st_size for p in written.rglob("*")) if written.is_dir() \
            else written.stat().st_size
        print(f"{written.relative_to(HERE)}: {size / 1e6:.2f} MB")
        if size > MAX_BYTES:
            sys.exit(f"{written.relative_to(HERE)}: {size} bytes, above the cap of "
                     f"{MAX_BYTES}; lower its rates")


if __name__ == "__main__":
    main()
