"""Which model identify learns: the user's outputs and regressors, or the default rate
model (:mod:`etsid.ident.defaults`), and a record of why."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from etsid.errors import IdentError
from etsid.ident.config import IdentConfig
from etsid.ident.defaults import ATTITUDE_TERMS, default_model
from etsid.ident.regressors import RegressorSpec


@dataclass
class ChosenModel:
    """The regressor spec identify learns, notes for people and the input record.

    Attributes
    ----------
    spec
        Outputs and regressors.
    notes
        One line each, printed and stored in config.json ``model.notes``.
    inputs
        config.json ``model.inputs``: the input family, its columns and sources.
    attitude
        The spec carries the default model's attitude states.
    """

    spec: RegressorSpec
    notes: list[str] = field(default_factory=list)
    inputs: dict[str, Any] = field(default_factory=dict)
    attitude: bool = False


def choose_model(table: pd.DataFrame, config: IdentConfig) -> ChosenModel:
    """The model of ``config`` for ``table``.

    Raises
    ------
    IdentError
        ``outputs`` without ``regressors``, a bad regressor spec, or no default model
        for the table's columns.
    """
    antecedent = config.antecedent_for(table)
    if config.outputs:
        if not config.regressors:
            raise IdentError("--output needs --regressors, e.g. --regressors "
                             f"\"{config.outputs[0]}[k-1],u[k-1]\"")
        spec = RegressorSpec.parse(config.regressors, config.outputs, antecedent)
        return ChosenModel(spec, [], {"family": "user", "columns": [
            c for c in spec.columns if c not in spec.outputs]})
    chosen = default_model(table, config.output_lags, config.input_lags, config.inputs,
                           config.attitude)
    spec = chosen.spec
    if config.regressors or antecedent:
        spec = RegressorSpec.parse(config.regressors or spec.text, spec.outputs, antecedent)
    info: dict[str, Any] = {"family": chosen.family, "kind": chosen.kind,
                            "columns": chosen.inputs, "sources": chosen.sources,
                            "mode": config.inputs, "reason": chosen.reason}
    selection = table.attrs.get("input_selection")
    if isinstance(selection, dict):
        info["selection"] = selection
    notes = [chosen.note]
    if chosen.attitude:
        notes.append(f"attitude states {ATTITUDE_TERMS}: the attitude loop closes around "
                     "the inputs; integrated from the simulated rates in free run "
                     "(--attitude-states none to leave them out)")
    if antecedent and config.antecedent and config.antecedent.strip().lower() == "auto":
        notes.append(f"rules fire on {antecedent} (altitude in the log: scheduled on the "
                     "ground-effect coordinate; --antecedent none for rules on the "
                     "regressors)")
    return ChosenModel(spec, notes, info, chosen.attitude and not config.regressors)
