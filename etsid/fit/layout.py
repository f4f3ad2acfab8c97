"""Rotor geometry of a log: which outputs drive motors, where they sit, how they spin.

Order of trust: the log's own mixer geometry (``attrs["motor_layout"]``: the simulator's
vehicle, PX4 ≥ 1.13 ``CA_ROTOR*``), else ArduPilot's ``FRAME_CLASS`` / ``FRAME_TYPE``
(angles and spins, :mod:`etsid.ingest.ardupilot_frames`), else the autopilot's standard
layout for the number of active outputs (PX4 Quad X / Hexa X / Octo coax X order), stated
as a declared default.
An output is *active* when it moves in flight: a servo rail parked at one value, or an
unused channel, is left out and counted.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import FitError
from etsid.ingest.ardupilot_frames import frame_layout
from etsid.ingest.px4_airframes import NOT_MULTIROTOR as PX4_NOT_MULTIROTOR
from etsid.ingest.px4_airframes import airframe_family

MOTORS = tuple(f"m{i}" for i in range(1, 9))

STANDARD_LAYOUTS: dict[int, tuple[list[float], list[str]]] = {
    4: ([45.0, 225.0, 315.0, 135.0], ["ccw", "ccw", "cw", "cw"]),
    6: ([90.0, 270.0, 330.0, 150.0, 30.0, 210.0], ["cw", "ccw", "cw", "ccw", "ccw", "cw"]),
    8: ([45.0, 45.0, 315.0, 315.0, 225.0, 225.0, 135.0, 135.0],
        ["ccw", "cw", "cw", "ccw", "ccw", "cw", "cw", "ccw"]),
}
"""Rotor angles (deg clockwise from the nose) and spins of PX4's Quad X, Hexa X and
Octo coax X, in output order (docs/physics.md, PX4 airframe reference)."""

STANDARD_FAMILY = {4: "quad X", 6: "hexa X", 8: "octo coax"}
"""The PX4 airframe family (:mod:`etsid.ingest.px4_airframes`) of each standard layout."""

NOT_MULTIROTOR = ("fixed wing", "plane", "vtol", "helicopter", "rover", "submarine", "boat",
                  "airship")
"""Vehicle kinds (``attrs["vehicle"]``) whose outputs are not all rotors (a QuadPlane's
servos move in flight like motors and would be taken for an octocopter)."""

DEFAULT_ARM = 0.25
"""m, declared arm length when the log has no geometry (a mid-size frame), or when its
geometry is in nominal units (PX4's default CA_ROTOR positions are ±1: arms over 1 m are
taken as angles only)."""


def active_motors(table: pd.DataFrame, min_std: float = 0.003) -> tuple[list[str], list[str]]:
    """(motor columns that move in flight, columns present but parked/unused)."""
    used, parked = [], []
    for name in MOTORS:
        if name not in table.columns:
            continue
        col = table[name].to_numpy(dtype=float)
        ok = np.isfinite(col)
        if ok.sum() < 10 or np.nanstd(col) < min_std or np.nanmax(col) < 0.05:
            parked.append(name)
        else:
            used.append(name)
    return used, parked


def rotor_layout(table: pd.DataFrame, motors: list[str]) -> dict[str, Any]:
    """Geometry of the active motors: ``angles_deg``, ``spin``, ``arm`` (m), ``source``.

    Raises
    ------
    FitError
        Fewer than 4 active motor outputs, or a count without a standard layout and no
        geometry in the log.
    """
    n = len(motors)
    src = table.attrs.get("source", "table")
    kind = str(table.attrs.get("vehicle", "")).lower()
    if any(word in kind for word in NOT_MULTIROTOR):
        raise FitError(f"{src}: the log names a {kind} ({table.attrs.get('firmware', '')}"
                       "): its outputs drive control surfaces too; etsid fit models "
                       "multirotors only")
    if n < 4:
        raise FitError(f"{src}: {n} active motor output(s) ({', '.join(motors) or 'none'}); "
                       "a multirotor fit needs at least 4")
    layout = table.attrs.get("motor_layout")
    if isinstance(layout, dict) and all(k in layout for k in ("x", "y", "spin")):
        x = np.asarray(layout["x"], dtype=float)
        y = np.asarray(layout["y"], dtype=float)
        spin = np.sign(np.asarray(layout["spin"], dtype=float))
        arm = float(np.median(np.hypot(x, y))) if x.size else 0.0
        if x.size == n and np.all(np.isfinite(np.r_[x, y])) and 0.03 <= arm <= 1.0:
            angles = [math.degrees(math.atan2(b, a)) % 360.0 for a, b in zip(x, y, strict=True)]
            return {"angles_deg": angles, "spin": ["ccw" if s > 0 else "cw" for s in spin],
                    "arm": arm, "arm_known": True, "n": n,
                    "source": "the log's mixer geometry (motor_layout)"}
        if x.size == n and np.all(np.isfinite(np.r_[x, y])):
            angles = [math.degrees(math.atan2(b, a)) % 360.0 for a, b in zip(x, y, strict=True)]
            return {"angles_deg": angles, "spin": ["ccw" if s > 0 else "cw" for s in spin],
                    "arm": DEFAULT_ARM, "arm_known": False, "n": n,
                    "source": "the log's mixer angles and spins (its arm lengths "
                              f"{arm:.2f} m are nominal: arm declared {DEFAULT_ARM} m)"}
    log = table.attrs.get("log") if isinstance(table.attrs.get("log"), dict) else {}
    frame = frame_layout({"FRAME_CLASS": log.get("frame_class"),
                          "FRAME_TYPE": log.get("frame_type")})
    if frame is not None and len(frame["spin"]) == n:
        return {"angles_deg": frame["angles_deg"],
                "spin": ["ccw" if s > 0 else "cw" for s in frame["spin"]],
                "arm": DEFAULT_ARM, "arm_known": False, "n": n,
                "source": f"{frame['source']}, arm declared {DEFAULT_ARM} m"}
    family = airframe_family(log.get("sys_autostart"))
    if family is not None and family[0] in PX4_NOT_MULTIROTOR:
        raise FitError(f"{src}: SYS_AUTOSTART {log['sys_autostart']} is a PX4 {family[0]} "
                       "airframe: its outputs are not all rotors; etsid fit models "
                       "multirotors only")
    if n not in STANDARD_LAYOUTS:
        raise FitError(f"{src}: {n} active motor outputs and no rotor geometry in the log; "
                       "only 4, 6 or 8 have a standard layout")
    angles, spin = STANDARD_LAYOUTS[n]
    source = f"PX4 standard layout for {n} rotors (declared: the log has no geometry)"
    if family is not None:
        confirmed = family[1] and family[0] == STANDARD_FAMILY[n]
        source = (f"PX4 standard layout for {n} rotors, the log's SYS_AUTOSTART "
                  f"{log['sys_autostart']} ({family[0]} family) "
                  + ("confirms it" if confirmed else "is not laid out: declared"))
    return {"angles_deg": list(angles), "spin": list(spin), "arm": DEFAULT_ARM,
            "arm_known": False, "n": n, "source": source}


def geometry_rows(layout: dict[str, Any]) -> np.ndarray:
    """(3, N) moment arms per unit arm length: roll −sin a, pitch cos a, yaw spin (+1 ccw)."""
    a = np.radians(np.asarray(layout["angles_deg"], dtype=float))
    s = np.array([1.0 if v == "ccw" else -1.0 for v in layout["spin"]])
    return np.vstack([-np.sin(a), np.cos(a), s])
