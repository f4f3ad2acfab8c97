"""``etsid batch inspect|ingest|identify|gap``: one command over many logs.

Each batch command takes the options of the single command of the same name (the very same
click options, so the two never drift apart) plus the batch options.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from etsid.batch.limits import RENEW_GROWTH_MB
from etsid.cli.ident_cmds import identify_cmd
from etsid.cli.ingest_cmds import ingest as ingest_cmd
from etsid.cli.ingest_cmds import inspect as inspect_cmd
from etsid.cli.options import read_options
from etsid.errors import BatchError
from etsid.progress import stage, wanted

if TYPE_CHECKING:  # pragma: no cover
    from etsid.batch.run import BatchSummary
    from etsid.batch.spec import BatchSpec

_NOT_BATCH = {"log", "out", "as_json", "quiet"}
"""Parameters of the single commands a batch sets itself."""


def _batch_options(func: Callable[..., Any]) -> Callable[..., Any]:
    func = click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(func)
    func = click.option("--dashboard", default=None, metavar="HOST:PORT",
                        help="--scheduler processes: serve Dask's dashboard at this "
                             "address, e.g. 127.0.0.1:8787 (this machine only; "
                             "0.0.0.0:8787 opens it to the network). Default: none.")(func)
    func = click.option("--protocol", "protocols", multiple=True, metavar="NAME",
                        help="Also open URLs of this fsspec protocol (repeatable, e.g. "
                             "--protocol s3); file:// is always allowed, any other URL "
                             "is an error row without being opened.")(func)
    func = click.option("--max-memory", "max_memory_mb", type=click.FloatRange(100),
                        default=None, metavar="MB",
                        help="Memory limit of each local worker process, MB: a log whose "
                             "worker grows past it becomes an error row and the worker goes "
                             "on (default: no limit; the pool is renewed anyway when a "
                             f"worker has grown by {RENEW_GROWTH_MB:g} MB since its first "
                             "log).")(func)
    func = click.option("--skip-failed", is_flag=True,
                        help="With --resume, also skip the logs whose earlier run failed "
                             "(by default they run again).")(func)
    func = click.option("--resume", is_flag=True,
                        help="Skip every log that has a successful result for the same "
                             "input (SHA-256) and options; failed logs run again.")(func)
    func = click.option("--scheduler", default="local", show_default=True,
                        metavar="local|processes|dask://HOST:PORT",
                        help="local: a process pool here; processes: a Dask LocalCluster "
                             "here; dask://HOST:PORT (or tcp://, tls://): an existing Dask "
                             "cluster (processes and dask:// need etsid[cluster]).")(func)
    func = click.option("--jobs", "-j", type=click.IntRange(1), default=None,
                        help="Worker processes (default: every core).")(func)
    func = click.option("-o", "--out", required=True,
                        type=click.Path(file_okay=False, path_type=Path),
                        help="Batch directory: runs/ (one directory per log), results/ "
                             "(the Parquet dataset), batch.json.")(func)
    return func


_BATCH = ("out", "jobs", "scheduler", "resume", "skip_failed", "max_memory_mb", "protocols",
          "dashboard", "quiet")
"""Parameters of :func:`_batch_options`."""


def _borrowed(command: click.Command) -> list[click.Parameter]:
    return [p for p in command.params if p.name not in _NOT_BATCH]


def _echo_summary(summary: BatchSummary, command: str) -> None:
    for item, error in summary.failures[:20]:
        click.echo(f"failed: {error if error.startswith(item) else f'{item}: {error}'}",
                   err=True)
    if len(summary.failures) > 20:
        click.echo(f"… and {len(summary.failures) - 20} more failures (see results/)",
                   err=True)
    skipped = f", {summary.skipped} skipped (--resume)" if summary.skipped else ""
    rate = summary.total / summary.wall_s * 60 if summary.wall_s > 0 else float("nan")
    logs = "log" if summary.total == 1 else "logs"
    click.echo(f"{summary.total} {logs}: {summary.ok} ok, {summary.failed} failed{skipped} in "
               f"{summary.wall_s:.1f} s ({rate:.1f} logs/min); results in "
               f"{summary.out}/results/; next: etsid report {summary.out}")


def _find(logs: tuple[str, ...], out: Path, protocols: tuple[str, ...]) -> list[str]:
    """The logs of LOGS; saved tables met in its directories are not run, and said so."""
    from etsid.batch.fetch import is_url
    from etsid.batch.inputs import find_inputs

    missing = [item for item in logs if not is_url(item) and not os.path.lexists(item)]
    if missing:
        shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more"
                                            if len(missing) > 5 else "")
        raise BatchError(f"{shown}: no such file or directory (nothing run)")
    tables: list[str] = []
    items = find_inputs(logs, exclude=out, unsearched=tables, protocols=protocols)
    if tables:
        first = tables[0].replace("\\", "/")
        folder, suffix = first.rsplit("/", 1)[0], Path(first).suffix
        what = (f"{len(tables)} saved table{'s' if len(tables) > 1 else ''} "
                f"({', '.join(sorted({Path(t).suffix for t in tables}))})")
        hint = f"saved tables run only when named, e.g. {folder}/*{suffix}"
        if not items:
            raise BatchError(f"no logs to run: the directories hold {what} and no log; "
                             f"{hint}")
        click.echo(f"note: {what} in the directories not run: {hint}", err=True)
    return items


def _run(items: list[Any] | None, logs: tuple[str, ...], spec: BatchSpec,
         batch: dict[str, Any]) -> None:
    """Run ``spec`` over ``items`` (or the logs found in ``logs``) with the batch options."""
    with stage("batch: loading"):  # pyarrow, numpy: not for --help
        from etsid.batch.run import EXIT_ALL_FAILED, run_batch

    spec.protocols = ("file", *batch["protocols"])
    if items is None:
        items = _find(logs, batch["out"], spec.protocols)
    summary = run_batch(items, spec, batch["out"], jobs=batch["jobs"],
                        scheduler=batch["scheduler"], resume=batch["resume"],
                        show_progress=wanted(batch["quiet"]),
                        max_memory_mb=batch["max_memory_mb"],
                        retry_failed=not batch["skip_failed"], dashboard=batch["dashboard"])
    _echo_summary(summary, spec.command)
    if summary.failed and not summary.ok:
        click.echo(f"etsid: error: every log failed (exit code {EXIT_ALL_FAILED})", err=True)
        click.get_current_context().exit(EXIT_ALL_FAILED)


def _split(kw: dict[str, Any]) -> dict[str, Any]:
    """The batch options, taken out of ``kw`` (what is left: the single command's)."""
    return {name: kw.pop(name) for name in _BATCH}


def _read_spec(command: str, kw: dict[str, Any]) -> BatchSpec:
    """BatchSpec of the single command's options (``--map``, ``--rate``, …)."""
    from etsid.batch.spec import BatchSpec

    options = read_options(kw.pop("maps", ()), kw.pop("mapping_file", None),
                           kw.pop("sysid", None), True)
    return BatchSpec(command, read_options=options)


_INPUTS = click.argument("logs", nargs=-1, required=True, metavar="INPUTS...")


@click.group()
def batch() -> None:
    """Run inspect, ingest, identify, gap or fit over many logs: a result row per log.

    INPUTS are log files, directories (searched recursively for every supported format;
    a directory with metadata.yaml is a ROS 2 bag), text files (.txt/.list) listing
    inputs, or fsspec URLs. Rows go to the Parquet dataset DIR/results/ (read it with
    pandas, Dask or DuckDB); `etsid report DIR` draws the fleet report.

    Exit codes: 0 at least one log ok (failed logs listed, each with its error row);
    1 nothing run (an input that does not exist, no log found, a bad option; no batch
    directory is left behind); 2 a usage error; 3 every log failed.
    """


@batch.command("inspect")
@_INPUTS
@_batch_options
def batch_inspect(logs: tuple[str, ...], **kw: Any) -> None:
    """etsid inspect on every log of INPUTS."""
    options = _split(kw)
    _run(None, logs, _read_spec("inspect", kw), options)


@batch.command("ingest")
@_INPUTS
@_batch_options
def batch_ingest(logs: tuple[str, ...], **kw: Any) -> None:
    """etsid ingest on every log of INPUTS (RUN_DIR/table.parquet per log)."""
    options = _split(kw)
    spec = _read_spec("ingest", kw)
    spec.rate_hz, spec.start, spec.end = kw["rate_hz"], kw["start"], kw["end"]
    _run(None, logs, spec, options)


@batch.command("identify")
@_INPUTS
@_batch_options
def batch_identify(logs: tuple[str, ...], **kw: Any) -> None:
    """etsid identify on every log of INPUTS (a RUN_DIR per log)."""
    from etsid.ident import IdentConfig

    options = _split(kw)
    spec = _read_spec("identify", kw)
    spec.rate_hz = kw.pop("rate_hz")
    outputs = kw.pop("outputs")
    kw["outputs"] = [s.strip() for s in outputs.split(",") if s.strip()] if outputs else None
    names = {f.name for f in fields(IdentConfig)}
    spec.ident_config = IdentConfig(**{k: v for k, v in kw.items() if k in names})
    _run(None, logs, spec, options)


@batch.command("gap")
@click.argument("pairs", nargs=-1, required=True, type=click.Path(path_type=Path))
@_batch_options
@click.option("--vehicle", default=None,
              help="Vehicle TOML file or packaged name for every pair (as etsid gap).")
def batch_gap(pairs: tuple[Path, ...], vehicle: str | None, **kw: Any) -> None:
    """Sim-vs-real gap analysis of every SIM,REAL pair in the PAIRS CSV files."""
    from etsid.batch import GAP_UNAVAILABLE, gap_available
    from etsid.batch.inputs import read_pairs

    if not gap_available():
        raise BatchError(GAP_UNAVAILABLE)
    options = _split(kw)
    spec = _read_spec("gap", kw)
    if vehicle is not None:
        spec.extra["vehicle"] = vehicle
    _run(list(read_pairs(pairs)), (), spec, options)


@batch.command("fit")
@click.argument("root", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Directory for fleet.csv (one row per flight), flags.json and fleet.png.")
@click.option("--full", is_flag=True,
              help="The full fit per flight (default: the quick fit, about 5x faster: a "
                   "100 Hz grid and the coarse lag/delay grid; docs/fit.md).")
def batch_fit(root: Path, out: Path, full: bool) -> None:
    """etsid fit on every flight below ROOT (one row per flight), grouped by airframe (the
    log's vehicle id where it has one, else its folder); flags a parameter that leaves
    its reference (the first flights) at the flight where the change starts."""
    import json

    with stage("batch: loading"):
        from etsid.fit.fleet import fit_fleet
        from etsid.ingest import read_log
        from etsid.report.fit_fleet import fleet_figure

    def say(line: str) -> None:
        if wanted(False):
            click.echo(line, err=True)

    result = fit_fleet(root, read_log, progress=say, quick=not full)
    out.mkdir(parents=True, exist_ok=True)
    result.rows.to_csv(out / "fleet.csv", index=False)
    (out / "flags.json").write_text(json.dumps({"flags": result.flags,
                                                "errors": result.errors}, indent=1),
                                    encoding="utf-8")
    for error in result.errors:
        click.echo(f"failed: {error}", err=True)
    if not result.rows.empty:
        fleet_figure(result.rows, result.flags, out / "fleet.png")
    n_air = result.rows["airframe"].nunique() if not result.rows.empty else 0
    click.echo(f"{len(result.rows)} flights of {n_air} airframes fitted, "
               f"{len(result.errors)} failed; {len(result.flags)} change(s) flagged")
    for flag in result.flags:
        click.echo(f"  {flag['airframe']}: {flag['param']} changes from flight "
                   f"{flag['flight']} ({flag['name']}, z = {flag['z']:+.1f})")
    click.echo(f"wrote {out}/fleet.csv, flags.json, fleet.png")


for _command, _single in ((batch_inspect, inspect_cmd), (batch_ingest, ingest_cmd),
                          (batch_identify, identify_cmd), (batch_gap, inspect_cmd)):
    _command.params.extend(_borrowed(_single))

COMMANDS = [batch]
