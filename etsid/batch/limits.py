"""Limits of the local pool that ``etsid batch --help`` states, in a module that imports
nothing (the pool itself, :mod:`etsid.batch.local`, loads numpy and pyarrow)."""

from __future__ import annotations

RENEW_GROWTH_MB = 256.0
"""A worker whose resident memory after a log exceeds its resident memory after its first
log by more than this (MB) gets the pool renewed: memory one log leaves behind never
accumulates over the fleet."""
