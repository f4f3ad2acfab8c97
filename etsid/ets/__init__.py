"""Evolving Takagi–Sugeno (eTS / eTS+) MIMO models: learning, prediction, rule-base JSON.

The core imports nothing of etsid except :mod:`etsid.errors`.
"""

from __future__ import annotations

from etsid.ets.history import History
from etsid.ets.model import ETS
from etsid.ets.params import ETSParams
from etsid.ets.state import LearnedState

__all__ = ["ETS", "ETSParams", "History", "LearnedState"]
