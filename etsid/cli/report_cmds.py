"""``etsid report``."""

from __future__ import annotations

from pathlib import Path

import click

from etsid.report import make_report
from etsid.report.build import FORMATS


@click.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="png", show_default=True,
              help="Figure format.")
def report(run_dir: Path, fmt: str) -> None:
    """Write RUN_DIR/report/: figures, a self-contained index.html and report.md.

    On a batch directory (written by `etsid batch`), the fleet report: distributions of the
    key figures, the best and worst flights linked to their own reports, failures by cause.
    """
    result = make_report(run_dir, fmt)
    names = ", ".join(p.name for p in result.figures.values())
    click.echo(f"wrote {result.directory}/: index.html, report.md, {names}")


COMMANDS = [report]
