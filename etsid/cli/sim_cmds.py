"""``etsid simulate``: fly a scenario with the hexacopter physics and write a real log."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import click

from etsid.cli.settings import parse_assignments
from etsid.errors import SimError
from etsid.progress import stage
from etsid.sim.vehicle_params import RUN
from etsid.sim.writers import WRITE_FORMATS, format_for

if TYPE_CHECKING:
    import pandas as pd


def _scenario_names() -> list[str]:
    from etsid.sim import SCENARIOS

    return sorted(SCENARIOS)


_SUFFIX_FORMATS = {".tlog": ("tlog",), ".bag": ("ros1",), ".db3": ("ros2-db3",),
                   ".mcap": ("mcap", "mcap-ros1", "mcap-json", "ros2-mcap"),
                   ".parquet": ("parquet",), ".csv": ("csv",)}


def _check_out(out: Path, fmt: str | None) -> None:
    """Refuse an output path that cannot be written, before minutes of simulation."""
    chosen = format_for(out, fmt)
    allowed = _SUFFIX_FORMATS.get(out.suffix.lower())
    if fmt is not None and allowed is not None and chosen not in allowed:
        raise SimError(f"{out}: --format {fmt} does not match the extension {out.suffix}")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise SimError(f"{out}: the directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise SimError(f"{out}: the directory {parent} is not writable")
    if out.is_dir() and chosen not in ("ros2-db3", "ros2-mcap"):
        raise SimError(f"{out}: is a directory; give a file name")


@click.command()
@click.argument("scenario", required=False)
@click.option("-o", "--out", type=click.Path(path_type=Path), default=None,
              help="Output log; the extension picks the format (.tlog .bag .db3 .mcap "
                   ".parquet .csv).")
@click.option("--format", "fmt", type=click.Choice(WRITE_FORMATS), default=None,
              help="Log format when the extension is not enough (e.g. ros2-mcap).")
@click.option("--vehicle", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Vehicle TOML file (default: the Tarot 680 hexacopter).")
@click.option("--duration", type=click.FloatRange(min=RUN["duration"].low, max=RUN["duration"].high,
                                                 min_open=RUN["duration"].low_open), default=None,
              help="Flight time, s (default: the scenario's).")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed (noise, "
              "excitation).")
@click.option("--ground-effect", type=click.Choice(["on", "off"]), default="on",
              show_default=True, help="Model ground effect.")
@click.option("--rate", "rate_hz", type=click.FloatRange(min=RUN["rate"].low, max=RUN["rate"].high),
              default=250.0,
              show_default=True, help="Sensor/table rate, Hz.")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="Change a setting; repeatable. vehicle.EFFECT (time_delay, motor_lag, "
                   "thrust_scale, torque_scale, cg_offset, torque_offset, inertia_scale, "
                   "gyro_bias, accel_bias, estimator, ground_effect_torque, battery_sag, "
                   "weak_motor, rotor_twist), "
                   "vehicle.mass, vehicle.SECTION.FIELD, or scenario.SETTING "
                   "(duration, altitude, amplitude, ...). Values in TOML syntax, e.g. "
                   "--set vehicle.cg_offset=[0.02,0,0].")
@click.option("--replay", "replay_log", type=click.Path(exists=True, path_type=Path),
              default=None, help="Instead of a scenario: drive the vehicle with the commands "
                                 "of this recorded log (or saved table) and write its twin.")
@click.option("--replay-mode", type=click.Choice(["loop", "motors"]), default="loop",
              show_default=True, help="loop: recorded loop commands through the simulator's "
              "own loops; motors: recorded m1..mN open loop over --horizon re-initialised "
              "runs.")
@click.option("--loop-input", type=click.Choice(["sticks", "rates", "torque"]),
              default="sticks", show_default=True,
              help="Replayed loop commands: u_roll/u_pitch/u_yaw as sticks or torque demands, "
                   "or sp_p/sp_q/sp_r rate setpoints.")
@click.option("--thrust", "thrust_mode", type=click.Choice(["command", "alt-hold"]),
              default="command", show_default=True,
              help="Replayed collective: recorded u_thrust, or the simulator's altitude hold "
                   "tracking the recorded alt.")
@click.option("--horizon", type=click.FloatRange(min=0, min_open=True), default=2.0,
              show_default=True, help="Re-initialisation period of --replay-mode motors, s.")
@click.option("--noise", "noise", type=click.Choice(["log", "vehicle", "none"]), default="log",
              show_default=True, help="Sensor noise of a --replay twin: the log's own "
                                      "(estimated per sensor), the vehicle file's, or none.")
@click.option("--list", "list_only", is_flag=True, help="List the scenarios and exit.")
def simulate(scenario: str | None, out: Path | None, fmt: str | None, vehicle: Path | None,
             duration: float | None, seed: int, ground_effect: str, rate_hz: float,
             assignments: tuple[str, ...], replay_log: Path | None, replay_mode: str,
             loop_input: str, thrust_mode: str, horizon: float, noise: str,
             list_only: bool) -> None:
    """Fly SCENARIO with the hexacopter physics model and write it as a real flight log.

    Every physical effect of docs/physics.md is a vehicle setting, off by default:
    e.g. --set vehicle.time_delay=0.02 --set vehicle.motor_lag=[0.04,0.08]
    --set scenario.altitude=1.0.
    """
    with stage("simulate: loading"):  # numpy, scipy, numba: not for --help
        from etsid.sim import SCENARIOS
        from etsid.sim import simulate as run_simulation

    if replay_log is not None:
        if scenario is not None:
            raise click.UsageError("give either SCENARIO or --replay LOG, not both.")
        ctx = click.get_current_context()
        for name, flag in (("duration", "--duration"), ("rate_hz", "--rate"),
                           ("list_only", "--list")):
            if ctx.get_parameter_source(name) == click.core.ParameterSource.COMMANDLINE:
                raise click.UsageError(f"{flag} does not apply to --replay (the log sets "
                                       "the duration and rate).")
        if out is None:
            raise click.UsageError("Missing option '-o' / '--out'.")
        _replay(replay_log, out, fmt, vehicle, seed, ground_effect == "on",
                parse_assignments(assignments), replay_mode, loop_input,
                thrust_mode.replace("-", "_"), horizon, noise)
        return
    if scenario is None and out is not None and not list_only:
        raise click.UsageError("Missing argument 'SCENARIO' (see etsid simulate --list).")
    if list_only or scenario is None:
        for name in _scenario_names():
            info = SCENARIOS[name]
            text = info.get("description", "") if isinstance(info, dict) else str(info)
            click.echo(f"{name:<16} {text}")
        return
    if scenario not in SCENARIOS:
        raise click.BadParameter(f"unknown scenario {scenario!r}; choose one of "
                                 f"{', '.join(_scenario_names())}", param_hint="SCENARIO")
    if out is None:
        raise click.UsageError("Missing option '-o' / '--out'.")
    settings = parse_assignments(assignments)
    _check_out(out, fmt)
    flight = run_simulation(scenario, vehicle=vehicle, duration=duration, seed=seed,
                            ground_effect=ground_effect == "on", rate_hz=rate_hz,
                            settings=settings)
    table = flight.table
    with stage(f"simulate: writing {out}"):
        written = _write(table, flight.truth, out, fmt)
    click.echo(f"{written}: {scenario}, {table.index[-1]:.1f} s at {rate_hz:g} Hz, "
               f"vehicle {table.attrs.get('vehicle', '?')}, seed {seed}, "
               f"ground effect {ground_effect}")
    _echo_settings(settings)


def _echo_settings(settings: dict) -> None:
    """One line of the --set values the run applied, as parsed (nothing without --set)."""
    if settings:
        click.echo("settings applied: " + ", ".join(f"{k} = {v!r}" if isinstance(v, str)
                                                    else f"{k} = {v}"
                                                    for k, v in settings.items()))


def _write(table: pd.DataFrame, truth: pd.DataFrame, out: Path, fmt: str | None) -> Path:
    from etsid.sim.writers import write_log

    if format_for(out, fmt) in ("parquet", "csv"):
        # a saved table also carries the noise-free states (true_* columns) for tests
        attrs = dict(table.attrs)
        table = table.join(truth)
        table.attrs = attrs
    try:
        return write_log(table, out, fmt)
    except OSError as err:
        raise SimError(f"{out}: cannot write ({err.strerror or err})") from err


def _replay(log: Path, out: Path, fmt: str | None, vehicle: Path | None, seed: int,
            ground_effect: bool, settings: dict, mode: str, loop_input: str, thrust: str,
            horizon: float, noise: str = "log") -> None:
    with stage("simulate: loading"):
        from etsid.ingest import read_log
        from etsid.sim.flight import refuse_non_finite
        from etsid.sim.replay import replay

    scenario_keys = [k for k in settings if not k.startswith("vehicle.")]
    if scenario_keys:
        raise SimError(f"--replay takes vehicle settings only, got {scenario_keys[0]!r}")
    _check_out(out, fmt)
    table = read_log(log)
    result = replay(table, vehicle, mode=mode, loop_input=loop_input, thrust=thrust,
                    horizon=horizon, ground_effect=ground_effect, seed=seed,
                    settings=settings, noise=noise)
    refuse_non_finite(result.table, f"{log}: replay twin with vehicle {result.vehicle.name!r}",
                      "check the log's initial states and commands, the vehicle and settings")
    written = _write(result.table, result.truth, out, fmt)
    t = result.table.index
    click.echo(f"{written}: twin of {log} ({mode} replay, {t[-1] - t[0]:.1f} s), vehicle "
               f"{result.vehicle.name}")
    _echo_settings(settings)
    for part, where in result.sources.items():
        click.echo(f"  {part}: {where}")
    errs = ", ".join(f"{k} {v['rmse']:.3g} ({100 * v['ratio']:.0f} % of std)"
                     for k, v in result.errors.items() if k in ("p", "q", "r", "alt"))
    click.echo(f"  twin - log RMSE: {errs}")
    div = result.divergence
    if div is None:
        click.echo("  the twin follows the recording (altitude within "
                   "5 m and roll/pitch within 30° throughout)")
    else:
        crash = (f"; it is on the ground at {div['ground_t']:.1f} s while the recording flies"
                 if div.get("ground_t", div["t"]) != div["t"] else "")
        click.echo(f"  warning: the twin diverges from the recording at {div['t']:.1f} s "
                   f"({div['what']}){crash}")


COMMANDS = [simulate]
