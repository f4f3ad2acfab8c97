"""Worker processes that die with the batch: ``etsid batch`` killed with SIGKILL (or by the
OOM killer) leaves no fork server, pool worker or resource tracker behind.

Linux's ``PR_SET_PDEATHSIG`` has the kernel send SIGKILL to a process when its parent
dies; the fork server asks for it against the batch process, and each pool worker against
the fork server, so the chain goes down together (the resource tracker then reads the end
of its pipe and exits on its own). Elsewhere this is a no-op. Dask's worker processes
already watch their parent.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1
"""``prctl`` option (linux/prctl.h)."""

PARENT_ENV = "ETSID_BATCH_PARENT"
"""Environment variable holding the batch process's id for the fork server."""


def die_with_parent(expected_parent: int | None = None) -> bool:
    """Have the kernel SIGKILL this process when its parent dies (Linux).

    ``expected_parent``: the parent's id; if the parent is already gone (this process was
    re-parented before the request took effect), exit now. Returns True when armed.
    """
    if not sys.platform.startswith("linux"):
        return False
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            return False
        if expected_parent is not None and os.getppid() != expected_parent:
            os._exit(1)
        return True
    return False
