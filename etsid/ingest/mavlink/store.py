"""The wanted messages' frames of a whole tlog, gathered chunk by chunk into their final
arrays (:class:`FrameStore`), so that no per-chunk part has to be joined afterwards.

Each field (payload bytes, frame number, ground-station stamp, system, component) is one
buffer with a region per message. The regions are sized from the first chunks: each
message's rows so far, scaled by the share of the file read, plus 5 %. A chunk that does
not fit grows the regions (at least doubling a region that overflowed) and moves the rows
already stored, so the copies stay linear in the file, and memory stays within a small
factor of the decoded output.
"""

from __future__ import annotations

import numpy as np

from etsid.ingest.mavlink.scan import OK, ScanResult, gather_payloads_reference

MARGIN = 1.05
"""Rows reserved per message: its rows so far over the share of the file read, times this."""


class FrameStore:
    """Frames of the message ids ``ids`` (payloads ``sizes`` bytes each, zero-padded)."""

    def __init__(self, ids: list[int], sizes: list[int]) -> None:
        self.ids = list(ids)
        self.sizes = np.asarray(sizes, dtype=np.int64)
        self.group = np.full(max(self.ids, default=-1) + 1, -1, np.int64)
        self.group[np.asarray(self.ids, dtype=np.int64)] = np.arange(len(self.ids))
        n = len(self.ids)
        self.rows = np.zeros(n, np.int64)
        self.cap = np.zeros(n, np.int64)
        self.fbase = np.zeros(n, np.int64)
        self.rbase = np.zeros(n, np.int64)
        self.rec = np.empty(0, np.uint8)
        self.index = np.empty(0, np.int64)
        self.stamp = np.empty(0, np.int64)
        self.sysid = np.empty(0, np.uint8)
        self.compid = np.empty(0, np.uint8)

    def add(self, buf: np.ndarray, res: ScanResult, first: int, share: float,
            fast: bool) -> None:
        """Append the frames of ``res`` (scanned from ``buf``; ``first`` is the file's frame
        number of its first frame) with status OK; ``share`` is the part of the file read
        so far (0–1], for the sizes of the regions; ``fast``: the numba kernels."""
        counts = self._counts(res, fast)
        need = self.rows + counts
        if np.any(need > self.cap):
            self._grow(need, share)
        if fast:
            from etsid.ingest.mavlink.scan_kernels import _store_kernel

            _store_kernel(buf, res.offset, res.length, res.msgid, res.sysid, res.compid,
                          res.stamp_us, res.status, self.group, OK, first, self.sizes,
                          self.rbase, self.fbase, self.rows, self.rec, self.index, self.stamp,
                          self.sysid, self.compid)
            return
        slot = self._slots(res)
        for g in np.flatnonzero(counts).tolist():
            sel = np.flatnonzero(slot == g)
            size = int(self.sizes[g])
            f = int(self.fbase[g] + self.rows[g])
            r = int(self.rbase[g]) + int(self.rows[g]) * size
            rec = gather_payloads_reference(buf, res.offset[sel], res.length[sel], size)
            self.rec[r:r + rec.size] = rec.ravel()
            self.index[f:f + sel.size] = first + sel
            self.stamp[f:f + sel.size] = res.stamp_us[sel]
            self.sysid[f:f + sel.size] = res.sysid[sel]
            self.compid[f:f + sel.size] = res.compid[sel]
            self.rows[g] += sel.size

    def parts(self, dtypes: dict[int, np.dtype]) -> dict[int, dict[str, np.ndarray]]:
        """Each id with frames: ``rec`` (its payloads viewed as ``dtypes[id]``), ``index``,
        ``stamp``, ``sysid``, ``compid`` (views of the buffers)."""
        out = {}
        for g, mid in enumerate(self.ids):
            n = int(self.rows[g])
            if not n:
                continue
            f = int(self.fbase[g])
            r = int(self.rbase[g])
            out[mid] = {"rec": self.rec[r:r + n * int(self.sizes[g])].view(dtypes[mid]),
                        "index": self.index[f:f + n], "stamp": self.stamp[f:f + n],
                        "sysid": self.sysid[f:f + n], "compid": self.compid[f:f + n]}
        return out

    def _slots(self, res: ScanResult) -> np.ndarray:
        """Each frame's group, −1 for none (plain numpy)."""
        known = (res.msgid >= 0) & (res.msgid < self.group.size) & (res.status == OK)
        return np.where(known, self.group[np.where(known, res.msgid, 0)], -1)

    def _counts(self, res: ScanResult, fast: bool) -> np.ndarray:
        counts = np.zeros(len(self.ids), np.int64)
        if not counts.size:
            return counts
        if fast:
            from etsid.ingest.mavlink.scan_kernels import _count_kernel

            _count_kernel(res.msgid, res.status, self.group, OK, counts)
            return counts
        slot = self._slots(res)
        return np.bincount(slot[slot >= 0], minlength=counts.size)

    def _grow(self, need: np.ndarray, share: float) -> None:
        """New regions: room for ``need`` rows and, while the file is not read to its end,
        for the estimate of the whole file and at least twice a region that overflowed;
        the stored rows move to them."""
        cap = np.maximum(need, self.cap)
        if share < 1.0:  # more chunks may follow
            est = np.ceil(need / max(share, 1e-9) * MARGIN).astype(np.int64)
            cap = np.maximum(np.maximum(cap, est), np.where(need > self.cap, 2 * self.cap, 0))
        fbase = np.concatenate(([0], np.cumsum(cap)[:-1])).astype(np.int64)
        rbase = np.concatenate(([0], np.cumsum(cap * self.sizes)[:-1])).astype(np.int64)
        rec = np.empty(int((cap * self.sizes).sum()), np.uint8)
        fields = [np.empty(int(cap.sum()), a.dtype)
                  for a in (self.index, self.stamp, self.sysid, self.compid)]
        for g, n in enumerate(self.rows.tolist()):
            if not n:
                continue
            size = int(self.sizes[g])
            old, new = int(self.rbase[g]), int(rbase[g])
            rec[new:new + n * size] = self.rec[old:old + n * size]
            old, new = int(self.fbase[g]), int(fbase[g])
            for dst, src in zip(fields, (self.index, self.stamp, self.sysid, self.compid),
                                strict=True):
                dst[new:new + n] = src[old:old + n]
        self.rec = rec
        self.index, self.stamp, self.sysid, self.compid = fields
        self.cap, self.fbase, self.rbase = cap, fbase, rbase
