"""Exception classes, one per layer. The CLI turns them into one-line messages, exit code 1."""

from __future__ import annotations


class EtsidError(Exception):
    """Base of every error etsid raises on purpose; its message is meant for people."""


class TableError(EtsidError):
    """A FlightTable (or a saved table file) breaks the contract in etsid/table.py."""


class IngestError(EtsidError):
    """A log file cannot be read: names the file and what is wrong with it."""


class ModelError(EtsidError):
    """An eTS model or rule-base file is invalid."""


class SimError(EtsidError):
    """A vehicle file, scenario or simulation setting is invalid."""


class IdentError(EtsidError):
    """An identification run cannot be set up (missing columns, bad regressor spec)."""


class ReportError(EtsidError):
    """A report cannot be written: not a run directory, or a bad figure format."""


class GapError(EtsidError):
    """Sim-vs-real gap analysis cannot be carried out.

    Not raised yet: reserved for the gap-analysis room (``etsid/gap/``, the next issue),
    so that its errors have their own class from the first line of code.
    """


class BatchError(EtsidError):
    """A batch cannot be set up or one log cannot be run: no inputs, an unreadable list
    file, a bad pairs CSV, a missing input, an unreachable scheduler."""
