"""Applying a saved rule base: :func:`load_rules` reads rules.json, :func:`predict` runs it
over another table (one-step and free-run, optionally learning on)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError, ModelError
from etsid.escape import clean
from etsid.ets import ETS
from etsid.ets.serialize import check_caps, read_document
from etsid.ident.checks import motion_warnings
from etsid.ident.evaluate import (
    noise_std,
    output_metrics,
    prediction_columns,
    predictions_frame,
    rate_info,
    validation_info,
)
from etsid.ident.fallback import read_fallback
from etsid.ident.flight import EXCITE_STD, apply_selection, select_flight
from etsid.ident.learn import empty_history, history_frames, learn_online
from etsid.ident.motors import MOTOR_COMMANDS, add_motor_commands
from etsid.ident.regimes import regime_summary_of, rotor_radius
from etsid.ident.regressors import RegressorSpec, build
from etsid.ident.resample import decimate
from etsid.ident.rundir import Run, jsonable, rules_json, run_header, sha256


def load_rules(path: str | Path) -> tuple[ETS, RegressorSpec, dict[str, Any]]:
    """A rule base and its regressor spec from rules.json (or a RUN_DIR holding one).

    Raises
    ------
    IdentError
        Missing file, invalid rule base, or no regressor spec in it.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "rules.json"
    if not path.exists():
        raise IdentError(f"{path}: no such rule-base file")
    try:
        data = read_document(path)
        check_caps(data, str(path))
    except ModelError as err:
        raise IdentError(str(err)) from err
    data = clean(data)  # names from the file made printable where they enter
    if not isinstance(data, dict) or not isinstance(data.get("regressors"), dict):
        raise IdentError(f"{path}: the rule base has no 'regressors' spec; "
                         "it was not written by etsid identify")
    radius = data["regressors"].get("rotor_radius_m")
    if radius is not None and rotor_radius({"rotor_radius_m": radius}) is None:
        raise IdentError(f"{path}: regressors/rotor_radius_m must be a rotor radius in m "
                         f"(a positive number), got {radius!r}")
    rate = data["regressors"].get("sample_rate_hz")
    if rate is not None and (isinstance(rate, bool) or not isinstance(rate, (int, float))
                             or not 0 < rate <= MAX_SAMPLE_RATE_HZ):
        raise IdentError(f"{path}: regressors/sample_rate_hz must be a rate in Hz, "
                         f"0 < rate ≤ {MAX_SAMPLE_RATE_HZ:g}, got {rate!r}")
    try:
        spec = RegressorSpec.from_dict(data["regressors"])
    except IdentError as err:
        raise IdentError(f"{path}: {err}") from err
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise IdentError(f"{path}: the 'regressors' spec is not valid ({err})") from err
    try:
        model = ETS.from_dict(data)
    except ModelError as err:
        raise IdentError(f"{path}: {err}" if str(path) not in str(err) else str(err)) from err
    read_fallback(data, spec, str(path))  # the schema checked its shape; this, its sizes
    return model, spec, data


MAX_SAMPLE_RATE_HZ = 10_000.0
"""Highest identification rate a rule base may state (Hz); no flight log samples faster."""


def predict(table: pd.DataFrame, rules: str | Path, learn: bool = False,
            sim_from: float | None = None, source: str | Path | None = None,
            show_progress: bool = False, segments: str = "auto",
            fallback: bool = True) -> Run:
    """Apply a saved rule base to ``table``: one-step and free-run, optionally learning on.

    Parameters
    ----------
    table
        The flight to predict (must have the rule base's columns).
    rules
        rules.json written by :func:`etsid.ident.identify` (or a RUN_DIR).
    learn
        Continue learning while predicting (``y_hat`` is then predict-then-learn, as in
        identify's online pass); without it the rules stay frozen.
    sim_from
        Time (s) from which the free-run simulation starts (default: the first usable row).
        The rows before it are the ARX baseline's learning part. Use identify's
        ``validation.t_start`` to reproduce its validation predictions exactly.
    source, show_progress
        As for :func:`etsid.ident.identify`.
    segments
        ``auto`` (airborne rows, the same rule as identify), ``all`` or ``T0:T1[,…]`` (s):
        the rows predicted and scored (:func:`etsid.ident.flight.select_flight`).
    fallback
        Apply the rule base's per-output fall-back (:mod:`etsid.ident.fallback`: ARX or
        no-change where identify found eTS behind on its validation; fixed, also with
        ``learn``). False: eTS on every output, as the rules alone predict.
    """
    path = Path(rules)
    model, spec, data = load_rules(path)
    applied = read_fallback(data, spec, str(path)) if fallback else None
    sigma_native = noise_std(table, spec.outputs)
    rate_hz = (data.get("regressors") or {}).get("sample_rate_hz")
    table = add_motor_commands(table)
    need = [c for c in MOTOR_COMMANDS if c in spec.columns and c not in table.columns]
    if need:
        raise IdentError(f"{path}: the model's inputs are the motor commands "
                         f"({', '.join(need)}), computed from m1…mN and the table's motor "
                         "layout; this table has no layout matching its motor columns "
                         "(attrs['motor_layout'])")
    selection = select_flight(table, segments)
    table = apply_selection(table, selection)
    table = decimate(table, float(rate_hz) if rate_hz else None)
    reg = build(table, spec)
    n = len(reg.X)
    split = 0 if sim_from is None else int(np.searchsorted(reg.t, sim_from, side="left"))
    frozen = ETS.from_dict(data, trusted=True)  # validated by load_rules
    if learn:
        yhat, _ = learn_online(model, reg, -1, show_progress, "predict: samples")
    else:
        yhat = np.asarray(frozen.predict(reg.X, reg.S)).reshape(n, -1)
    if applied is not None:  # the fall-back stays as identify fitted it, also with learn
        yhat = applied.apply(reg.X, yhat)
    cols, diverged = prediction_columns(reg, spec, split, len(table), yhat, frozen, table,
                                        applied)
    cols["y_val"][:split] = np.nan
    if not learn:
        cols["y_val"][split:] = yhat[split:]
    history, consequents = history_frames(model, reg) if learn else empty_history()
    sigma = noise_std(table, spec.outputs)
    peak = int(history["n_rules"].max()) if len(history) else frozen.n_rules
    metrics = {
        "n_samples": n,
        "rules": {"final": model.n_rules, "peak": max(peak, frozen.n_rules),
                  "frozen": frozen.n_rules},
        "skipped": reg.skipped,
        "validation": validation_info(reg, split, (n - split) / n),
        "outputs": output_metrics(reg, spec, split, cols, sigma, sigma_native, diverged,
                                  EXCITE_STD),
        "sample_rate": rate_info(table),
        "flight": selection.to_dict(),
    }
    used = (applied.used(spec.outputs) if applied is not None
            else dict.fromkeys(spec.outputs, "eTS"))
    for y in spec.outputs:
        metrics["outputs"][y]["used"] = used[y]
    notes = (applied.lines() if applied is not None else []) + motion_warnings(
        metrics["outputs"], EXCITE_STD)
    if not fallback and data.get("fallback"):
        notes.insert(0, "eTS on every output (--no-fallback): the rule base's fall-back on "
                        f"{', '.join(data['fallback'])} is not applied")
    radius = None  # the table's own rotor radius (--vehicle, the simulator) comes first
    if rotor_radius(table.attrs) is None and (radius := data["regressors"].get(
            "rotor_radius_m")) is not None:
        notes.insert(0, f"rotor radius {radius:g} m from the rule base (the vehicle it was "
                        "identified on) for the regime bands in z/R; --vehicle for another")
    metrics["regimes"] = regime_summary_of(data, table, reg, list(spec.outputs), cols, split,
                                           learnt_here=False, rotor_radius_m=radius)
    run_config = {
        **run_header("predict", table, source),
        "rules": {"path": str(path), "sha256": sha256(path if path.is_file()
                                                      else path / "rules.json")},
        "model": {**spec.to_dict(), "inputs": {"columns": [
            c for c in spec.columns if c not in spec.outputs]},
                  "notes": notes},
        "parameters": {"learn": learn, "sim_from": sim_from, "segments": segments,
                       "fallback": fallback},
        "ets": {**{k: data["params"].get(k) for k in ("radius", "omega", "variant")},
                "fixed_ranges": data["params"].get("x_range") is not None}
        if isinstance(data.get("params"), dict) else {},
        "skipped": reg.skipped,
        "warnings": list(table.attrs.get("warnings") or []),
    }
    learnt = rules_json(model.to_dict(), spec, data["regressors"].get("decimation"),
                        radius or rotor_radius(table.attrs), data.get("fallback")
                        ) if learn else None
    return Run(predictions_frame(reg, spec, table, split, cols), jsonable(metrics), run_config,
               history, consequents, data, learnt)
