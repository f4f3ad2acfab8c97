"""One continuous autopilot clock for the frames of one MAVLink system.

Every frame carries a ground-station stamp (bursty: packets queue on the link and arrive
late, sometimes out of order); most also carry the autopilot's own clock
(``time_boot_ms``, uint32 ms, or ``time_usec``). The autopilot clock is the one to use.
Walking the frames in the order they were logged, :func:`autopilot_clock`

* unwraps ``time_boot_ms`` at 2³² ms (≈ 49.7 days) and uint32 ``time_usec`` fields
  (SERVO_OUTPUT_RAW) at 2³² µs (≈ 71.6 min), the latter against the latest ms clock;
* tells a reboot from late packets: the clock steps back by more than
  :data:`STEP_S` *and* the ground-station stamp minus the clock (the "boot epoch")
  exceeds the segment's smallest epoch by more than :data:`REBOOT_LAG_S`. Late packets
  keep their own clock (they are re-sorted later); a rebooted segment is shifted so its
  zero lands where the ground-station stamps put it (and after the previous segment);
* gives frames without a clock of their own (SYS_STATUS, BATTERY_STATUS, or a
  ``time_usec`` in Unix time) the latest autopilot time seen before them in the stream.

``start_time`` (Unix s of clock zero) is the smallest boot epoch of the first segment:
the link only ever adds delay, so the smallest difference is the best estimate.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

NONE, BOOT, WRAP32_US = 0, 1, 2
"""Clock kinds per frame: no own clock; boot clock (s); uint32 µs boot clock (s, wraps)."""

MS_WRAP_S = 2.0**32 / 1000.0
US_WRAP_S = 2.0**32 / 1e6
STEP_S = 1.0
"""A step back smaller than this is jitter between message types, never a reboot."""
REBOOT_LAG_S = 10.0
"""A step back whose boot epoch grew by more than this is a reboot, else a late packet."""


@dataclass
class Clock:
    """Result of :func:`autopilot_clock`."""

    t: np.ndarray
    """Autopilot time per frame, s, continuous across reboots and wraps."""
    start_time: float | None
    """Unix s of ``t == 0``."""
    reboots: int
    rebooted_frames: int
    ms_wraps: int
    us_wraps: int
    own_clock: bool
    """False when no frame had an autopilot clock (``t`` is then ground-station time)."""


SMALL_FRAMES = 100_000
"""Most frames walked in plain Python while numba is not loaded (≈ 1 µs each; see
:mod:`.scan` for why a small log avoids numba's import)."""


def _walk(gcs, value, kind, step, lag, ms_wrap, us_wrap):  # type: ignore[no-untyped-def]
    """The clock walk of :func:`autopilot_clock`, in plain Python; compiled by numba
    unchanged (:mod:`.clock_kernel`) for larger logs."""
    n = value.size
    cont = np.full(n, np.nan)
    seg = np.zeros(n, np.int64)
    s = 0
    wrap_off = 0.0
    running = -np.inf
    epoch_min = np.inf
    last_ref = np.nan  # latest ms/boot clock in this segment (continuous)
    last_us = np.nan
    ms_wraps = 0
    us_wraps = 0
    last = np.nan
    for i in range(n):
        k = kind[i]
        if k == BOOT:
            c = value[i] + wrap_off
            if c < running - step and value[i] < 600.0 and running - wrap_off > ms_wrap - 600.0:
                wrap_off += ms_wrap
                c += ms_wrap
                ms_wraps += 1
        elif k == WRAP32_US:
            c = value[i]
            ref = last_ref if not np.isnan(last_ref) else last_us
            if not np.isnan(ref):
                turns = np.floor((ref - c) / us_wrap + 0.5)
                if turns != 0:
                    us_wraps += 1
                c += turns * us_wrap
        else:
            cont[i] = last
            seg[i] = s
            continue
        epoch = gcs[i] - c
        if c < running - step and epoch > epoch_min + lag:
            s += 1
            wrap_off = 0.0
            c = value[i]
            running = c
            epoch_min = epoch
            last_ref = np.nan
            last_us = np.nan
        else:
            running = max(running, c)
            epoch_min = min(epoch_min, epoch)
        if k == BOOT:
            last_ref = c
        else:
            last_us = c
        cont[i] = c
        seg[i] = s
        last = c
    return cont, seg, ms_wraps, us_wraps


def autopilot_clock(gcs_s: np.ndarray, value_s: np.ndarray, kind: np.ndarray) -> Clock:
    """Autopilot time of every frame (see the module docstring).

    Parameters
    ----------
    gcs_s
        Ground-station stamps, Unix s, in logged order.
    value_s
        The frame's own clock in s (ignored where ``kind == NONE``).
    kind
        :data:`NONE`, :data:`BOOT` or :data:`WRAP32_US` per frame.
    """
    gcs_s = np.asarray(gcs_s, dtype=float)
    n = gcs_s.size
    if n == 0:
        return Clock(np.empty(0), None, 0, 0, 0, 0, True)
    clocked = kind != NONE
    if not clocked.any():
        return Clock(gcs_s - gcs_s[0], float(gcs_s[0]), 0, 0, 0, 0, False)
    walk = _walk
    if "numba" in sys.modules or n > SMALL_FRAMES:
        from etsid.ingest.mavlink.clock_kernel import walk
    kind = np.asarray(kind)
    cont, seg, ms_wraps, us_wraps = walk(gcs_s, np.asarray(value_s, dtype=float),
                                         kind if kind.dtype == np.int8 else
                                         np.asarray(kind, dtype=np.int64), STEP_S,
                                         REBOOT_LAG_S, MS_WRAP_S, US_WRAP_S)
    first = int(np.argmax(clocked))
    cont[:first] = cont[first]  # frames before the first clock take its value
    nseg = int(seg.max()) + 1
    epoch = gcs_s - cont
    if nseg == 1:  # no reboot: the loop below with one segment and no offset, unmasked
        epoch0 = float(np.min(epoch if first == 0 and clocked.all() else epoch[clocked]))
        return Clock(np.add(cont, 0.0, out=cont), epoch0, 0, 0, int(ms_wraps),
                     int(us_wraps), True)
    t = cont.copy()
    offsets = np.zeros(nseg)
    epoch0 = float(np.min(epoch[clocked & (seg == 0)]))
    prev_end = -np.inf
    for k in range(nseg):
        in_seg = seg == k
        mask = in_seg & clocked
        if not mask.any():
            continue
        off = float(np.min(epoch[mask])) - epoch0 if k else 0.0
        lo = float(np.min(cont[in_seg]))
        off = max(off, prev_end - lo + 1e-3) if k else off
        offsets[k] = off
        t[in_seg] = cont[in_seg] + off
        prev_end = float(np.max(t[in_seg]))
    return Clock(t, epoch0, nseg - 1, int(np.count_nonzero(seg > 0)), int(ms_wraps),
                 int(us_wraps), True)
