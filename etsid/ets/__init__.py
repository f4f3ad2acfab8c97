"""Evolving Takagi–Sugeno (eTS / eTS+) MIMO models: learning, prediction, rule-base JSON.

The core imports nothing of etsid except :mod:`etsid.errors`.
"""

from __future__ import annotations

from etsid.ets.history import History
from etsid.ets.model import ETS

__all__ = ["ETS", "History"]
