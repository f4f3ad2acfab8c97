"""Real recordings with a known change injected: what ``etsid gap`` names, and what it says
it could not have seen.

SIM is a real flight from ``../shared/data/logs`` (those with motor outputs or loop
commands and at least a minute of flight); REAL is the same flight with one change of
known size made to its FlightTable (:func:`inject`), plus the identical copy and the copy
re-encoded through a Parquet table. Every change is run at sizes from below to well above
what such a flight can show. How each injection is made, and why it is faithful, is in
docs/gap_benchmarks.md ("Real recordings: injected changes").

Run::

    python benchmarks/gap_real.py                     # every log, every change
    python benchmarks/gap_real.py --logs hexa         # logs whose name contains "hexa"
    python benchmarks/gap_real.py --changes delay,gyro_bias --json out.json

A case is scored as (docs/gap_benchmarks.md gives the rules):

* ``identical`` / ``parquet``: right when ``consistent`` with every dynamic channel within its
  floor (a sensor-consistency channel is judged by its offset test, as the verdict judges it);
* an in-vocabulary change: ``named`` when its effect is among the named ones;
* an out-of-vocabulary change (gyro scale, accelerometer scale, IMU misalignment):
  ``seen`` when the verdict is ``mismatch``;
* every change: never ``different-vehicle``; where the verdict carries the pair's detectable
  size (``detectable``), a change below it is honest when nothing (it or another effect)
  is named at confidence >= 0.5 and the verdict says the pair could not see it.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

SHARED_LOGS = next((p / "shared" / "data" / "logs" for p in Path(__file__).resolve().parents
                    if (p / "shared" / "data" / "logs").is_dir()),
                   Path(__file__).resolve().parents[2] / "shared" / "data" / "logs")
"""The shared real logs: ``shared/data/logs`` beside the repository (or beside a folder
holding it)."""
LOGS = ("px4_v6c_quad_lowhover_real.ulg", "px4_coaxocto_stabilized_real.ulg",
        "px4_coaxocto_manual_real.ulg", "ardupilot_copter403_hexa_loiter_real.bin",
        "ardupilot_copter33_loiter_acro_flips_real.bin")
"""The shared real flights with motor outputs and more than the gap's minimum airborne time
(the others are too short, too slow, simulated or not a multirotor)."""
RESPONSE_COLUMNS = ("p", "q", "r", "roll", "pitch", "yaw", "ax", "ay", "az", "vx", "vy", "vz",
                    "alt")
"""Everything the vehicle's motion produces (sensors and estimates); the motor outputs and
the pilot's commands are what it responds to."""
ANGLES = ("roll", "pitch", "yaw")
"""Columns that wrap at ±π (shifted on their unwrapped values)."""
K_IDLE = 0.1
"""Idle offset k of rotor speed ∝ (m + k) used to turn a thrust change into the command a
motor needs (etsid's own default; the real vehicles' k is not known)."""
MAX_CLIPPED = 0.01
"""A thrust injection that would push more than this share of airborne motor samples past
full command is not made (the vehicle could not have flown the recording)."""


def _late(table: pd.DataFrame, cols: tuple[str, ...], delay: float) -> pd.DataFrame:
    """``cols`` of ``table`` as they would read ``delay`` s later (linear interpolation on the
    table's own clock; the first ``delay`` s hold the first value)."""
    out = table.copy()
    t = table.index.to_numpy(dtype=float)
    for c in cols:
        if c not in table.columns:
            continue
        v = table[c].to_numpy(dtype=float)
        good = np.isfinite(v)
        if good.sum() < 2:
            continue
        angle = c in ANGLES
        src = np.unwrap(v[good]) if angle else v[good]
        shifted = np.interp(t - delay, t[good], src)
        if angle:  # interpolated on the unwrapped angle: no spike across ±π
            shifted = np.angle(np.exp(1j * shifted))
        shifted[~good] = np.nan
        out[c] = shifted
    return out


def _rotate_imu(table: pd.DataFrame, rot: Rotation) -> pd.DataFrame:
    """The IMU mounted rotated by ``rot`` (sensor = rot⁻¹ · body): gyro and accelerometer
    in the sensor's axes, and the attitude the estimator then reports (the sensor frame's)."""
    out = table.copy()
    inv = rot.inv()
    for cols in (("p", "q", "r"), ("ax", "ay", "az")):
        if all(c in table.columns for c in cols):
            v = table[list(cols)].to_numpy(dtype=float)
            good = np.all(np.isfinite(v), axis=1)
            w = np.full_like(v, np.nan)
            w[good] = inv.apply(v[good])
            out[list(cols)] = w
    att = ("roll", "pitch", "yaw")
    if all(c in table.columns for c in att):
        e = table[list(att)].to_numpy(dtype=float)
        good = np.all(np.isfinite(e), axis=1)
        body = Rotation.from_euler("ZYX", e[good][:, ::-1])
        sensor = (body * rot).as_euler("ZYX")[:, ::-1]
        new = np.full_like(e, np.nan)
        new[good] = sensor
        out[list(att)] = new
    return out


def motor_columns(table: pd.DataFrame) -> list[str]:
    """The table's motor output columns m1..mN."""
    return [c for c in table.columns if c[0] == "m" and c[1:].isdigit()]


def _thrust(table: pd.DataFrame, gains: dict[str, float]) -> pd.DataFrame | None:
    """Motor outputs a vehicle whose motor ``c`` gives ``gains[c]`` of the thrust at a given
    command needs to fly the same motion: ``(m + k)/√g − k``; None when that needs more than
    full command too often (:data:`MAX_CLIPPED`)."""
    out = table.copy()
    clipped, total = 0, 0
    for c, g in gains.items():
        m = table[c].to_numpy(dtype=float)
        need = (m + K_IDLE) / np.sqrt(g) - K_IDLE
        active = m > 0.05
        clipped += int(np.sum(need[active] > 1.0))
        total += int(np.sum(active))
        out[c] = np.where(active, np.clip(need, 0.0, 1.0), m)
    if total == 0 or clipped > MAX_CLIPPED * total:
        return None
    return out


@dataclass(frozen=True)
class Change:
    """One kind of injected change: its name, the effect gap should name (None: outside the
    vocabulary), its sizes (unit), and how it is made."""

    name: str
    effect: str | None
    unit: str
    sizes: tuple[float, ...]
    make: Callable[[pd.DataFrame, float], pd.DataFrame | None]
    parameter: str = ""
    """The effect parameter the size is compared with (``detectable``)."""


def _add(cols: tuple[str, ...], size: float) -> Callable[[pd.DataFrame], pd.DataFrame]:
    def go(t: pd.DataFrame) -> pd.DataFrame:
        out = t.copy()
        for c in cols:
            out[c] = t[c] + size
        return out
    return go


def _scale(col: str, size: float) -> Callable[[pd.DataFrame], pd.DataFrame]:
    def go(t: pd.DataFrame) -> pd.DataFrame:
        out = t.copy()
        out[col] = t[col] * (1.0 + size)
        return out
    return go


CHANGES: tuple[Change, ...] = (
    Change("delay", "time_delay", "s", (0.01, 0.02, 0.04, 0.06),
           lambda t, d: _late(t, RESPONSE_COLUMNS, d), "delay"),
    Change("gyro_bias", "gyro_bias", "rad/s", (0.003, 0.01, 0.03, 0.1),
           lambda t, b: _add(("q",), b)(t), "by"),
    Change("gyro_scale", None, "1", (0.02, 0.05, 0.15), lambda t, s: _scale("p", s)(t)),
    Change("accel_bias", "accel_bias", "m/s²", (0.05, 0.2, 0.5, 1.5),
           lambda t, b: _add(("az",), b)(t), "bz"),
    Change("accel_scale", None, "1", (0.01, 0.03, 0.1), lambda t, s: _scale("az", s)(t)),
    Change("misalignment", None, "deg", (1.0, 3.0, 6.0),
           lambda t, a: _rotate_imu(t, Rotation.from_euler("x", a, degrees=True))),
    Change("weak_motor", "weak_motor", "1", (0.95, 0.85, 0.7),
           lambda t, g: _thrust(t, {motor_columns(t)[0]: g}), "scale"),
    Change("thrust_scale", "thrust_scale", "1", (0.95, 0.85),
           lambda t, g: _thrust(t, {c: g for c in motor_columns(t)}), "scale"),
)
BY_NAME = {c.name: c for c in CHANGES}


def reencode(table: pd.DataFrame, folder: Path) -> pd.DataFrame:
    """The table saved as Parquet and read back by etsid's own table reader (what a user's
    saved table goes through)."""
    from etsid.table import load_table, save_table

    return load_table(save_table(table, folder / "real.parquet"))


def load(name: str, folder: Path = SHARED_LOGS) -> pd.DataFrame:
    """The shared real log as a FlightTable."""
    from etsid.ingest import read_log

    return read_log(folder / name)


@dataclass
class Case:
    """One pair: log, change, size, and what gap said."""

    log: str
    change: str
    size: float
    verdict: str = ""
    named: list[tuple[str, float]] | None = None
    detectable: dict[str, Any] | None = None
    worst_ratio: float = 0.0
    caveats: list[str] | None = None
    seconds: float = 0.0
    skipped: str = ""
    limit: float = 1.0
    """The worst channel a copy may show: √ of the calibrated innovation-variance ratio."""

    def expected(self) -> str | None:
        """The effect gap should name (None: identical, parquet, or out of vocabulary)."""
        ch = BY_NAME.get(self.change)
        return ch.effect if ch else None

    def below(self) -> bool | None:
        """Is the injected size below the pair's stated detectable size of the injected
        parameter, in the injected direction? True also when the verdict calls the effect
        ``insufficient``; None when the verdict states nothing for it (or the change is
        outside the vocabulary)."""
        ch = BY_NAME.get(self.change)
        if ch is None or ch.effect is None or not self.detectable:
            return None
        entry = self.detectable.get(ch.effect)
        if not entry:
            return None
        if entry.get("status") == "insufficient":
            return True
        null = 1.0 if ch.effect in ("weak_motor", "thrust_scale") else 0.0
        way = "up" if self.size >= null else "down"
        limit = (entry.get("per_parameter") or {}).get(ch.parameter, {}).get(way)
        if limit is None:
            return True  # not detectable within the parameter's range in that direction
        return abs(self.size - null) < float(limit)

    def outcome(self) -> str:
        """``right`` (the injected effect named; below the stated detectable size only when
        named alone at confidence >= 0.5), ``look-alike`` (named as the chosen effect's
        look-alike), ``honest`` (below the stated detectable size, not named at confidence
        >= 0.5), ``seen`` /
        ``unseen`` (outside the vocabulary: a mismatch or not) or ``wrong``."""
        if self.skipped:
            return "skipped"
        if self.verdict == "different-vehicle":
            return "wrong"
        if self.change in ("identical", "parquet"):
            return "right" if self.verdict == "consistent" and self.worst_ratio <= self.limit \
                else "wrong"
        exp = self.expected()
        if exp is None:
            return "seen" if self.verdict == "mismatch" else "unseen"
        names = dict(self.named or [])
        if self.below():  # honest: nothing said with confidence; right: the truth alone
            confident = {n for n, c in names.items() if c >= 0.5 and n != "unexplained"}
            if not confident:
                return "honest"
            return "right" if confident == {exp} else "wrong"  # the truth alone is right
        if exp in names:
            return "right"
        if any(exp.replace("_", " ") in c for c in self.caveats or []):
            return "look-alike"
        return "wrong"


def run_case(sim: pd.DataFrame, real: pd.DataFrame, log: str, change: str, size: float
             ) -> Case:
    """gap on one pair, summarised."""
    from etsid.gap.run import analyse

    case = Case(log, change, size)
    t0 = time.time()
    try:
        data = analyse(sim, real, "sim.ulg", "real.ulg").data
    except Exception as err:  # a refusal is a result too
        case.verdict = f"error: {err}"
        return case
    case.seconds = time.time() - t0
    case.verdict = data["verdict"]
    case.named = [(e["name"], float(e.get("confidence", 0.0))) for e in data["effects"]]
    case.caveats = [str(e["caveat"]) for e in data["effects"] if e.get("caveat")]
    case.detectable = data.get("detectable")
    # a sensor-consistency channel is judged by its offset test, not by this ratio
    # (criterion.mismatched): the dynamic channels' variance ratios only
    by_offset = set((data.get("criterion") or {}).get("offset") or {})
    z = [v for d in (data.get("nominal", {}).get("z_all", {}),
                     data.get("nominal", {}).get("z_held_out", {}))
         for c, v in d.items() if c not in by_offset]
    case.worst_ratio = float(np.sqrt(max(z))) if z else 0.0
    # the criterion's own bar (innovation variance ratio): a copy is right when within it
    thresholds = (data.get("criterion") or {}).get("thresholds") or {}
    case.limit = float(np.sqrt(thresholds.get("mismatch_ratio", 1.0)))
    return case


def cases_for(table: pd.DataFrame, log: str, changes: list[str], pick: str = ""
              ) -> list[tuple]:
    """(log, change, size, REAL table or skip reason) for every case of one log (``pick``
    ``"quick"``: each change at its largest size only; ``"ends"``: its smallest and largest)."""
    out: list[tuple] = []
    if "identical" in changes:
        out.append((log, "identical", 0.0, table.copy()))
    if "parquet" in changes:
        with tempfile.TemporaryDirectory() as tmp:
            out.append((log, "parquet", 0.0, reencode(table, Path(tmp))))
    for ch in CHANGES:
        if ch.name not in changes:
            continue
        sizes = {"quick": ch.sizes[-1:], "ends": (ch.sizes[0], ch.sizes[-1])}.get(pick, ch.sizes)
        for s in sizes:
            real = ch.make(table, s)
            out.append((log, ch.name, s, real if real is not None else
                        "needs more than full command"))
    return out


def table_lines(cases: list[Case]) -> list[str]:
    """Markdown rows: log, change, size, verdict, named, detectable, outcome."""
    rows = ["| log | change | size | verdict | worst × floor | named (confidence) | detectable "
            "| outcome |", "|---|---|---|---|---|---|---|---|"]
    for c in cases:
        named = ", ".join(f"{n} {conf:.2f}" for n, conf in c.named or []) or "–"
        ch = BY_NAME.get(c.change)
        det = "–"
        if c.detectable and ch is not None and ch.effect:
            e = c.detectable.get(ch.effect) or {}
            ways = (e.get("per_parameter") or {}).get(ch.parameter, {})
            limit = [v for v in ways.values() if v is not None]
            det = (e.get("status", "–") if e.get("status") == "insufficient" or not limit
                   else "/".join(f"{v:.3g}" for v in limit))
        rows.append(f"| {c.log} | {c.change} | {c.size:g} | {c.verdict} | {c.worst_ratio:.2f} "
                    f"| {named} | {det} | "
                    f"{c.outcome()} |")
    return rows


def score(cases: list[Case]) -> dict[str, Any]:
    """Counts by outcome and by change kind."""
    by: dict[str, dict[str, int]] = {}
    for c in cases:
        kind = c.change
        d = by.setdefault(kind, {})
        d[c.outcome()] = d.get(c.outcome(), 0) + 1
    total = {k: sum(d.get(k, 0) for d in by.values())
             for k in ("right", "look-alike", "honest", "seen", "unseen", "wrong", "skipped")}
    dv = sum(c.verdict == "different-vehicle" for c in cases
             if c.change not in ("identical", "parquet"))
    return {"by_change": by, "total": total, "different_vehicle": dv}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print a table and the scores."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", default="", help="comma list of substrings of log names")
    ap.add_argument("--changes", default="", help="comma list of change names (default all)")
    ap.add_argument("--json", default="", help="write the cases as JSON here")
    ap.add_argument("--data", default=str(SHARED_LOGS), help="folder of the real logs")
    ap.add_argument("--quick", action="store_true",
                    help="the largest size of each change only (one case per change and log)")
    ap.add_argument("--ends", action="store_true",
                    help="the smallest and the largest size of each change")
    args = ap.parse_args(argv)
    folder = Path(args.data)
    if not folder.is_dir():
        print(f"{folder}: not here (the shared real logs are not shipped; --data DIR)")
        return 1
    logs = [n for n in LOGS if not args.logs or any(s in n for s in args.logs.split(","))]
    changes = args.changes.split(",") if args.changes else \
        ["identical", "parquet", *BY_NAME]
    cases: list[Case] = []
    for log in logs:
        table = load(log, folder)
        pick = "quick" if args.quick else ("ends" if args.ends else "")
        for lg, change, size, real in cases_for(table, log, changes, pick):
            if isinstance(real, str):
                case = Case(lg, change, size, skipped=real)
            else:
                case = run_case(table, real, lg, change, size)
            cases.append(case)
            print(table_lines([case])[-1], flush=True)
    print()
    print("\n".join(table_lines(cases)))
    s = score(cases)
    print(json.dumps(s, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps([c.__dict__ for c in cases], indent=1,
                                              default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
