"""Fleet trends: one fit per flight, grouped by airframe, and the flight where a parameter
leaves its reference.

Airframe: the log's own identity where it states one (``attrs`` keys of
:data:`IDENTITY_KEYS`: a vehicle UUID, system id, serial), else the flight's folder. Flights
of an airframe are ordered by their start time where the log has it, else by name.

Change rule (declared before the benchmark; docs/fit.md): the first :data:`N_REFERENCE`
flights of an airframe are its reference; each later flight's value gets
z = (v − μ_ref) / √(se² + s_between² + se_μ²), with s_between the reference flights' scatter
beyond their own standard errors. A parameter is flagged at the first flight of the first
run of :data:`RUN` consecutive flights with |z| > :data:`Z_FLAG` on the same side.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import EtsidError, FitError
from etsid.fit.run import fit_tables

IDENTITY_KEYS = ("vehicle_uuid", "sys_uuid", "sys_id", "serial", "airframe_id")
"""Table attrs that name one airframe, in order of trust."""
SUFFIXES = (".tlog", ".bin", ".ulg", ".bag", ".mcap", ".parquet", ".csv")
TRACKED = ("hover_command", "motor_time_constant", "roll_accel_per_command",
           "pitch_accel_per_command", "yaw_accel_per_command")
"""Parameters trended besides each motor's share of the work."""
N_REFERENCE = 5
Z_FLAG = 3.0
RUN = 2
"""Two consecutive flights beyond 3σ: under no change, about 0.27 %² per flight pair and
parameter (a single 3σ excursion in 10 parameters × 15 flights would be common)."""


@dataclass
class FleetResult:
    """Rows (one per flight) and flags (one per airframe and parameter that changed)."""

    rows: pd.DataFrame
    flags: list[dict[str, Any]] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)


def find_logs(root: Path) -> list[Path]:
    """Every log or saved table below ``root``, sorted."""
    found = []
    for dirpath, _dirs, files in os.walk(root):
        found += [Path(dirpath) / f for f in files if f.lower().endswith(SUFFIXES)]
    return sorted(found)


def airframe_of(table: pd.DataFrame, path: Path, root: Path) -> str:
    """The airframe a flight belongs to (module docstring)."""
    for key in IDENTITY_KEYS:
        value = table.attrs.get(key)
        if value not in (None, ""):
            return f"{key}={value}"
    rel = path.parent.relative_to(root) if path.parent != root else Path(".")
    return str(rel) if str(rel) != "." else root.name


def fit_fleet(root: Path, read: Callable[[Path], pd.DataFrame],
              progress: Callable[[str], None] | None = None, quick: bool = True
              ) -> FleetResult:
    """Fit every flight below ``root`` and trend each airframe's parameters.

    Raises
    ------
    FitError
        No log below ``root``.
    """
    paths = find_logs(root)
    if not paths:
        raise FitError(f"{root}: no log or saved table below it")
    rows, errors = [], []
    for path in paths:
        try:
            table = read(path)
            result = fit_tables([table], name=path.stem, quick=quick)
        except EtsidError as err:
            errors.append(f"{path}: {err}")
            continue
        row: dict[str, Any] = {"airframe": airframe_of(table, path, root), "flight": path.name,
                               "path": str(path), "start": table.attrs.get("start_time")}
        for name, p in result.params.items():
            if p.verdict in ("identified", "not-determined") and math.isfinite(p.se):
                row[name] = p.value
                row[f"{name}_se"] = p.se
        rows.append(row)
        if progress:
            progress(f"{path.name}: {row['airframe']}")
    frame = pd.DataFrame(rows)
    if frame.empty:
        return FleetResult(frame, [], errors)
    frame["_order"] = frame["start"].fillna(0.0) if "start" in frame else 0.0
    frame = frame.sort_values(["airframe", "_order", "flight"]).drop(columns="_order")
    frame["index"] = frame.groupby("airframe").cumcount() + 1
    return FleetResult(frame.reset_index(drop=True), change_flags(frame), errors)


def tracked(frame: pd.DataFrame) -> list[str]:
    """Parameters of ``frame`` that are trended."""
    shares = sorted(c for c in frame if c.startswith("motor") and c.endswith("_share"))
    return [c for c in (*TRACKED, *shares) if c in frame]


def zscores(values: np.ndarray, ses: np.ndarray) -> np.ndarray:
    """z of every flight against the first :data:`N_REFERENCE` (NaN for those)."""
    ref_v, ref_s = values[:N_REFERENCE], ses[:N_REFERENCE]
    ok = np.isfinite(ref_v) & np.isfinite(ref_s)
    z = np.full(values.size, np.nan)
    if ok.sum() < 3:
        return z
    mu = float(np.mean(ref_v[ok]))
    between = max(0.0, float(np.var(ref_v[ok], ddof=1) - np.mean(ref_s[ok] ** 2)))
    se_mu = math.sqrt(float(np.var(ref_v[ok], ddof=1)) / ok.sum())
    den = np.sqrt(ses ** 2 + between + se_mu ** 2)
    z[N_REFERENCE:] = (values[N_REFERENCE:] - mu) / den[N_REFERENCE:]
    return z


def change_flags(frame: pd.DataFrame) -> list[dict[str, Any]]:
    """One flag per airframe and parameter: the flight where a sustained change starts."""
    flags = []
    for airframe, group in frame.groupby("airframe"):
        group = group.sort_values("index")
        for name in tracked(group):
            z = zscores(group[name].to_numpy(dtype=float),
                        group[f"{name}_se"].to_numpy(dtype=float))
            for i in range(N_REFERENCE, len(z) - RUN + 1):
                window = z[i:i + RUN]
                if np.all(np.isfinite(window)) and (np.all(window > Z_FLAG)
                                                   or np.all(window < -Z_FLAG)):
                    flags.append({"airframe": airframe, "param": name,
                                  "flight": int(group["index"].iloc[i]),
                                  "name": str(group["flight"].iloc[i]),
                                  "z": float(window[0])})
                    break
    return flags
