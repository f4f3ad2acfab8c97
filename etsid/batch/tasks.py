"""The single commands a batch runs on each log: the one place that calls ingest and ident.

A batch is many independent runs of the existing commands, never a second implementation:
``inspect`` is :func:`etsid.ingest.inspect_log`, ``ingest`` is :func:`etsid.ingest.read_log`
+ :func:`etsid.table.save_table`, ``identify`` is :func:`etsid.ident.identify` +
:func:`etsid.ident.write_run` (with the log read as ``etsid identify`` reads it), ``gap`` is
:func:`etsid.gap.run.run_gap`. Every
call into those packages is in this module, so that a rename there is a one-line fix here.
Each function writes the log's run directory and returns the row fields it knows.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

import numpy as np

from etsid.batch.schema import RATE_OUTPUTS
from etsid.batch.spec import BatchSpec
from etsid.errors import BatchError
from etsid.files import read_json
from etsid.ingest.vehicle import FACTS

GAP_UNAVAILABLE = "gap analysis is not available in this version"

PRELOAD = ("etsid.ingest", "etsid.ident.defaults", "etsid.ident.metrics",
           "etsid.ident.regressors", "etsid.ident.rundir", "etsid.table", "pandas",
           "pyarrow.parquet")
"""Modules worker processes import once, before their first log (the modules of
:mod:`etsid.ident`, whose package loads its names lazily, named one by one)."""


def gap_available() -> bool:
    """True when this etsid has the gap package (:mod:`etsid.gap`)."""
    return importlib.util.find_spec("etsid.gap") is not None


def _log_facts(info: dict[str, Any]) -> dict[str, Any]:
    """Vehicle, autopilot, firmware and hardware where the log names them (the readers put
    them in the table's attrs and inspect's ``extra``: :mod:`etsid.ingest.vehicle`)."""
    return {key: str(info[key]) for key in FACTS if info.get(key) not in (None, "")}


def _term_base(name: str) -> str:
    return name.split("[", 1)[0]


def regimes_fields(rules: dict[str, Any]) -> dict[str, Any]:
    """``regime_count`` and ``regimes`` of a rules.json (schema etsid.rules/2).

    ``regimes`` is each rule's focal point in the antecedent (scheduling) variables, in
    original units, rules separated by ``; `` (``alt=0.27 m; alt=1.9 m``); a lag suffix is
    dropped where the base names are distinct. Only a scheduled rule base has it: an
    unscheduled one fires on every regressor (dozens of lagged values per rule).

    >>> regimes_fields({"antecedents": {"scheduled": True, "names": ["alt[k-1]"],
    ...                 "dimension": 1}, "rules": [{"focal_point": [0.2712, 3.0]},
    ...                                            {"focal_point": [1.9, 2.0]}]})
    {'regime_count': 2, 'regimes': 'alt=0.271 m; alt=1.9 m'}
    """
    rule_list = rules.get("rules") or []
    row: dict[str, Any] = {"regime_count": len(rule_list), "regimes": None}
    ante = rules.get("antecedents") or {}
    names = list(ante.get("names") or [])
    if not ante.get("scheduled") or not names or not rule_list:
        return row
    from etsid.table import COLUMNS

    bases = [_term_base(n) for n in names]
    labels = bases if len(set(bases)) == len(bases) else names
    units = [COLUMNS[b].unit if b in COLUMNS and COLUMNS[b].unit not in ("", "1") else ""
             for b in bases]
    parts = []
    for rule in rule_list:
        point = rule.get("focal_point") or []
        parts.append(", ".join(
            f"{label}={float(value):.3g}" + (f" {unit}" if unit else "")
            for label, unit, value in zip(labels, units, point[:len(names)], strict=False)))
    row["regimes"] = "; ".join(parts)
    return row


def _table_fields(table: Any) -> dict[str, Any]:
    attrs = table.attrs
    t = table.index.to_numpy(dtype=float)
    rate = attrs.get("rate_hz")
    if rate is None and t.size > 1 and t[-1] > t[0]:
        rate = (t.size - 1) / (t[-1] - t[0])
    return {
        "format": attrs.get("format"),
        "duration_s": float(t[-1] - t[0]) if t.size else None,
        "start_time": attrs.get("start_time"),
        "rows": len(table),
        "rate_hz": None if rate is None else float(rate),
        "columns": ",".join(str(c) for c in table.columns),
        "warnings": len(attrs.get("warnings") or []),
        **_log_facts({**(attrs.get("log") or {}), **attrs}),
    }


def inspect(path: Path, spec: BatchSpec, run_dir: Path) -> dict[str, Any]:
    """``etsid inspect`` of one log; writes ``RUN_DIR/inspect.json``."""
    from etsid.ingest import inspect_log

    info = inspect_log(path, spec.read_options)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "inspect.json").write_text(json.dumps(info, indent=1, default=str) + "\n")
    return {
        "format": info.get("format"),
        "duration_s": info.get("duration_s"),
        "start_time": info.get("start_time"),
        "channels": len(info.get("channels") or []),
        "columns": ",".join(info.get("mapping") or {}),
        "warnings": len(info.get("warnings") or []),
        **_log_facts(info.get("extra") or {}),
    }


def ingest(path: Path, spec: BatchSpec, run_dir: Path) -> dict[str, Any]:
    """``etsid ingest`` of one log; writes ``RUN_DIR/table.parquet``."""
    from etsid.errors import IngestError
    from etsid.ingest import read_log
    from etsid.table import save_table

    table = read_log(path, spec.read_options, rate_hz=spec.rate_hz, start=spec.start,
                     end=spec.end)
    if len(table) == 0:
        raise IngestError(f"{path}: the table has no rows")
    run_dir.mkdir(parents=True, exist_ok=True)
    save_table(table, run_dir / "table.parquet")
    return _table_fields(table)


def _load_for_identify(path: Path, spec: BatchSpec) -> Any:
    """The table as ``etsid identify`` reads it (the input choice of the rate model)."""
    from etsid.ident.inputs import load_for_ident
    from etsid.ingest import read_log

    config = spec.ident_config
    if config.outputs:
        return read_log(path, spec.read_options, rate_hz=spec.rate_hz)
    return load_for_ident(path, spec.read_options, inputs=config.inputs, rate_hz=spec.rate_hz)


def _mean(values: list[Any]) -> float | None:
    finite = [float(v) for v in values if isinstance(v, (int, float)) and np.isfinite(v)]
    return float(np.mean(finite)) if finite else None


def _get(data: Any, *keys: str) -> Any:
    for key in keys:
        if not isinstance(data, dict):
            return None
        data = data.get(key)
    return data


def _scored(block: Any, free_run: bool = False) -> Any:
    """``block`` when its fit means something: not flagged ``informative: false`` (an output
    that barely moves in the validation part) and, for a free run, not diverged."""
    if not isinstance(block, dict) or block.get("informative") is False:
        return None
    return None if free_run and block.get("diverged") else block


def metrics_fields(metrics: dict[str, Any], config: dict[str, Any]) -> dict[str, Any]:
    """Row fields of an identification run from its metrics.json and config.json; the
    validation means skip outputs whose validation part is not informative and diverged
    free runs."""
    outputs = metrics.get("outputs") or {}
    row: dict[str, Any] = {
        "n_samples": metrics.get("n_samples"),
        "rules_final": _get(metrics, "rules", "final"),
        "rules_peak": _get(metrics, "rules", "peak"),
        "rules_frozen": _get(metrics, "rules", "frozen"),
        "input_family": _get(config, "model", "inputs", "family"),
        "fit_online": _mean([_get(m, "online", "fit") for m in outputs.values()]),
        "fit_one_step": _mean([_get(_scored(_get(m, "validation", "one_step")), "fit")
                               for m in outputs.values()]),
        "fit_free_run": _mean([_get(_scored(_get(m, "validation", "free_run"), True), "fit")
                               for m in outputs.values()]),
        "ndei_one_step": _mean([_get(_scored(_get(m, "validation", "one_step")), "ndei")
                                for m in outputs.values()]),
        "airborne_s": _get(metrics, "flight", "airborne_s"),
        "metrics_json": json.dumps(metrics, sort_keys=True),
    }
    for y in RATE_OUTPUTS:
        row[f"{y}_fit_one_step"] = _get(outputs, y, "validation", "one_step", "fit")
        row[f"{y}_rmse_one_step"] = _get(outputs, y, "validation", "one_step", "rmse")
    return row


def identify(path: Path, spec: BatchSpec, run_dir: Path) -> dict[str, Any]:
    """``etsid identify`` of one log; writes the RUN_DIR (predictions, rules, metrics …)."""
    from etsid.errors import IdentError
    from etsid.ident import identify as identify_table
    from etsid.ident import write_run

    table = _load_for_identify(path, spec)
    try:
        run = identify_table(table, spec.ident_config, source=path)
    except IdentError as err:
        if str(path) in str(err):
            raise
        raise IdentError(f"{path}: {err}") from err
    write_run(run, run_dir)
    row = _table_fields(table)
    row.update(metrics_fields(run.metrics, run.config))
    rules_path = run_dir / "rules.json"
    if rules_path.is_file():  # the rule base as written, not a second computation
        row.update(regimes_fields(read_json(rules_path, "rules", BatchError)))
    row["warnings"] = len(run.config.get("warnings") or []) + len(
        [n for n in _get(run.config, "model", "notes") or [] if str(n).startswith("warning")])
    return row


def gap(sim: Path, real: Path, spec: BatchSpec, run_dir: Path) -> dict[str, Any]:
    """Sim-vs-real gap analysis of one pair (needs :mod:`etsid.gap`)."""
    if not gap_available():
        raise BatchError(GAP_UNAVAILABLE)
    from etsid.gap.run import run_gap

    result = run_gap(sim, real, run_dir, vehicle=spec.extra.get("vehicle"),
                     options=spec.read_options)
    return gap_fields(result.data)


def gap_fields(result: dict[str, Any]) -> dict[str, Any]:
    """Row fields of a gap.json (``verdict``; ``effects`` ranked, each a name or a dict)."""
    effects = [e.get("name") if isinstance(e, dict) else str(e)
               for e in result.get("effects") or result.get("candidates") or []]
    return {"gap_verdict": result.get("verdict"),
            "gap_effects": ",".join(str(e) for e in effects if e) or None,
            "gap_json": json.dumps(result, sort_keys=True, default=str)}


RUNNERS = {"inspect": inspect, "ingest": ingest, "identify": identify}
"""Command → function(path, spec, run_dir) -> row fields (``gap`` takes a pair)."""


WARMED: set[str] = set()
"""Commands this process has warmed up for (inherited by the processes it forks)."""


def warm(command: str) -> None:
    """Load (or compile once) the numba kernels a command uses, before the workers start.

    ``identify`` learns a small synthetic table, which runs every eTS and ARX kernel; the
    compiled code lands in numba's on-disk cache, so the workers load it instead of each
    compiling it again. Once per process: a process forked from a warm one (the fork
    server's workers) is warm already.
    """
    if command != "identify" or command in WARMED:
        return
    from etsid.ident import IdentConfig
    from etsid.ident import identify as identify_table
    from etsid.ident.synthetic import rate_table

    identify_table(rate_table(600, seed=0), IdentConfig(ident_rate=0))
    WARMED.add(command)
