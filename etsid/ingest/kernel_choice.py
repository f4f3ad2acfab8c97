"""Whether a reader runs its numba kernels or their plain-Python forms on a buffer.

Importing numba and loading its typing registries at the first compiled call costs about
0.5–1 s of CPU, whatever the file. A small log read while numba is not loaded yet
(``etsid inspect``) is walked by the plain forms instead, which give the same result:
the tlog frame scan, the ULog message chain and the DataFlash indexer. Once numba is
loaded (identify, a batch) or for a larger file, the kernels run.
"""

from __future__ import annotations

import sys
import types
from collections.abc import Callable
from typing import Any

SMALL_BYTES = 4 << 20
"""Largest buffer walked by the plain forms while numba is not loaded. They take about
0.1 s of CPU per MiB (tlog scan with its CRC through ``binascii``: 0.08–0.12 s per MiB;
ULog chain of a 1.9 MB log 0.11 s; DataFlash index of a 1.3 MB log 0.08 s), numba's import
and first call 0.5–1 s, so they break even near 5 MiB: ``etsid inspect`` of a 5.3 MB tlog
took 1.45–1.68 s of user CPU through numba and 1.37–1.64 s plain (4 runs each;
docs/performance.md)."""


def use_kernels(size: int) -> bool:
    """Whether to run the numba kernels on ``size`` bytes (else the plain forms)."""
    return "numba" in sys.modules or size > SMALL_BYTES


def compiled(fn: Callable[..., Any], **callees: Callable[..., Any]) -> Any:
    """``fn`` compiled by numba (cached), its calls to the plain functions named in
    ``callees`` going to the compiled ones given there. ``fn`` stays plain Python."""
    import numba

    clone = types.FunctionType(fn.__code__, {**fn.__globals__, **callees}, fn.__name__,
                               fn.__defaults__)
    clone.__qualname__ = fn.__qualname__
    clone.__doc__ = fn.__doc__
    return numba.njit(cache=True)(clone)
