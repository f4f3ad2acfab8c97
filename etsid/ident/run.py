"""Identification runs: online eTS over a log, frozen validation, ARX beside it.

:func:`identify` learns online (predict, then learn) over every usable row. The model as it
stood after the first ``1 − validate`` of the rows is the *frozen* model: it is saved as
rules.json and evaluated on the rest (one-step and free-run). Because the online pass is
one pass in time order, the frozen model is exactly a model trained on the first part only.
Applying a saved rule base to another table is :func:`etsid.ident.prediction.predict`.

The jobs around the run live beside it: :mod:`~etsid.ident.config` (parameters),
:mod:`~etsid.ident.model_choice` (which model), :mod:`~etsid.ident.checks` (split and
warnings), :mod:`~etsid.ident.ranges` (normalisation), :mod:`~etsid.ident.learn` (the
online pass and its history), :mod:`~etsid.ident.evaluate` (predictions and metrics) and
:mod:`~etsid.ident.rundir` (the RUN_DIR files).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.blas import one_blas_thread
from etsid.errors import IdentError
from etsid.ets import ETS
from etsid.ident.attitude_check import check_attitude_states
from etsid.ident.blocks import (
    blocked_line,
    blocked_validation,
    not_validated_line,
    still_tail_lines,
    tail_informs,
)
from etsid.ident.checks import (
    data_warnings,
    excitation_warnings,
    motion_warnings,
    refuse_coarse,
    split_excited,
)
from etsid.ident.config import IdentConfig
from etsid.ident.evaluate import (
    applied_validation,
    noise_std,
    output_metrics,
    prediction_columns,
    predictions_frame,
    rate_info,
    validation_info,
)
from etsid.ident.fallback import REASONS, applied_line, fallback_block, read_fallback
from etsid.ident.flight import (
    EXCITE_STD,
    FlightSelection,
    apply_selection,
    excited_mask,
    select_flight,
)
from etsid.ident.learn import history_frames, learn_online
from etsid.ident.model_choice import choose_model
from etsid.ident.motors import add_motor_commands
from etsid.ident.ranges import fixed_ranges, schedule_range
from etsid.ident.regimes import regime_summary_of, rotor_radius
from etsid.ident.regressors import Regression, RegressorSpec, build
from etsid.ident.resample import decimate
from etsid.ident.rundir import Run, jsonable, rules_json, run_header
from etsid.ident.structure import (
    ORDER,
    StructureChoice,
    behind_lines,
    candidate,
    choose_structure,
    fallbacks,
    validation_table,
)
from etsid.progress import done, say


def _rate_note(work: pd.DataFrame) -> str:
    d = work.attrs.get("decimation") or {}
    if d.get("factor", 1) > 1:
        return (f"identification rate {d['rate_hz']:.4g} Hz: {d['native_rate_hz']:.4g} Hz "
                f"table, block mean of {d['factor']} samples (noise σ / √{d['factor']})")
    return f"identification rate {d.get('rate_hz', 0):.4g} Hz (the table's rate)"


def _flight_note(selection: FlightSelection, excited: np.ndarray, dt: float) -> str:
    windows = ", ".join(f"{a:.1f}–{b:.1f}" for a, b in selection.windows[:6])
    more = f" (+{len(selection.windows) - 6} more)" if len(selection.windows) > 6 else ""
    return (f"flight ({selection.method}): {selection.airborne_s:.1f} s of "
            f"{selection.total_s:.1f} s kept in {len(selection.windows)} segment(s) "
            f"[{windows}{more} s]; {np.count_nonzero(excited) * dt:.1f} s with excitation")


def _new_model(config: IdentConfig, spec: RegressorSpec, x_range: np.ndarray | None = None,
               y_range: np.ndarray | None = None, s_range: np.ndarray | None = None) -> ETS:
    try:
        shared = config.shared_outputs(spec.outputs, bool(spec.antecedent))
        params = config.ets_params(bool(spec.antecedent), len(spec.antecedent_names or []))
        return ETS(**params, input_names=spec.input_names,
                   output_names=list(spec.outputs), x_range=x_range, y_range=y_range,
                   s_range=s_range, antecedent_names=spec.antecedent_names,
                   shared_outputs=shared)
    except (ValueError, TypeError) as err:
        raise IdentError(f"bad eTS parameter: {err}") from err


def _structure(reg: Regression, spec: RegressorSpec, config: IdentConfig,
               excited: np.ndarray, table: pd.DataFrame) -> StructureChoice:
    """The structure to learn: chosen on the inner split (``--structure auto``) or forced."""
    mode = (config.structure or "auto").strip().lower()
    if mode not in ("auto", *ORDER):
        raise IdentError(f"--structure {config.structure!r}: use auto, "
                         f"{', '.join(ORDER[::-1])}")
    if mode == "auto" and (config.antecedent or "auto").strip().lower() != "auto":
        mode = "scheduled" if spec.antecedent else "unscheduled"  # the user's own choice
    if mode == "auto":
        try:
            return choose_structure(reg, spec, config, excited,
                                    split_excited(excited, config.validate), len(table))
        except (ValueError, TypeError) as err:
            raise IdentError(f"bad eTS parameter: {err}") from err
    if mode == "scheduled" and not spec.antecedent:
        raise IdentError("--structure scheduled needs an antecedent (altitude in the log, "
                         "or --antecedent TERMS)")
    c_spec, c_config = candidate(mode, spec, config)
    return StructureChoice(mode, c_spec, c_config, f"structure: {mode} (--structure)")


def identify(table: pd.DataFrame, config: IdentConfig | None = None,
             source: str | Path | None = None, show_progress: bool = False) -> Run:
    """Identify an eTS model of ``table`` (see the module docstring for the protocol).

    Parameters
    ----------
    table
        A FlightTable or any table indexed by ``t`` (s) with the needed columns.
    config
        Model and run parameters (defaults: the rate model of :mod:`etsid.ident.defaults`).
    source
        Path of the file the table came from (hashed into config.json).
    show_progress
        Draw a progress bar on stderr.

    Raises
    ------
    IdentError
        Missing columns, bad regressor spec, too few usable rows, or bad eTS parameters.
    """
    with one_blas_thread():
        return _identify(table, config, source, show_progress)


def _identify(table: pd.DataFrame, config: IdentConfig | None, source: str | Path | None,
              show_progress: bool) -> Run:
    """:func:`identify` with BLAS on one thread (:mod:`etsid.blas`)."""
    config = config or IdentConfig()
    rate_hz = config.rate_for(not config.outputs)
    table = add_motor_commands(table)
    say("identify: choosing the inputs and the model")
    chosen = choose_model(table, config)
    spec = chosen.spec
    sigma_native = noise_std(table, spec.outputs)
    rate_model = not config.outputs
    selection = select_flight(table, config.segments)
    table = apply_selection(table, selection)
    table = decimate(table, rate_hz)
    chosen.notes.append(_rate_note(table))
    if rate_model:
        refuse_coarse(float(table.attrs["decimation"]["rate_hz"]),
                      str((table.attrs.get("mapping") or {}).get("p", "p")))
    reg = build(table, spec)
    masks: dict[tuple[str, ...], np.ndarray] = {}  # excited_mask of this table per outputs

    def excited_of(outputs: tuple[str, ...]) -> np.ndarray:
        if outputs not in masks:
            masks[outputs] = excited_mask(table, outputs)
        return masks[outputs]

    excited = (excited_of(spec.outputs)[reg.rows] if rate_model
               else np.ones(len(reg.X), dtype=bool))
    attitude = None
    if chosen.attitude and config.attitude == "auto":
        say("identify: checking the attitude states on an inner split of the learning part")
        attitude = check_attitude_states(reg, spec, split_excited(excited, config.validate),
                                         excited, len(table), config.validate)
        chosen.notes = [attitude.note if note.startswith("attitude states") else note
                        for note in chosen.notes]
        if not attitude.keep:
            spec = attitude.spec
            reg = build(table, spec)
            excited = excited_of(spec.outputs)[reg.rows]
    choice = None
    requested_spec, requested_config, requested_reg = spec, config, reg
    if rate_model:
        say("identify: choosing the structure on an inner split of the learning part")
        choice = _structure(reg, spec, config, excited, table)
        if choice.spec != spec:
            spec, config = choice.spec, choice.config
            reg = build(table, spec)
            excited = excited_of(spec.outputs)[reg.rows]
            chosen.notes = [n for n in chosen.notes if not n.startswith("rules fire on")]
        elif choice.chosen == "scheduled":
            config = choice.config  # it may leave outputs unscheduled (structure.py)
        chosen.notes.append(choice.note)
    n = len(reg.X)
    dt = 1.0 / float(table.attrs["decimation"]["rate_hz"])
    chosen.notes.append(_flight_note(selection, excited, dt))
    chosen.notes.extend(data_warnings(table, n, reg.X.shape[1], rate_model=rate_model))
    split = split_excited(excited, config.validate)
    if rate_model:
        chosen.notes.extend(excitation_warnings(excited, split, reg.X.shape[1], dt))
    x_range, y_range = fixed_ranges(reg, spec, split, config.normalise)
    model = _new_model(config, spec, x_range, y_range,
                       schedule_range(reg, spec, split, config.normalise))
    try:
        merges: list[dict[str, Any]] = []
        yhat, frozen_dict = learn_online(model, reg, split if split < n else -1,
                                         show_progress, "identify: learning online (samples)",
                                         rate_model if config.merge is None
                                         else config.merge, merges)
    except ValueError as err:
        raise IdentError(f"bad eTS parameter: {err}") from err
    if split == n:
        frozen_dict = model.to_dict()
    say("identify: free run of the held-out part, metrics")
    frozen = ETS.from_dict(frozen_dict, trusted=True) if frozen_dict is not None else None
    cols, diverged = prediction_columns(reg, spec, split, len(table), yhat, frozen, table)
    history, consequents = history_frames(model, reg)
    sigma = noise_std(table, spec.outputs)
    frozen_rules = frozen.n_rules if frozen is not None else 0
    rate = rate_info(table)
    metrics = {
        "n_samples": n,
        "rules": {"final": model.n_rules, "peak": int(history["n_rules"].max()),
                  "frozen": frozen_rules, "merges": merges},
        "skipped": reg.skipped,
        "validation": {**validation_info(reg, split, config.validate),
                       "excited_s": float(np.count_nonzero(excited[split:]) * dt)},
        "flight": {**selection.to_dict(), "excited_s": float(np.count_nonzero(excited) * dt),
                   "excitation_std_min": EXCITE_STD if rate_model else None},
        "outputs": output_metrics(reg, spec, split, cols, sigma, sigma_native, diverged,
                                  EXCITE_STD),
        "sample_rate": rate_info(table),
    }
    blocked, still_used, fallback = None, {}, None
    if rate_model and frozen is not None and split < n:
        tail = tail_informs(reg, spec, split, EXCITE_STD)
        blocked = blocked_validation(reg, spec, config, excited, config.validate, len(table),
                                     cols["y_persist"], EXCITE_STD)
        metrics["validation"]["tail_motion"] = tail
        metrics["validation_blocks"] = blocked
        lines, still_used = still_tail_lines(metrics["outputs"], tail, blocked)
        unvalidated = not_validated_line(tail, blocked)
        chosen.notes.extend(([blocked_line(blocked)] if blocked else []) + lines
                            + ([unvalidated] if unvalidated else []))
    chosen.notes.extend(motion_warnings(metrics["outputs"], EXCITE_STD))
    if choice is not None and frozen is not None and split < n:
        metrics["structure"] = {**choice.to_dict(), "validation": validation_table(
            table, reg, requested_spec, requested_config, choice.chosen, split, cols,
            requested_reg, choice.online)}
        chosen.notes.extend(behind_lines(metrics["outputs"], frozen_rules,
                                         float(np.count_nonzero(excited[:split]) * dt),
                                         1.0 / dt, reg.X.shape[1] + 1))
        used = {**fallbacks(metrics["outputs"]), **still_used}
        for y in spec.outputs:
            metrics["outputs"][y]["used"] = used.get(y, "eTS")
        fallback, unsaved = fallback_block(
            used, {y: REASONS["blocks" if y in still_used else "tail"] for y in used},
            reg, spec, split)
        chosen.notes.extend(unsaved)
        applied = read_fallback({"fallback": fallback}, spec, "identify")
        if applied is not None:
            blocks = applied_validation(reg, spec, split, len(table), cols, frozen, applied,
                                        sigma, sigma_native, EXCITE_STD)
            for y in spec.outputs:
                metrics["outputs"][y]["applied"] = {"model": applied.used(spec.outputs)[y],
                                                    "validation": blocks[y]}
            chosen.notes.append(applied_line(metrics["outputs"], applied.models))
    metrics["regimes"] = regime_summary_of(frozen_dict, table, reg, list(spec.outputs), cols,
                                           split)
    run_config = {
        **run_header("identify", table, source),
        "model": {**spec.to_dict(), "inputs": chosen.inputs, "notes": chosen.notes,
                  "sample_rate": rate_info(table),
                  **({"attitude_states": attitude.to_dict()} if attitude else {})},
        "parameters": asdict(config),
        "ets": {**config.ets_params(bool(spec.antecedent), len(spec.antecedent_names or [])),
                "normalise": config.normalise},
        "skipped": reg.skipped,
        "warnings": list(table.attrs.get("warnings") or []),
    }
    radius = rotor_radius(table.attrs)
    done()
    return Run(predictions_frame(reg, spec, table, split, cols), jsonable(metrics), run_config,
               history, consequents, rules_json(frozen_dict, spec, rate, radius, fallback),
               rules_json(model.to_dict(), spec, rate, radius))
