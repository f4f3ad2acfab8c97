"""``etsid report``."""

from __future__ import annotations

from pathlib import Path

import click

from etsid.progress import done, say, stage
from etsid.report.choices import FORMATS


@click.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="png", show_default=True,
              help="Format of the static figures (for papers).")
def report(run_dir: Path, fmt: str) -> None:
    """Write RUN_DIR/report/: an interactive, self-contained index.html (zoom, pan, linked
    time axes, hover values; works offline), report.md and static figures.

    On a batch directory (written by `etsid batch`), the fleet report: distributions of the
    key figures, the best and worst flights linked to their own reports, failures by cause.
    On a directory of `etsid gap` or `etsid control`, their reports.
    """
    with stage("report: loading"):  # matplotlib, pandas: not for --help
        from etsid.batch.pool import WarmPool
        from etsid.report import make_report

    try:
        # a fleet report's ranked flights: their reports written by warm worker processes
        result = make_report(run_dir, fmt, say, run_with=WarmPool)
    finally:
        done()
    names = ["index.html (interactive; open it in a browser)", "report.md",
             *(p.name for p in result.figures.values())]
    for note in result.notes:
        click.echo(f"note: {note}", err=True)
    click.echo(f"wrote {result.directory}/: {', '.join(names)}")


COMMANDS = [report]
