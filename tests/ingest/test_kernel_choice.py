"""The plain-Python forms of the ULog and DataFlash walkers (run on small logs while numba
is not loaded) give what their compiled forms give, on real logs and on damaged copies."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from etsid.ingest import dataflash_index, ulog_clean
from etsid.ingest.dataflash_kernels import index
from etsid.ingest.kernel_choice import SMALL_BYTES, use_kernels
from etsid.ingest.ulog_kernels import chain, resync

DATA = Path(__file__).parents[1] / "data"


def _damaged(data: bytes, where: float, size: int) -> bytes:
    """``data`` with ``size`` bytes zeroed from ``where`` (a share of its length) on."""
    out = bytearray(data)
    at = int(where * len(out))
    out[at:at + size] = bytes(size)
    return bytes(out)


@pytest.mark.parametrize("name", ["ardupilot_copter403_hexa_loiter_real.bin",
                                  "arduplane_truncated.BIN"])
@pytest.mark.parametrize("damage", [None, (0.3, 500), (0.6, 7)])
def test_dataflash_plain_index_equals_compiled(name: str, damage: tuple[float, int] | None
                                               ) -> None:
    data = (DATA / name).read_bytes()
    if damage:
        data = _damaged(data, *damage)
    buf = np.frombuffer(data, np.uint8)
    results = []
    for walk in (dataflash_index._index, index):
        lengths = np.zeros(256, np.int64)
        lengths[dataflash_index.FMT_TYPE] = dataflash_index.FMT_BYTES
        results.append(walk(buf, 0, buf.size, -1, 0xA3, 0x95, dataflash_index._SIZES,
                            lengths))
    plain, fast = results
    assert (int(plain[0]), int(plain[1])) == (int(fast[0]), int(fast[1]))
    for a, b in zip(plain[2:], fast[2:], strict=True):
        np.testing.assert_array_equal(a, b)
    assert len(fast[2]) > 1000  # messages were found
    if damage is None:
        assert len(fast[4]) == 0
    elif damage[1] >= 500:  # zeros over at least one header: a stretch skipped
        assert len(fast[4]) > 0


@pytest.mark.parametrize("name", ["px4_sitl_tagged.ulg", "px4_cubeorange_real.ulg"])
def test_ulog_plain_chain_equals_compiled(name: str) -> None:
    data = (DATA / name).read_bytes()
    for blob in (data, _damaged(data, 0.5, 300)):
        buf = np.frombuffer(blob, np.uint8)
        plain = tuple(int(v) for v in ulog_clean._chain(buf, ulog_clean.HEADER_BYTES,
                                                        ulog_clean._KNOWN))
        fast = tuple(int(v) for v in chain(buf, ulog_clean.HEADER_BYTES, ulog_clean._KNOWN))
        assert plain == fast
        if blob is not data:  # the zeros break the chain; both resume at the same place
            assert plain[1] == 0
            got = [int(f(buf, plain[0] + 1, buf.size, ulog_clean._KNOWN,
                         ulog_clean.RESYNC_MESSAGES)) for f in (ulog_clean._resync, resync)]
            assert got[0] == got[1] > plain[0]


def test_kernels_once_numba_is_loaded_or_the_log_is_large() -> None:
    assert use_kernels(10)  # this test process has numba loaded (the imports above)
    assert use_kernels(SMALL_BYTES + 1)
