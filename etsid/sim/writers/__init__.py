"""Write a FlightTable as a real flight log, the format picked by the output path.

| output | format |
|---|---|
| ``*.tlog`` | MAVLink telemetry log as a Pixhawk streams it |
| ``*.bag`` | ROS 1 bag with MAVROS topics (FLU/ENU) |
| ``*.db3`` | ROS 2 bag directory named by the stem, sqlite3 storage |
| ``*.mcap`` | MCAP file, ROS 2 (cdr) encoding |
| ``*.parquet``, ``*.csv`` | the FlightTable itself |

``fmt`` overrides the choice: ``tlog``, ``ros1``, ``ros2-db3``, ``ros2-mcap`` (a ROS 2 bag
directory with MCAP storage), ``mcap``, ``mcap-ros1``, ``mcap-json``, ``parquet``, ``csv``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from etsid.errors import SimError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

WRITE_FORMATS = ("tlog", "ros1", "ros2-db3", "ros2-mcap", "mcap", "mcap-ros1", "mcap-json",
                 "parquet", "csv")

_BY_SUFFIX = {".tlog": "tlog", ".bag": "ros1", ".db3": "ros2-db3", ".mcap": "mcap",
              ".parquet": "parquet", ".csv": "csv"}


def format_for(path: Path, fmt: str | None = None) -> str:
    """The write format for ``path`` (or ``fmt`` when given)."""
    if fmt is not None:
        if fmt not in WRITE_FORMATS:
            raise SimError(f"unknown log format {fmt!r}; choose one of {', '.join(WRITE_FORMATS)}")
        return fmt
    chosen = _BY_SUFFIX.get(path.suffix.lower())
    if chosen is None:
        raise SimError(f"{path}: cannot tell the log format from the extension; use one of "
                       f"{', '.join(_BY_SUFFIX)} or give the format explicitly")
    return chosen


def write_log(table: pd.DataFrame, path: str | Path, fmt: str | None = None,
              rates: dict[str, float] | None = None) -> Path:
    """Write ``table`` to ``path`` in the format of :func:`format_for`; returns what was written.

    For ROS 2 bags the returned path is the bag directory. ``rates`` overrides stream
    rates, Hz: MAVLink message names for a tlog (:data:`etsid.sim.writers.tlog.RATES`),
    MAVROS stream keys for ROS and MCAP (:data:`etsid.sim.writers.rosbag.RATES`); tables
    are written at their own rate.
    """
    path = Path(path)
    fmt = format_for(path, fmt)
    if fmt == "tlog":
        from etsid.sim.writers.tlog import write_tlog

        return write_tlog(table, path, rates=rates)
    if fmt == "ros1":
        from etsid.sim.writers.rosbag import write_ros1_bag

        return write_ros1_bag(table, path, rates=rates)
    if fmt in ("ros2-db3", "ros2-mcap"):
        from etsid.sim.writers.rosbag import write_ros2_bag

        bag_dir = path.with_suffix("") if path.suffix in (".db3", ".mcap") else path
        return write_ros2_bag(table, bag_dir, storage="sqlite3" if fmt == "ros2-db3" else "mcap",
                              rates=rates)
    if fmt.startswith("mcap"):
        from etsid.sim.writers.mcapfile import write_mcap

        encoding = {"mcap": "ros2", "mcap-ros1": "ros1", "mcap-json": "json"}[fmt]
        return write_mcap(table, path, encoding=encoding, rates=rates)
    from etsid.table import save_table

    return save_table(table, path)
