"""etsid: learn a drone's rate dynamics from its flight logs with evolving Takagi-Sugeno models."""

from __future__ import annotations

__version__ = "0.1.0"
