"""Motor outputs as model inputs: the loop commands they carry, when the geometry is known.

A multirotor's mixer turns four commands — collective thrust, roll, pitch and yaw — into
one output per motor, ``m = M c`` with the mixer matrix ``M`` (N × 4). Its columns follow
from the motor layout alone (as PX4's and ArduPilot's geometric mixers build them): per
motor ``i`` at ``(xᵢ, yᵢ)`` (m, body FRD) spinning ``sᵢ`` (+1 counter-clockwise seen from
above, −1 clockwise),

- thrust 1,
- roll ``−yᵢ / max|y|`` (a right-hand motor slows for a right roll),
- pitch ``xᵢ / max|x|`` (a front motor speeds up for nose up),
- yaw ``sᵢ`` (a counter-clockwise rotor's drag torque turns the body nose right).

The least-squares inverse ``c = M⁺ m`` gives back the commands the outputs carry — the
*motor commands* ``mot_thrust mot_roll mot_pitch mot_yaw`` — whatever the number of motors
(4, 6, 8, coaxial pairs): these are the regressors of ``--inputs motors`` when the table
knows its layout (``attrs["motor_layout"]``: the simulator's vehicle, or PX4's
``CA_ROTOR{i}_PX/_PY/_KM`` parameters, PX4 ≥ 1.13). Without a layout the raw outputs
``m1 … mN`` are the regressors. Saturated or idle motors make ``M⁺ m`` a least-squares
estimate, not the controller's command.

>>> import numpy as np, pandas as pd
>>> layout = {"x": [1, -1, 1, -1], "y": [1, -1, -1, 1], "spin": [1, 1, -1, -1]}
>>> t = pd.DataFrame({f"m{i + 1}": [0.5 + d] for i, d in enumerate([-0.1, 0.1, 0.1, -0.1])})
>>> t.attrs["motor_layout"] = layout
>>> round(float(add_motor_commands(t)["mot_roll"].iloc[0]), 6)
0.1
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from etsid.ident.bare import bare

MOTORS = tuple(f"m{i}" for i in range(1, 9))
"""FlightTable motor-output columns, 0…1."""

MOTOR_COMMANDS = ("mot_roll", "mot_pitch", "mot_yaw", "mot_thrust")
"""Derived columns: the roll, pitch, yaw and thrust commands the motor outputs carry."""


def motor_columns(table: pd.DataFrame) -> list[str]:
    """``m1 … mN``: the table's motor columns with data, from m1 without a hole."""
    out = []
    cols = bare(table)
    for name in MOTORS:
        if name not in cols.columns or not cols[name].notna().any():
            break
        out.append(name)
    return out


def layout_of(table: pd.DataFrame) -> dict[str, list[float]] | None:
    """``attrs["motor_layout"]`` when it is well formed (``x``, ``y``, ``spin``, one entry per
    motor column of the table, at least 4), else None."""
    layout: Any = table.attrs.get("motor_layout")
    motors = motor_columns(table)
    if not isinstance(layout, dict) or len(motors) < 4:
        return None
    try:
        x, y, spin = (np.asarray(layout[k], dtype=float) for k in ("x", "y", "spin"))
    except (KeyError, TypeError, ValueError):
        return None
    if not (x.size == y.size == spin.size == len(motors)) or not np.isfinite(
            np.r_[x, y, spin]).all() or not np.any(x) or not np.any(y):
        return None
    return {"x": x.tolist(), "y": y.tolist(), "spin": np.sign(spin).tolist()}


def mixer(layout: dict[str, list[float]]) -> np.ndarray:
    """The mixer matrix (N, 4) of ``layout``: columns thrust, roll, pitch, yaw (module
    docstring)."""
    x, y, spin = (np.asarray(layout[k], dtype=float) for k in ("x", "y", "spin"))
    return np.column_stack([np.ones(x.size), -y / np.max(np.abs(y)), x / np.max(np.abs(x)),
                            spin])


def add_motor_commands(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with ``mot_roll mot_pitch mot_yaw mot_thrust`` = ``M⁺ m`` when it has a
    motor layout and its motor columns (module docstring); unchanged otherwise."""
    layout = layout_of(table)
    if layout is None:
        return table
    motors = motor_columns(table)
    commands = bare(table)[motors].to_numpy(dtype=float) @ np.linalg.pinv(mixer(layout)).T
    out = table.copy(deep=False)  # new columns only: the table's own stay shared
    for j, name in enumerate(("mot_thrust", "mot_roll", "mot_pitch", "mot_yaw")):
        out[name] = commands[:, j]
    out.attrs = dict(table.attrs)
    return out
