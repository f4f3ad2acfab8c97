"""What every log of a batch is run with: the command and its options, and their digest."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from typing import Any

from etsid.batch.fetch import DEFAULT_PROTOCOLS

COMMANDS = ("inspect", "ingest", "identify", "gap")
"""Batch commands; each runs the single command of the same name on every log."""


@dataclass
class BatchSpec:
    """The command and options every log of a batch is run with (picklable, sent to workers).

    Parameters
    ----------
    command
        One of :data:`COMMANDS`.
    read_options
        :class:`etsid.ingest.ReadOptions` (``--map``, ``--mapping``, ``--sysid``); its
        ``progress`` flag is ignored (workers draw no bars).
    ident_config
        :class:`etsid.ident.IdentConfig` for ``identify`` (None otherwise).
    rate_hz, start, end
        Grid rate (Hz) and window (s) of the table, as ``etsid ingest`` / ``identify``.
    extra
        Further options that change results and belong in the digest (e.g. the content
        hash of a ``--mapping`` file, gap options).
    protocols
        URL schemes the workers may open (``file`` and those named by ``--protocol``);
        not in the digest: it decides what may be read, not what a log gives.
    """

    command: str
    read_options: Any = None
    ident_config: Any = None
    rate_hz: float | None = None
    start: float | None = None
    end: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    protocols: tuple[str, ...] = DEFAULT_PROTOCOLS

    def options(self) -> dict[str, Any]:
        """Every option that changes a log's result, as plain JSON types."""
        read = None
        if self.read_options is not None:
            read = dataclasses.asdict(self.read_options)
            read.pop("progress", None)
        ident = (dataclasses.asdict(self.ident_config)
                 if self.ident_config is not None else None)
        return {"command": self.command, "read": read, "ident": ident,
                "rate_hz": self.rate_hz, "start": self.start, "end": self.end,
                "extra": self.extra}

    def digest(self) -> str:
        """SHA-256 (hex) of :meth:`options`: a result is reused by ``--resume`` only for the
        same input hash and the same digest."""
        text = json.dumps(self.options(), sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()
