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
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Also replay each log with the fitted vehicle and write "
                                 "twin_<log>.png and twin.json here (docs/fit.md).")
def fit(logs: tuple[Path, ...], out: Path, template: str | None, name: str | None,
        report_dir: Path | None) -> None:
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
    if report_dir is not None:
        import json

        from etsid.report.fit_twin import twin_report
        from etsid.sim.vehicle import load_vehicle as load

        report_dir.mkdir(parents=True, exist_ok=True)
        fitted = load(vehicle_path)
        reports = []
        for path, table in zip(logs, tables, strict=True):
            rep = twin_report(table, fitted, report_dir / f"twin_{path.stem}.png")
            reports.append(rep)
            div = rep["divergence"]
            click.echo(f"twin of {path.name}: " + ("follows the recording" if div is None
                       else f"diverges at {div['t']:.1f} s ({div['what']})"))
            for ch, m in rep["channels"].items():
                click.echo(f"  {ch:5s} RMSE/std twin {m['twin']:.2f}, ARX {m['arx']:.2f}, "
                           f"log noise {m['noise']:.2f}")
        (report_dir / "twin.json").write_text(json.dumps(reports, indent=1, default=str),
                                              encoding="utf-8")
        click.echo(f"wrote {report_dir}/twin.json and the twin figures")


COMMANDS = [fit]
