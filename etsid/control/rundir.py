"""RUN_DIR of a control experiment: the files ``etsid control`` writes.

* ``flight.parquet`` — the flight as a FlightTable at the control rate (``alt``, ``vz``,
  ``roll``, ``pitch``, ``u_thrust``) with ``alt_ref``, ``alt_ref_rate``, ``true_alt``,
  ``u_ff``, ``u_fb``, ``mass``;
* ``metrics.json`` — scores (:mod:`etsid.control.metrics`), rule counts, timing;
* ``config.json`` — ``"kind": "control"``, scenario, controller and its settings, vehicle, seed;
* eTS only: ``rules.json`` (the learnt inverse model, schema ``etsid.rules/2``),
  ``history.parquet`` (per learned sample: ``t``, ``step``, ``n_rules``, ``potential``,
  ``focal_max`` = P_max, ``focal_min`` = P_min, cumulative ``births``, ``replacements``,
  ``removals``) and ``events.parquet`` (``t``, ``step``, ``kind``, ``rule_id``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import ControlError
from etsid.table import save_table

KIND = "control"
"""``config.json["kind"]`` of a control run (what ``etsid report`` dispatches on)."""


def jsonable(obj: Any) -> Any:
    """Plain JSON types; NaN/inf become None, numpy scalars and arrays become Python."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def history_frames(model: Any, learn_times: list[float]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The eTS model's per-sample history and its events, with flight time ``t`` (s)."""
    hist = model.history
    frame = hist.to_frame()
    times = np.asarray(learn_times, dtype=np.float64)
    frame.insert(0, "t", times[frame["step"].to_numpy() - 1])
    events = hist.events_frame()
    events.insert(0, "t", times[events["step"].to_numpy(dtype=np.int64) - 1]
                  if len(events) else np.zeros(0))
    for kind, column in (("birth", "births"), ("replace", "replacements"),
                         ("removal", "removals")):
        counts = np.zeros(len(frame), dtype=np.int64)
        steps = events.loc[events["kind"] == kind, "step"].to_numpy(dtype=np.int64)
        np.add.at(counts, steps - 1, 1)
        frame[column] = np.cumsum(counts)
    return frame, events


def write_run(out: str | Path, table: pd.DataFrame, metrics: dict[str, Any],
              config: dict[str, Any], model: Any = None,
              learn_times: list[float] | None = None) -> Path:
    """Write a control RUN_DIR (see the module docstring); returns its path."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ControlError(f"{out}: cannot create the run directory "
                           f"({err.strerror or err})") from err
    if not out.is_dir():
        raise ControlError(f"{out}: is not a directory")
    for stale in ("rules.json", "history.parquet", "events.parquet"):
        (out / stale).unlink(missing_ok=True)
    save_table(table, out / "flight.parquet")
    if model is not None and model.n_rules > 0:
        model.save(out / "rules.json")
        frame, events = history_frames(model, learn_times or [])
        frame.to_parquet(out / "history.parquet", index=False)
        events.to_parquet(out / "events.parquet", index=False)
    (out / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2) + "\n")
    (out / "config.json").write_text(json.dumps(jsonable({"kind": KIND, **config}),
                                                indent=2) + "\n")
    return out
