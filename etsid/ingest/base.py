"""What every reader hands back: source signals on native clocks, and a catalogue of channels.

A reader (one module per format) turns a log into a :class:`RawLog`: for every
FlightTable column it can fill, one or more candidate :class:`Signal` objects, each with
its own native timestamps, already in SI units and FRD/NED frames. Choosing among
candidates (:mod:`etsid.ingest.mapping`) and putting them on one grid
(:mod:`etsid.ingest.align`) is common to all formats.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from etsid.escape import printable as printable  # the one escaping path, re-exported
from etsid.pwm import DEFAULT_RC_MAP, DEFAULT_RC_RANGE_US


@dataclass
class Signal:
    """One source signal that can fill one FlightTable column.

    Parameters
    ----------
    column
        FlightTable column name (``p``, ``u_roll``, …) or, for user overrides, any name.
    t
        Sample times, s, on the log's native clock (any origin, float64).
    values
        Samples in the column's SI unit and FRD/NED frame, float64, same length as ``t``.
    source
        ``TOPIC.FIELD`` it came from, e.g. ``ATTITUDE.rollspeed`` or
        ``/mavros/imu/data.angular_velocity.x`` (before the frame conversion).
    priority
        Lower wins when several signals fill the same column (see docs/ingest.md).
    """

    column: str
    t: np.ndarray
    values: np.ndarray
    source: str
    priority: int = 10

    @property
    def topic(self) -> str:
        """Topic or message name part of :attr:`source`."""
        return split_source(self.source)[0]

    @property
    def rate_hz(self) -> float:
        """Mean native rate, Hz (0 for fewer than two samples)."""
        if self.t.size < 2 or self.t[-1] <= self.t[0]:
            return 0.0
        return float((self.t.size - 1) / (self.t[-1] - self.t[0]))


@dataclass
class Channel:
    """One topic / message stream in a log, as ``etsid inspect`` lists it."""

    name: str
    type: str
    count: int
    t_first: float | None = None
    t_last: float | None = None
    columns: list[str] = field(default_factory=list)
    note: str = ""

    @property
    def rate_hz(self) -> float:
        """Mean rate, Hz (0 when unknown)."""
        if self.t_first is None or self.t_last is None or self.count < 2:
            return 0.0
        span = self.t_last - self.t_first
        return (self.count - 1) / span if span > 0 else 0.0


@dataclass
class Issue:
    """Samples a reader dropped or repaired, with the reason (nothing is dropped silently)."""

    reason: str
    count: int
    signal: str = ""


@dataclass
class RawLog:
    """Everything a reader extracted from one log file."""

    path: Path
    format: str
    channels: list[Channel] = field(default_factory=list)
    signals: list[Signal] = field(default_factory=list)
    start_time: float | None = None
    """Absolute time (Unix s) of native-clock zero, when the log knows it."""
    dropped: list[Issue] = field(default_factory=list)
    repaired: list[Issue] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    extra: dict[str, object] = field(default_factory=dict)
    """Format-specific facts for ``inspect`` (system ids, storage, profile, …)."""


@dataclass
class Override:
    """A user mapping ``COLUMN=TOPIC[.FIELD]``; FIELD is a dotted path (``a.b[0]``)."""

    column: str
    topic: str
    field: str | None = None

    @property
    def text(self) -> str:
        return f"{self.column}={self.topic}" + (f".{self.field}" if self.field else "")


@dataclass
class ReadOptions:
    """Options every reader accepts (a reader ignores those that do not apply)."""

    overrides: list[Override] = field(default_factory=list)
    rc_map: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_RC_MAP))
    """Stick → RC channel number (1-based), ArduPilot AETR default."""
    rc_range_us: tuple[float, float, float] = DEFAULT_RC_RANGE_US
    """PWM min, centre, max in µs for RC channels (−1…1, throttle 0…1) and motors (0…1),
    converted by :mod:`etsid.pwm`."""
    sysid: int | None = None
    progress: bool = False
    """Show a progress bar on stderr (the CLI sets it when stderr is a TTY)."""

    def field_requests(self) -> list[Override]:
        """Overrides that ask for an explicit field the reader must extract itself."""
        return [o for o in self.overrides if o.field]


def split_source(source: str) -> tuple[str, str]:
    """Split ``TOPIC.FIELD`` at the first dot after the topic.

    ROS topics and MAVLink/ULog message names contain no dots, so the first dot ends the
    topic.

    >>> split_source("/mavros/imu/data.angular_velocity.x")
    ('/mavros/imu/data', 'angular_velocity.x')
    >>> split_source("ATTITUDE")
    ('ATTITUDE', '')
    """
    topic, _, fld = source.partition(".")
    return topic, fld


def get_field(obj: object, path: str) -> float:
    """Numeric value at a dotted path (``angular_velocity.x``, ``channels[2]``) of a message.

    Works on objects with attributes, dicts and sequences.

    >>> get_field({"a": {"b": [1.0, 2.5]}}, "a.b[1]")
    2.5
    """
    value: object = obj
    for part in path.split("."):
        name, _, rest = part.partition("[")
        if name:
            value = value[name] if isinstance(value, dict) else getattr(value, name)
        while rest:
            index, _, rest = rest.partition("]")
            value = value[int(index)]  # type: ignore[index]
            rest = rest.lstrip("[")
    return float(value)  # type: ignore[arg-type]
