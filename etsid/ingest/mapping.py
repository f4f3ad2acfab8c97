"""Choose one source signal per FlightTable column; parse ``--map`` and TOML mapping files.

Rule when several signals can fill one column (documented in docs/ingest.md):

1. a user override (``--map COLUMN=TOPIC[.FIELD]``) wins; with only a TOPIC it restricts
   the candidates to that topic;
2. otherwise the lowest reader priority (e.g. ATTITUDE rates before raw gyro; a fused
   ``/mavros/imu/data`` before ``data_raw``);
3. then the highest native rate, then the most samples, then the topic name (A→Z)
   (:func:`signal_rank`);
4. rate beats priority for the inertial signals (body rates ``p q r`` and specific force
   ``ax ay az``): when the preferred source is slower than :data:`SLOW_RATE_HZ` (too slow
   for the rate loop, e.g. DataFlash ``RATE`` at 10 Hz) and another candidate is at least
   twice as fast (``IMU.GyrX`` at 49 Hz), the fastest candidate wins (:func:`prefer_rate`);
5. content beats name for the measured columns: a candidate empty over most of the
   flight, stuck at one value (:mod:`etsid.ingest.source_check`) or implausible against
   the other channels (:mod:`etsid.ingest.source_consistency`) gives way to a sound one,
   and the note says which and why.

A caller that has already chosen the signal of some columns by its own rule (identify's
input family, :mod:`etsid.ident.inputs`) passes them as ``preset``; they are used as given
unless a user override names the same column. Every column that had more than one
candidate is reported in ``attrs["warnings"]``.
"""

from __future__ import annotations

from pathlib import Path

from etsid.errors import IngestError
from etsid.files import read_toml
from etsid.ingest.base import DEFAULT_RC_MAP, Override, Signal, split_source
from etsid.ingest.source_check import order_by_content, reference_span
from etsid.ingest.source_consistency import REFEREE_COLUMNS, Referee
from etsid.table import COLUMNS


def parse_override(text: str) -> Override:
    """Parse ``COLUMN=TOPIC[.FIELD]``.

    >>> parse_override("p=/imu/data.angular_velocity.x").field
    'angular_velocity.x'
    """
    column, sep, source = text.partition("=")
    column, source = column.strip(), source.strip()
    if not sep or not column or not source:
        raise IngestError(f"--map {text!r}: expected COLUMN=TOPIC[.FIELD]")
    topic, fld = split_source(source)
    return Override(column=column, topic=topic, field=fld or None)


def load_mapping_file(path: str | Path) -> tuple[list[Override], dict[str, int]]:
    """Read a TOML mapping file: ``[map]`` COLUMN = "TOPIC[.FIELD]", ``[rc]`` stick = channel.

    Example::

        [map]
        p = "/my_imu/data.angular_velocity.x"
        alt = "/lidar/range"

        [rc]
        u_roll = 1
        u_pitch = 2
        u_thrust = 3
        u_yaw = 4
    """
    path = Path(path)
    if not path.exists():
        raise IngestError(f"{path}: mapping file not found")
    data = read_toml(path, "mapping", IngestError, "TOML mapping file")
    unknown = set(data) - {"map", "rc"}
    if unknown:
        raise IngestError(f"{path}: unknown section(s) {sorted(unknown)}; use [map] and [rc]")
    for section in ("map", "rc"):
        if not isinstance(data.get(section, {}), dict):
            raise IngestError(f"{path}: {section} must be a [{section}] table, not a value")
    overrides = []
    for column, source in data.get("map", {}).items():
        if not isinstance(source, str):
            raise IngestError(f"{path}: [map] {column} must be a string 'TOPIC[.FIELD]'")
        overrides.append(parse_override(f"{column}={source}"))
    rc = dict(DEFAULT_RC_MAP)
    for stick, channel in data.get("rc", {}).items():
        if stick not in DEFAULT_RC_MAP:
            raise IngestError(f"{path}: [rc] {stick!r} is not one of {sorted(DEFAULT_RC_MAP)}")
        if not isinstance(channel, int) or not 1 <= channel <= 18:
            raise IngestError(f"{path}: [rc] {stick} must be a channel number 1..18")
        rc[stick] = channel
    return overrides, rc


SLOW_RATE_HZ = 20.0
"""A body-rate or specific-force source slower than this, Hz, gives way to a candidate
twice as fast."""

FAST_COLUMNS = ("p", "q", "r", "ax", "ay", "az")
"""Columns of rule 4 (rate beats priority)."""


def prefer_rate(column: str, cands: list[Signal]) -> list[Signal]:
    """``cands`` (sorted by :func:`signal_rank`) with the fastest first when rule 4 of the
    module docstring applies."""
    if column not in FAST_COLUMNS or len(cands) < 2:
        return cands
    first = cands[0]
    fastest = max(cands, key=lambda s: s.rate_hz)
    if first.rate_hz < SLOW_RATE_HZ and fastest.rate_hz >= 2.0 * first.rate_hz:
        return [fastest] + [s for s in cands if s is not fastest]
    return cands


def signal_rank(sig: Signal) -> tuple[int, float, int, str]:
    """Sort key of rules 2–3 of the module docstring: the best candidate sorts first."""
    return (sig.priority, -sig.rate_hz, -sig.t.size, sig.source)


def choose_signals(
    signals: list[Signal], overrides: list[Override], path: Path,
    preset: dict[str, Signal] | None = None,
) -> tuple[dict[str, Signal], list[str]]:
    """Pick one signal per column by the rule in the module docstring.

    Parameters
    ----------
    signals
        The reader's candidate signals.
    overrides
        The user's ``--map`` overrides (they win).
    path
        The log, for messages.
    preset
        Column → signal (one of ``signals``) already chosen by the caller; used as given
        unless an override names the column.

    Returns
    -------
    chosen
        column → signal.
    notes
        Human-readable notes on ambiguous columns.
    """
    span = reference_span(signals)
    by_column: dict[str, list[Signal]] = {}
    for sig in signals:
        if sig.t.size:
            by_column.setdefault(sig.column, []).append(sig)
    notes_of: dict[str, str] = {}
    chosen: dict[str, Signal] = {}
    wanted = {o.column: o for o in overrides}
    preset = preset or {}
    referee = Referee(chosen, by_column, span)
    # the referees (attitude, vertical velocity) first: the columns they judge read them
    order = sorted(by_column, key=lambda c: c not in REFEREE_COLUMNS)
    for column in order:
        cands = by_column[column]
        override = wanted.get(column)
        if override is None and column in preset:
            chosen[column] = preset[column]
            continue
        if override is not None:
            picked = [
                s for s in cands
                if s.topic == override.topic
                and (override.field is None or s.source == f"{override.topic}.{override.field}")
            ]
            if not picked:
                found = ", ".join(sorted({s.source for s in cands}))
                raise IngestError(
                    f"{path}: --map {override.text} matches no signal; candidates: {found}"
                )
            cands = picked
        cands = sorted(cands, key=signal_rank)
        why = None
        if override is None:
            cands, why = order_by_content(column, prefer_rate(column, cands), span,
                                          referee.judge)
        chosen[column] = cands[0]
        if why is not None:
            notes_of[column] = why
        elif len({s.source for s in cands}) > 1 and override is None:
            others = ", ".join(s.source for s in cands[1:])
            notes_of[column] = f"{column}: used {cands[0].source} (also found {others})"
    for column, override in wanted.items():
        if column not in chosen:
            topics = sorted({s.topic for s in signals})
            raise IngestError(
                f"{path}: --map {override.text}: topic or field not found; topics with "
                f"usable data: {', '.join(topics) or 'none'}"
            )
    # columns and notes in the reader's order, whatever order they were judged in
    return ({c: chosen[c] for c in by_column if c in chosen},
            [notes_of[c] for c in by_column if c in notes_of])


def check_columns(column: str) -> None:
    """Raise for an override naming a column that is neither known nor a valid name."""
    if column not in COLUMNS and not column.isidentifier():
        raise IngestError(f"--map: {column!r} is not a valid column name")
