"""The flight behind a run, for the report's flight overview: altitude, thrust, sticks and
the leading rule over time.

A RUN_DIR keeps the model's outputs, not the whole flight, so the overview reads the log
the run names in config.json (``input.path``) again, with the run's input choice, when that
file is still there and unchanged (same SHA-256); otherwise the overview says why it is
missing. The leading rule of every prediction row is the frozen rule base's
:meth:`~etsid.ets.ETS.leading_rule` on the antecedent terms rebuilt from the table.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import EtsidError
from etsid.ident.rundir import Run, sha256

COLUMNS = ("alt", "u_thrust", "u_roll", "u_pitch", "u_yaw")
"""Columns of the overview (those the table has)."""


@dataclass
class Overview:
    """The flight of a run: ``table`` (time index, s) with :data:`COLUMNS` it has, and
    the 1-based leading rule at the prediction times ``lead_t`` (None when not known)."""

    table: pd.DataFrame | None
    lead_t: np.ndarray | None = None
    lead: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)


def _log_path(run: Run, base: Path | None = None) -> tuple[Path | None, str]:
    info = run.config.get("input") or {}
    path = info.get("path")
    if not path:
        return None, "the run names no input file"
    file = Path(str(path))
    if not file.exists() and base is not None and not file.is_absolute() \
            and (base / file).exists():
        file = base / file  # the run was made from the directory that holds RUN_DIR
    if not file.exists():
        return None, f"{file} (the run's input) is not there any more"
    digest = info.get("sha256")
    if digest and file.is_file() and sha256(file) != digest:
        return None, f"{file} changed since the run (SHA-256 differs)"
    return file, ""


def read_flight(run: Run, base: Path | None = None) -> Overview:
    """The :class:`Overview` of ``run``; ``table`` None (with a note) when the log cannot
    be read again. A relative input path is looked for from the working directory, then
    from ``base`` (the directory holding RUN_DIR)."""
    from etsid.ident.inputs import load_for_ident

    file, why = _log_path(run, base)
    if file is None:
        return Overview(None, notes=[f"No flight overview: {why}."])
    mode = str((run.config.get("parameters") or {}).get("inputs") or "auto")
    try:
        table = load_for_ident(file, inputs=mode)
    except (EtsidError, OSError, ValueError) as err:
        return Overview(None, notes=[f"No flight overview: {file} not readable ({err})."])
    keep = [c for c in COLUMNS if c in table.columns]
    overview = Overview(table[keep].copy() if keep else None)
    if not keep:
        overview.notes.append(f"No flight overview: {file.name} has none of "
                              f"{', '.join(COLUMNS)}.")
    try:
        overview.lead_t, overview.lead = leading_rules(run, table)
    except (EtsidError, KeyError, ValueError, IndexError) as err:
        overview.notes.append(f"Leading rule not shown: {err}.")
    return overview


def leading_rules(run: Run, table: pd.DataFrame) -> tuple[np.ndarray | None,
                                                           np.ndarray | None]:
    """(t, rule) at the run's prediction times: the 1-based rule that fires most, from the
    antecedent terms (``NAME[k-LAG]``, NAME a table or derived column) of rules.json."""
    from etsid.ets import ETS
    from etsid.ident.regressors import column_values, parse_terms

    rules = run.rules
    names = (rules.get("antecedents") or {}).get("names") or []
    if not names or not rules.get("rules"):
        return None, None
    spec = rules.get("regressors") or {}
    rate = float(spec.get("sample_rate_hz") or (run.config.get("input") or {}).get("rate_hz")
                 or 0.0)
    if rate <= 0:
        raise ValueError("the rule base does not say its sample rate")
    t_pred = run.predictions["t"].to_numpy(dtype=float)
    t_table = table.index.to_numpy(dtype=float)
    A = np.empty((t_pred.size, len(names)))
    for j, name in enumerate(names):
        term = parse_terms(name)[0]
        values = column_values(table, term.name)
        ok = np.isfinite(values)
        if ok.sum() < 2:
            raise ValueError(f"{term.name} has no data in the log")
        A[:, j] = np.interp(t_pred - term.lag / rate, t_table[ok], values[ok])
    model: Any = ETS.from_dict(rules, trusted=True)
    return t_pred, model.leading_rule(A) + 1
