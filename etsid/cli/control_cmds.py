"""``etsid control``: close the hexacopter's vertical loop with the eTS or PID controller."""

from __future__ import annotations

from pathlib import Path

import click

from etsid.progress import stage

SCENARIO_NAMES = ("altitude-steps", "hover-ige", "ige-sine", "mass-change", "sine-altitude")
"""Kept in step with :data:`etsid.control.scenarios.SCENARIOS` (tests check it), so that
``--help`` does not import the simulator."""
SCENARIO_ALIASES = {"sine": "sine-altitude", "step": "altitude-steps"}
"""Former names still accepted (:data:`etsid.control.scenarios.ALIASES`)."""


def _scenario(ctx: click.Context, param: click.Parameter, value: str) -> str:
    name = SCENARIO_ALIASES.get(value, value)
    if name not in SCENARIO_NAMES:
        raise click.BadParameter(f"{value!r} is not one of {', '.join(SCENARIO_NAMES)}")
    return name


@click.command()
@click.argument("scenario", metavar="{" + "|".join(SCENARIO_NAMES) + "}", callback=_scenario)
@click.option("-o", "--out", "out", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="RUN_DIR to write (flight, metrics, rules, report/); "
              "default ./control-SCENARIO-CONTROLLER.")
@click.option("--controller", type=click.Choice(["ets", "pid"]), default="ets",
              show_default=True, help="eTS controller learning from zero rules, or the PID "
              "baseline.")
@click.option("--vehicle", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Vehicle TOML file (default: the Tarot 680 hexacopter).")
@click.option("--duration", type=click.FloatRange(min=1, max=3600), default=None,
              help="Flight time, s (default: the scenario's).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the sensor noise.")
@click.option("--no-report", is_flag=True, help="Do not draw the figures (RUN_DIR/report/).")
def control(scenario: str, out: Path | None, controller: str, vehicle: Path | None,
            duration: float | None, seed: int, no_report: bool) -> None:
    """Fly SCENARIO with the vertical loop closed by CONTROLLER; write RUN_DIR and figures.

    Scenarios: sine-altitude (2.0 ± 1.0 m, 10 s; the task of `etsid simulate
    sine-altitude`), altitude-steps, hover-ige (0.32 m), mass-change (+1 kg at 30 s),
    ige-sine (0.30–1.20 m); the former names sine and step still work. Scores start after
    the first 10 s.
    """
    from etsid.control import run_control

    if out is None:
        out = Path(f"control-{scenario}-{controller}")
    with stage(f"control: {scenario} with {controller}"):  # the simulator loads, flies
        result = run_control(scenario, controller, vehicle=vehicle, duration=duration,
                             seed=seed, out=out)
    m = result.metrics
    line = (f"{out}: {controller} on {scenario}, {m['duration_s']:.0f} s, "
            f"{'stable' if m['stable'] else 'DIVERGED'}")
    if m.get("tracking_rmse") is not None:
        line += (f", tracking RMSE {m['tracking_rmse']:.4f} m, max error "
                 f"{m['max_error']:.3f} m (after {m['score_after_s']:g} s)")
    if m.get("rules_final") is not None:
        line += f", {m['rules_final']} rules, {m['rule_replacements']} replacements"
    click.echo(line)
    if not no_report:
        from etsid.report.control import make_control_report

        with stage(f"control report: drawing the figures into {out}/report/"):
            rep = make_control_report(out)
        click.echo(f"wrote {rep.directory}/: index.html, report.md, "
                   + ", ".join(p.name for p in rep.figures.values()))


COMMANDS = [control]
