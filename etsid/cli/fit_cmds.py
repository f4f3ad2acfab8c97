"""``etsid fit``."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("fit")
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Vehicle TOML to write (NAME.fit.json beside it holds every parameter).")
@click.option("--template", default=None,
              help="Packaged vehicle or TOML whose declared fields (mass, blades, torque "
                   "ratio) stand in for what logs cannot determine (default: by arm "
                   "length).")
@click.option("--name", default=None, help="Vehicle name in the file (default: OUT's stem).")
def fit(logs: tuple[Path, ...], out: Path, template: str | None, name: str | None) -> None:
    """Fit an airframe's physical parameters from its LOGS (flights of one airframe, pooled)
    and write them as a vehicle file the simulator flies.

    Every parameter gets a standard error and a verdict: identified, not-determined (this
    flight does not pin it down: the template's value), unidentifiable (no log can: a
    declared default) or declared (read from the log's parameters). Method: docs/fit.md.
    """
    from etsid.fit import fit_tables
    from etsid.fit.output import write_fit
    from etsid.ingest import read_log
    from etsid.sim.vehicle import load_vehicle

    tables = [read_log(p) for p in logs]
    tmpl = load_vehicle(template) if template else None
    result = fit_tables(tables, template=tmpl, name=name or out.stem)
    vehicle_path, json_path = write_fit(result, out)
    click.echo(result.summary())
    click.echo(f"rotors: {result.layout['n']} ({result.layout['source']})")
    click.echo(f"wrote {vehicle_path} and {json_path}")


COMMANDS = [fit]
