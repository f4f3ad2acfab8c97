"""Option bundles shared by several commands."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from etsid.progress import wanted

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from etsid.ingest.base import ReadOptions

MAX_RATE_HZ = 100_000.0
"""Highest grid or identification rate accepted, Hz (no flight log samples faster)."""


class RateHz(click.ParamType):
    """A rate in Hz: finite, above zero (or zero when ``allow_zero``), at most MAX_RATE_HZ.

    ``nan``, ``inf`` and ``1e-6`` are refused here, naming the option, rather than failing
    later with a message about something else.
    """

    name = "HZ"

    def __init__(self, allow_zero: bool = False, min_hz: float = 1e-3) -> None:
        self.allow_zero = allow_zero
        self.min_hz = min_hz

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        try:
            rate = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number of Hz", param, ctx)
        if self.allow_zero and rate == 0:
            return 0.0
        if not (self.min_hz <= rate <= MAX_RATE_HZ):
            low = "0 or " if self.allow_zero else ""
            self.fail(f"{value} is not a rate in Hz ({low}{self.min_hz:g} … {MAX_RATE_HZ:g})",
                      param, ctx)
        return rate


def check_output_dir(out: Path, option: str = "--out") -> None:
    """Refuse an output directory that cannot be written, before any log is read."""
    target = out
    while not target.exists() and target != target.parent:
        target = target.parent
    if target.exists() and not target.is_dir():
        raise click.BadParameter(f"{target} is not a directory", param_hint=option)
    if not os.access(target, os.W_OK | os.X_OK) or str(target.resolve()).startswith(
            ("/proc", "/sys")):
        raise click.BadParameter(f"{out}: cannot write there ({target} is not writable)",
                                 param_hint=option)


def log_options(func: Callable[..., Any]) -> Callable[..., Any]:
    """``--map``, ``--mapping``, ``--sysid``, ``--quiet``: how a log is read."""
    func = click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(func)
    func = click.option(
        "--sysid", type=int, default=None,
        help="MAVLink system id to read (default: the one with most ATTITUDE).",
    )(func)
    func = click.option(
        "--mapping", "mapping_file", type=click.Path(dir_okay=False, path_type=Path),
        default=None, help='TOML mapping file ([map] COLUMN = "TOPIC.FIELD", [rc]).',
    )(func)
    func = click.option("--map", "maps", multiple=True, metavar="COLUMN=TOPIC[.FIELD]",
                        help="Map a column to a topic/message (and field); repeatable.")(func)
    return func


def read_options(maps: tuple[str, ...], mapping_file: Path | None, sysid: int | None,
                 quiet: bool) -> ReadOptions:
    """Build :class:`ReadOptions` from the :func:`log_options` values (ingest, which loads
    numpy, is imported here: not for a command's ``--help``)."""
    from etsid.ingest.base import ReadOptions
    from etsid.ingest.mapping import load_mapping_file, parse_override

    options = ReadOptions(sysid=sysid, progress=wanted(quiet))
    if mapping_file is not None:
        overrides, rc = load_mapping_file(mapping_file)
        options.overrides.extend(overrides)
        options.rc_map = rc
    options.overrides.extend(parse_override(text) for text in maps)
    return options


def echo_table_notes(table: pd.DataFrame) -> None:
    """Print what reading the table dropped, repaired or noted (its attrs) on stderr."""
    attrs = table.attrs
    for kind in ("dropped", "repaired"):
        for item in attrs.get(kind) or []:
            click.echo(f"{kind}: {item['count']} ({item['reason']}) {item['signal']}", err=True)
    for warning in attrs.get("warnings") or []:
        click.echo(f"note: {warning}", err=True)
