"""``etsid gap``."""

from __future__ import annotations

from pathlib import Path

import click

from etsid.errors import GapError
from etsid.files import read_json, read_text
from etsid.progress import done, on_terminal, say

SCHEMA = Path(__file__).resolve().parents[1] / "gap" / "gap.schema.json"


def effect_names() -> list[str]:
    """The vocabulary as the shipped gap.json schema lists it (a test keeps that list equal
    to the effect registry's): read without importing the analysis, so that
    ``etsid gap --help`` starts at once."""
    schema = read_json(SCHEMA, "package", GapError)
    return list(schema["properties"]["effects"]["items"]["properties"]["name"]["enum"])


@click.command()
@click.argument("sim_log", type=click.Path(path_type=Path))
@click.argument("real_log", type=click.Path(path_type=Path))
@click.option("--out", "-o", "out_dir", type=click.Path(path_type=Path), required=True,
              help="Directory for gap.json, report.md, index.html and figures.")
@click.option("--vehicle", type=str, default=None,
              help="Vehicle TOML file or packaged name; sharpens the rotor-speed law and the "
                   "ground-effect geometry (optional).")
@click.option("--json", "as_json", is_flag=True, help="Print gap.json instead of the summary.")
def gap(sim_log: Path, real_log: Path, out_dir: Path, vehicle: str | None,
        as_json: bool) -> None:
    """Locate where SIM_LOG and REAL_LOG disagree and name the physics SIM left out."""
    from etsid.gap.run import run_gap
    from etsid.report.gap import make_gap_report

    try:
        result = run_gap(sim_log, real_log, out_dir, vehicle, progress=say)
        report = make_gap_report(out_dir, say=say)
    finally:
        done()
    files = ", ".join(["gap.json", "index.html (interactive)", "report.md",
                       *(p.name for p in report.figures.values())])
    if as_json:
        click.echo(read_text(out_dir / "gap.json", "gap", GapError).rstrip())
        if on_terminal():
            click.echo(f"wrote {out_dir}/ ({files})", err=True)
    else:
        click.echo(result.summary)
        click.echo(f"wrote {out_dir}/ ({files})")


gap.help = (
    "Locate where SIM_LOG and REAL_LOG disagree and name the physics SIM left out.\n\n"
    "Fits a physics-structured model on the simulation, predicts the recording, and explains "
    f"what differs with named effects ({', '.join(effect_names())}), fitted on one part of "
    "the recording and proven on another. Verdicts: consistent, mismatch, insufficient, "
    "different-vehicle (the logs are of two airframes).")
"""The help lists the effect registry's vocabulary (:mod:`etsid.gap.effects`, through the
shipped schema)."""

COMMANDS = [gap]
