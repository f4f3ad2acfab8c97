"""Imported by the local pool's fork server before it forks workers: importing this module
runs :func:`etsid.batch.tasks.warm` for ``identify``, so that every worker is born with the
eTS and ARX kernels loaded (numba cache) instead of loading them again after each renewal.
"""

from __future__ import annotations

from etsid.batch.tasks import warm

warm("identify")
