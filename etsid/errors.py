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
    """Sim-vs-real gap analysis cannot be carried out."""


class BatchError(EtsidError):
    """A batch cannot be set up or one log cannot be run: no inputs, an unreadable list
    file, a bad pairs CSV, a missing input, an unreachable scheduler."""


class ControlError(EtsidError):
    """A control experiment cannot be set up (unknown scenario or controller, bad setting)."""


class FitError(EtsidError):
    """``etsid fit``: a log that cannot give an airframe's parameters (no motor outputs, too
    few active motors, no airborne data)."""
