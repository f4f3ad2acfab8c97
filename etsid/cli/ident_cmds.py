"""``etsid identify``, ``etsid predict`` and ``etsid rules``."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import click

from etsid.cli.options import (
    RateHz,
    check_output_dir,
    echo_table_notes,
    log_options,
    read_options,
)
from etsid.errors import IdentError, ModelError
from etsid.ets.params import CLUSTERINGS, RLS_KINDS, VARIANTS
from etsid.ident.choices import (
    ATTITUDE_MODES,
    DEFAULT_RATE_HZ,
    MODES,
    NORMALISE_MODES,
    STICK_RATE_MIN,
    STICK_STD_MIN,
)
from etsid.ident.config import IDENT_ETS, IDENT_SCHEDULED_ETS, IdentConfig
from etsid.progress import stage, wanted

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ident.rundir import Run

# The option choices above come from light modules (no numpy, pandas or numba): the
# science stack is imported inside the commands (said as "loading", as the group says the
# import of a command module), so that `etsid identify --help` is at once.


def _outputs(text: str | None) -> list[str] | None:
    if not text:
        return None
    return [s.strip() for s in text.split(",") if s.strip()]


def _naming(err: IdentError, *paths: Path) -> IdentError:
    """``err`` with the input file named in front unless its message names one already."""
    text = str(err)
    if any(str(p) in text for p in paths):
        return err
    return IdentError(f"{paths[0]}: {text}")


def _print_run(run: Run, out: Path, as_json: bool) -> None:
    from etsid.ident.rundir import jsonable
    from etsid.report.regimes import regime_text
    from etsid.report.tables import merges_text, summary_table

    if as_json:
        click.echo(json.dumps(jsonable(run.metrics), indent=2))
        return
    for note in run.config.get("model", {}).get("notes") or []:
        click.echo(note)
    click.echo(summary_table(run))
    merged = merges_text(run.metrics.get("rules") or {}, run.rules,
                         (run.metrics.get("validation") or {}).get("n_learn"))
    if merged:
        click.echo(merged)
    compared = _structure_text(run.metrics.get("structure"))
    if compared:
        click.echo(compared)
    regimes = regime_text(run)
    if regimes:
        click.echo(regimes)
    click.echo(f"wrote {out}/ (predictions.parquet, metrics.json, rules.json, …); "
               f"next: etsid report {out}")


def _structure_text(block: dict | None) -> str:
    """One line per output: validation one-step RMSE of every candidate structure, ARX and
    no-change persistence (metrics.json ``structure.validation``)."""
    table = (block or {}).get("validation") or {}
    if not table:
        return ""
    models = list(table)
    outputs = list(next(iter(table.values())))
    lines = ["val 1-step RMSE by structure (chosen: " + str(block.get("chosen")) + "): "
             + ", ".join(models)]
    for y in outputs:
        values = [table[m][y].get("one_step_rmse") for m in models]
        lines.append(f"  {y}: " + " / ".join("–" if v is None else f"{v:.4g}" for v in values))
    return "\n".join(lines)


def _rotor_radius(vehicle: str) -> float:
    """Rotor radius, m, of a packaged vehicle name or a vehicle TOML file."""
    from etsid.sim import load_vehicle

    return float(load_vehicle(vehicle).params["rotor"]["radius"])


def _table_rate(table: object) -> float | None:
    """Grid rate of a table, Hz (None when it cannot be told)."""
    import numpy as np

    rate = getattr(table, "attrs", {}).get("rate_hz")
    if rate:
        return float(rate)
    t = np.asarray(getattr(table, "index", []), dtype=float)
    if t.size > 1 and t[-1] > t[0]:
        return float((t.size - 1) / (t[-1] - t[0]))
    return None


@click.command("identify")
@click.argument("log", type=click.Path(path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="RUN_DIR to write (created if needed).")
@click.option("--output", "outputs", metavar="COLS",
              help="Columns to predict, comma-separated (default: p,q,r with the default "
                   "rate model). Needs --regressors.")
@click.option("--regressors", metavar="SPEC",
              help='NARX regressors, e.g. "co2[k-1],input_gas_rate[k-4]" or '
                   '"p[k-1..k-3],u_roll[k-1..k-2]".')
@click.option("--antecedent", metavar="SPEC|auto|none", default="auto", show_default=True,
              help='Scheduling terms the rules fire on (consequents stay on all '
                   'regressors), e.g. "inv_alt[k-1]" (1/altitude, the ground-effect '
                   'coordinate) or "alt[k-1],u_thrust[k-1]"; auto = inv_alt[k-1] for the '
                   'default rate model when the log has altitude, else none; none = the '
                   'rules fire on the regressors.')
@click.option("--unscheduled", metavar="none|COLS", default=IdentConfig.unscheduled,
              show_default=True,
              help="Outputs of a scheduled model whose consequent is one linear model "
                   "shared by every rule (the antecedent does not act on them), e.g. r: for "
                   "an output whose physics does not change with the scheduling variable.")
@click.option("--structure", type=click.Choice(["auto", "scheduled", "unscheduled", "arx"]),
              default=IdentConfig.structure, show_default=True,
              help="Default rate model: auto = chosen on an inner split of the learning part "
                   "between scheduled eTS (rules on --antecedent), unscheduled eTS (rules on "
                   "the regressors) and one rule (ARX): the simplest within 0.5 points of "
                   "the best mean free-run fit. An explicit --antecedent is kept as given.")
@click.option("--attitude-states", "attitude", type=click.Choice(list(ATTITUDE_MODES)),
              default=IdentConfig.attitude, show_default=True,
              help="Default rate model: roll[k-1],pitch[k-1] as states (integrated from the "
                   "simulated rates in free run) when the attitude loop closes around the "
                   "inputs (sticks, attitude setpoints) and the log has the angles. auto = "
                   "kept if ARX free-run on an inner split of the learning part is better "
                   "with them; on = always; none = never.")
@click.option("--output-lags", type=click.IntRange(1, 50), default=IdentConfig.output_lags,
              show_default=True, help="Default rate model: lags of each rate, samples.")
@click.option("--input-lags", type=click.IntRange(1, 50), default=IdentConfig.input_lags,
              show_default=True, help="Default rate model: lags of each command, samples.")
@click.option("--radius", type=click.FloatRange(0, min_open=True), default=None,
              help=f"eTS zone of influence, fraction of the data range (default "
                   f"{IDENT_ETS.radius:g}, {IDENT_SCHEDULED_ETS.radius:g} when the rules "
                   "fire on --antecedent terms).")
@click.option("--clustering", type=click.Choice(list(CLUSTERINGS)), default=None,
              help=f"How rules are born and placed: potential (eTS/eTS+) or evq (evolving "
                   f"vector quantisation; default {IDENT_ETS.clustering}, "
                   f"{IDENT_SCHEDULED_ETS.clustering} when scheduled).")
@click.option("--omega", type=click.FloatRange(0, min_open=True), default=IdentConfig.omega,
              show_default=True, help="Initial RLS covariance of a new rule.")
@click.option("--variant", type=click.Choice(list(VARIANTS)), default=IdentConfig.variant,
              show_default=True, help="eTS (2004) or eTS+ (2010, with pruning).")
@click.option("--max-rules", type=click.IntRange(1, 1000), default=IdentConfig.max_rules,
              show_default=True, help="Cap on the number of rules.")
@click.option("--rls", type=click.Choice(list(RLS_KINDS)), default=IdentConfig.rls,
              show_default=True, help="Consequent learning: local or global RLS.")
@click.option("--forgetting", type=click.FloatRange(0, 1, min_open=True),
              default=IdentConfig.forgetting, show_default=True,
              help="RLS forgetting factor (1: none).")
@click.option("--normalise", type=click.Choice(list(NORMALISE_MODES)),
              default=IdentConfig.normalise, show_default=True,
              help="eTS normalisation ranges: learn = fixed, min/max of the learning part "
                   "(+5 %; set before the online pass), running = running min/max "
                   "(strictly causal, noisy start), apriori = fixed, loop commands ±1 "
                   "(thrust 0..1), the rest as learn.")
@click.option("--validate", type=click.FloatRange(0, 0.9), default=IdentConfig.validate,
              show_default=True,
              help="Fraction held out at the end: learn on the rest, freeze, then one-step "
                   "and free-run on it (0: no validation).")
@click.option("--rate", "rate_hz", type=RateHz(), default=None,
              help="Grid rate of a log when it is read, Hz (default: native rate of the "
                   "body rates). Identification then runs at --ident-rate.")
@click.option("--ident-rate", "ident_rate", type=RateHz(allow_zero=True), default=None,
              metavar="HZ",
              help="Identification rate, Hz: the table is averaged over blocks of k samples "
                   "(integer k, rate nearest HZ; noise σ becomes σ/√k). Default: "
                   f"{DEFAULT_RATE_HZ:g} Hz for the rate model, the table's rate with "
                   "--output; 0 keeps the table's rate.")
@click.option("--inputs", "inputs", type=click.Choice(list(MODES)), default="auto",
              show_default=True,
              help="Rate-model inputs: pilot sticks, controller torque commands, rate "
                   "or attitude setpoints, motor outputs; auto = sticks if they carry "
                   f"excitation (std ≥ {STICK_STD_MIN:g} and ≥ {STICK_RATE_MIN:g} Hz on each "
                   "axis), else the first of torque, rate setpoints, attitude setpoints at "
                   "≥ 20 Hz, else the fastest, else sticks anyway, else motor outputs.")
@click.option("--segments", default="auto", show_default=True, metavar="auto|all|T0:T1,…",
              help="Rows to identify on: auto = airborne samples (land detector, else the "
                   "thrust/altitude rule), all = every row, or time windows in s.")
@click.option("--vehicle", metavar="NAME|FILE",
              help="The vehicle flown (packaged name such as tarot680, or a vehicle TOML): "
                   "its rotor radius R puts the regimes in z/R (in / out of ground effect); "
                   "without it a simulated table's own vehicle, else altitude bands in m.")
@click.option("--json", "as_json", is_flag=True, help="Print metrics.json instead of a table.")
@log_options
def identify_cmd(log: Path, out: Path, outputs: str | None, regressors: str | None,
                 antecedent: str | None, unscheduled: str, structure: str, attitude: str,
                 output_lags: int,
                 input_lags: int,
                 radius: float | None, clustering: str | None, omega: float, variant: str,
                 max_rules: int, rls: str, forgetting: float, normalise: str,
                 validate: float,
                 rate_hz: float | None, ident_rate: float | None, inputs: str, segments: str,
                 vehicle: str | None, as_json: bool, maps: tuple[str, ...],
                 mapping_file: Path | None, sysid: int | None, quiet: bool) -> None:
    """Learn an eTS model of LOG (a flight log or a saved .parquet/.csv table).

    Default: the MIMO rate model (outputs p q r, inputs u_roll u_pitch u_yaw [u_thrust]
    from sticks or torque commands, else rate or attitude setpoints, else motor outputs;
    see --inputs) at 50 Hz (--ident-rate), learned and validated on the airborne rows
    (--segments). Writes RUN_DIR/ predictions.parquet,
    history.parquet, rules.json, metrics.json, config.json.
    """
    with stage("identify: loading"):  # numba, pandas: seconds on a cold start
        from etsid.ident import identify, write_run
        from etsid.ident.inputs import load_for_ident
        from etsid.ingest import read_log

    check_output_dir(out)
    options = read_options(maps, mapping_file, sysid, quiet)
    with stage(f"identify: reading {log}"):
        if outputs:
            table = read_log(log, options, rate_hz=rate_hz)
        else:
            table = load_for_ident(log, options, inputs=inputs, rate_hz=rate_hz)
    if vehicle:
        table.attrs["rotor_radius_m"] = _rotor_radius(vehicle)
    table_rate = _table_rate(table)
    if ident_rate and table_rate and ident_rate > 1.01 * table_rate:
        raise click.BadParameter(f"{ident_rate:g} Hz is above the rate of {log} "
                                 f"({table_rate:.4g} Hz); it can only lower the rate",
                                 param_hint="--ident-rate")
    config = IdentConfig(outputs=_outputs(outputs), regressors=regressors,
                         output_lags=output_lags, input_lags=input_lags, radius=radius,
                         omega=omega, variant=variant, max_rules=max_rules, rls=rls,
                         forgetting=forgetting, validate=validate, ident_rate=ident_rate,
                         inputs=inputs, normalise=normalise, segments=segments,
                         antecedent=antecedent, clustering=clustering, attitude=attitude,
                         unscheduled=unscheduled, structure=structure)
    try:
        run = identify(table, config, source=log, show_progress=wanted(quiet))
    except IdentError as err:
        raise _naming(err, log) from err
    echo_table_notes(table)  # after the run, so that an error stays one line
    write_run(run, out)
    _print_run(run, out, as_json)


@click.command("predict")
@click.argument("log", type=click.Path(path_type=Path))
@click.option("--rules", "rules_path", required=True, type=click.Path(path_type=Path),
              help="rules.json (or a RUN_DIR) written by etsid identify.")
@click.option("-o", "--out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="RUN_DIR to write (created if needed).")
@click.option("--learn", is_flag=True, help="Continue learning while predicting.")
@click.option("--sim-from", type=float, default=None, metavar="SECONDS",
              help="Start the free-run simulation at this time, s (default: the start). "
                   "Identify's validation start reproduces its validation predictions.")
@click.option("--rate", "rate_hz", type=RateHz(), default=None,
              help="Grid rate of a log, Hz (the rules are applied at their own "
                   "identification rate, stored in rules.json).")
@click.option("--segments", default="auto", show_default=True, metavar="auto|all|T0:T1,…",
              help="Rows to predict and score: auto = airborne samples (the same rule as "
                   "identify), all = every row, or time windows in s.")
@click.option("--vehicle", metavar="NAME|FILE",
              help="The vehicle flown: its rotor radius puts the scores per regime in z/R "
                   "(as for identify).")
@click.option("--no-fallback", is_flag=True,
              help="eTS on every output: do not apply the ARX / no-change fall-back that "
                   "identify saved for an axis where eTS was behind on its validation.")
@click.option("--json", "as_json", is_flag=True, help="Print metrics.json instead of a table.")
@log_options
def predict_cmd(log: Path, rules_path: Path, out: Path, learn: bool, sim_from: float | None,
                rate_hz: float | None, segments: str, vehicle: str | None, no_fallback: bool,
                as_json: bool, maps: tuple[str, ...], mapping_file: Path | None, sysid: int | None,
                quiet: bool) -> None:
    """Apply a saved rule base to LOG: one-step and free-run predictions and metrics."""
    with stage("predict: loading"):  # numba, pandas: seconds on a cold start
        from etsid.ident import predict, write_run
        from etsid.ingest import read_log

    if sim_from is not None and not math.isfinite(sim_from):
        raise click.BadParameter(f"must be a finite time, got {sim_from}", param_hint="--sim-from")
    check_output_dir(out)
    table = read_log(log, read_options(maps, mapping_file, sysid, quiet), rate_hz=rate_hz)
    if vehicle:
        table.attrs["rotor_radius_m"] = _rotor_radius(vehicle)
    t = table.index.to_numpy(dtype=float)
    if sim_from is not None and len(t) and not t[0] <= sim_from < t[-1]:
        raise click.BadParameter(f"{sim_from:g} s is outside {log} (0 … {t[-1]:.2f} s)",
                                 param_hint="--sim-from")
    try:
        run = predict(table, rules_path, learn=learn, sim_from=sim_from, source=log,
                      show_progress=wanted(quiet), segments=segments,
                      fallback=not no_fallback)
    except IdentError as err:
        raise _naming(err, log, rules_path) from err
    echo_table_notes(table)
    write_run(run, out)
    _print_run(run, out, as_json)


@click.command("rules")
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--full", is_flag=True, help="Every term of every consequent, as stored.")
@click.option("--json", "as_json", is_flag=True, help="Print the raw rules.json.")
def rules_cmd(path: Path, full: bool, as_json: bool) -> None:
    """Print the rule base in PATH (rules.json or a RUN_DIR) as readable IF … THEN … rules.

    By default each rule's focal point in physical units and, per output, the terms that
    dominate its consequent with their share; --full prints every term.
    """
    with stage("rules: loading"):  # numba, pandas: seconds on a cold start
        from etsid.ident import load_rules
        from etsid.ident.fallback import read_fallback
        from etsid.report.tables import rules_text

    data = _control_rules(path)  # a control run's rule base has no regressor spec
    spec = None
    if data is None:
        _, spec, data = load_rules(path)
    if as_json:
        click.echo(json.dumps(data, indent=1))
        return
    if full:
        click.echo(rules_text(data))
    else:
        from etsid.report.rulebook import readable

        click.echo(readable(data, trusted=True))  # checked when loaded
    fallback = read_fallback(data, spec, str(path)) if spec is not None else None
    for line in fallback.lines() if fallback is not None else []:
        click.echo(f"fall-back {line}; etsid predict applies it, not the rules")


def _control_rules(path: Path) -> dict | None:
    """The rules.json of an ``etsid control`` run (checked by the model loader), else None."""
    from etsid.files import read_json

    file = path / "rules.json" if path.is_dir() else path
    config = file.parent / "config.json"
    try:
        kind = read_json(config, "run", ModelError)
        if not isinstance(kind, dict) or kind.get("kind") != "control":
            return None
        data = read_json(file, "rules", ModelError)
    except ModelError:
        return None
    from etsid.escape import clean
    from etsid.ets import ETS

    data = clean(data)  # names from the file made printable where they enter
    ETS.from_dict(data)  # ModelError names what is wrong
    return data


COMMANDS = [identify_cmd, predict_cmd, rules_cmd]
