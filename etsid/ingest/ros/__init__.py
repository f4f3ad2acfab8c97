"""ROS logs: ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and MCAP files.

======================  ===============================================================
module                  job
======================  ===============================================================
:mod:`.bag`             reader for ROS 1 ``.bag`` and ROS 2 bags (format ``ros1``/``ros2``)
:mod:`.mcap`            reader for ``.mcap`` files (format ``mcap``; ROS 1, ROS 2, JSON)
:mod:`.messages`        message type → FlightTable columns: rows, frames, priorities
:mod:`.converter`       collects decoded messages per topic and builds the RawLog
:mod:`.fast`            vectorised decoding and storage walkers (same signals, faster)
======================  ===============================================================

The ROS message definitions shipped for bags without their own live in
:mod:`etsid.rosmsgs` (shared with the log writers of :mod:`etsid.sim.writers`).
"""
