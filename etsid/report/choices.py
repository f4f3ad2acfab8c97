"""The choices of ``etsid report``, in a module that imports nothing (no matplotlib), so that
``etsid report --help`` lists them at once."""

from __future__ import annotations

FORMATS = ("png", "svg", "pdf")
"""Formats of the static figures (``--format``); :mod:`etsid.report.build` re-exports it."""
