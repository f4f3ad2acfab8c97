"""Option bundles shared by several commands."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import pandas as pd

from etsid.ingest.base import ReadOptions
from etsid.ingest.mapping import load_mapping_file, parse_override
from etsid.progress import wanted


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
    """Build :class:`ReadOptions` from the :func:`log_options` values."""
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
