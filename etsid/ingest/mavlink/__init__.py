"""MAVLink telemetry logs (``.tlog``): a numpy frame scanner instead of one object per packet.

======================  ===============================================================
module                  job
======================  ===============================================================
:mod:`.tlog`            the reader (format ``tlog``)
:mod:`.scan`            frame scanner and payload gathering, with plain references
:mod:`.scan_kernels`    their numba kernels (loaded only when used)
:mod:`.dtypes`          MAVLink message → numpy structured dtype, CRC extras
:mod:`.clock`           autopilot clock: boot-time wraps, reboots, link timestamps
:mod:`.clock_kernel`    the clock walk compiled by numba (loaded only when used)
:mod:`.signals`         message → FlightTable signals: fields, units, priorities
======================  ===============================================================

ArduPilot DataFlash (:mod:`etsid.ingest.dataflash`) and PX4 ULog
(:mod:`etsid.ingest.ulog`) are separate formats with their own readers.
"""
