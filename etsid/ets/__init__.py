"""Evolving Takagi–Sugeno (eTS / eTS+) MIMO models: learning, prediction, rule-base JSON.

The core imports nothing of etsid except :mod:`etsid.errors`. Importing the package loads
no numpy or numba: :class:`ETS`, :class:`History` and :class:`LearnedState` are loaded when
first used, so that light modules such as :mod:`etsid.ets.params` (the option choices of
``etsid identify --help``) import at once.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from etsid.ets.params import ETSParams

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ets.history import History
    from etsid.ets.model import ETS
    from etsid.ets.state import LearnedState

_LAZY = {"ETS": "etsid.ets.model", "History": "etsid.ets.history",
         "LearnedState": "etsid.ets.state"}
"""Public names whose modules import numpy or numba: loaded when first used."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'etsid.ets' has no attribute {name!r}")


__all__ = ["ETS", "ETSParams", "History", "LearnedState"]
