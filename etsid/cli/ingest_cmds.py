"""``etsid inspect`` and ``etsid ingest``."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import Any

import click

from etsid.cli.options import RateHz, echo_table_notes, log_options, read_options
from etsid.errors import IngestError
from etsid.escape import printable
from etsid.progress import stage


@click.command()
@click.argument("log", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@log_options
def inspect(log: Path, as_json: bool, maps: tuple[str, ...], mapping_file: Path | None,
            sysid: int | None, quiet: bool) -> None:
    """Show what a LOG holds: format, duration, topics/messages and the columns they fill."""
    with stage("inspect: loading"):  # numpy: not for --help
        from etsid.ingest import inspect_log

    info = inspect_log(log, read_options(maps, mapping_file, sysid, quiet))
    if as_json:
        click.echo(json.dumps(info, indent=2, default=str))
        return
    click.echo(format_inspect(info))


def format_inspect(info: dict[str, Any]) -> str:
    """Human-readable ``inspect`` output (names from the log with control characters
    shown as ``\\xNN``, never sent to the terminal)."""
    text = _printable_info(info)
    return "\n".join(printable(line) for line in _inspect_lines(text).splitlines())


def _printable_info(info: dict[str, Any]) -> dict[str, Any]:
    """``info`` with every channel name, type and note made printable (so that the
    columns line up on what is shown)."""
    channels = [{**c, "name": printable(str(c["name"])), "type": printable(str(c["type"])),
                 "note": printable(str(c["note"]))} for c in info["channels"]]
    return {**info, "channels": channels}


def _inspect_lines(info: dict[str, Any]) -> str:
    lines = [f"file:      {info['path']}", f"format:    {info['format']}"]
    if info["start_time"]:
        start = dt.datetime.fromtimestamp(info["start_time"], tz=dt.UTC)
        lines.append(f"start:     {start:%Y-%m-%d %H:%M:%S} UTC")
    if info["duration_s"] is not None:
        lines.append(f"duration:  {info['duration_s']:.2f} s")
    for key, value in info["extra"].items():
        lines.append(f"{key + ':':<10} {value}")
    width = max((len(c["name"]) for c in info["channels"]), default=5)
    twidth = max((len(c["type"]) for c in info["channels"]), default=4)
    lines.append("")
    lines.append(f"{'topic':<{width}}  {'type':<{twidth}}  {'count':>8}  {'rate Hz':>8}  columns")
    for c in info["channels"]:
        cols = " ".join(c["columns"]) + (f"  ({c['note']})" if c["note"] else "")
        lines.append(f"{c['name']:<{width}}  {c['type']:<{twidth}}  {c['count']:>8}  "
                     f"{c['rate_hz']:>8.2f}  {cols}")
    if info["mapping"]:
        lines.append("")
        lines.append("mapping:")
        lines.extend(f"  {col:<9} <- {src}" for col, src in info["mapping"].items())
    for kind in ("dropped", "repaired"):
        for item in info[kind]:
            lines.append(f"{kind}: {item['count']} ({item['reason']}) {item['signal']}")
    lines.extend(f"note: {w}" for w in info["warnings"])
    return "\n".join(lines)


@click.command()
@click.argument("log", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Output table, .parquet or .csv.")
@click.option("--rate", "rate_hz", type=RateHz(), default=None,
              help="Grid rate in Hz (default: native rate of the body-rate source).")
@click.option("--start", type=float, default=None, help="Start, s from the first sample.")
@click.option("--end", type=float, default=None, help="End, s from the first sample.")
@log_options
def ingest(log: Path, out: Path, rate_hz: float | None, start: float | None, end: float | None,
           maps: tuple[str, ...], mapping_file: Path | None, sysid: int | None,
           quiet: bool) -> None:
    """Read LOG into a FlightTable (SI units, FRD body / NED world) and save it."""
    with stage("ingest: loading"):  # numpy: not for --help
        from etsid.ingest import read_log
        from etsid.table import save_table

    if out.suffix.lower() not in (".parquet", ".csv"):
        raise click.BadParameter("must end in .parquet or .csv", param_hint="--out")
    table = read_log(log, read_options(maps, mapping_file, sysid, quiet), rate_hz=rate_hz,
                     start=start, end=end)
    if len(table) == 0:
        raise IngestError(f"{log}: the table has no rows")
    overwrote = out.exists()
    try:
        save_table(table, out)
    except OSError as err:
        raise IngestError(f"{out}: cannot write ({err.strerror or err})") from err
    t = table.index.to_numpy(dtype=float)
    rate = table.attrs.get("rate_hz") or (
        (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else float("nan"))
    click.echo(f"{out}: {len(table)} rows x {len(table.columns)} columns at "
               f"{rate:.2f} Hz, {t[-1] - t[0]:.2f} s "
               f"({', '.join(c for c in table.columns)})"
               + ("; overwrote the existing file" if overwrote else ""))
    echo_table_notes(table)


COMMANDS = [inspect, ingest]
