"""Actuator outputs that carry no rotor: left out of the motor columns, with a note.

A flight controller logs every output of its mixer group (PX4's ``actuator_outputs`` has 8
or 16, ArduPilot's ``RCOU`` 14), and a quad's outputs 5–8 hold a disarmed value, a servo's
centre or zero through the whole flight. Counted as motors they make a quad an 8-rotor
vehicle. An output is *unused* when it does not move (peak to peak at most
:data:`STILL_SPAN` of the output range) through the airborne part of the log while the
others do; trailing unused outputs (after the last one that moves) are dropped from the
table, so ``m1..mN`` is the active rotors, and ``attrs["unused_outputs"]`` says which were
dropped and what they held. An unused output between active ones is kept (its position in
the mixer matters: a motor that stopped is a fault, not an absent rotor) and named in a
warning.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

STILL_SPAN = 0.005
"""Peak-to-peak (share of the 0…1 output range) at or below which an output does not move:
five PWM steps of 1 µs in a 1000 µs range, above the quantisation of any logged output."""
MIN_ACTIVE = 3
"""At least this many moving outputs before any is called unused (a log with fewer is not a
multirotor in flight, and is left as it is)."""


def _motor_columns(table: pd.DataFrame) -> list[str]:
    cols = [c for c in table.columns if c.startswith("m") and c[1:].isdigit()]
    return sorted(cols, key=lambda c: int(c[1:]))


def _airborne(table: pd.DataFrame) -> np.ndarray:
    """Rows the autopilot called airborne (``landed`` false), or every row when the log has
    no land detector or never leaves the ground."""
    if "landed" in table.columns:
        landed = table["landed"].to_numpy(dtype=float)
        air = np.isfinite(landed) & (landed < 0.5)
        if air.sum() >= 10:
            return air
    return np.ones(len(table), dtype=bool)


def unused_outputs(table: pd.DataFrame) -> dict[str, str]:
    """Motor column → what it held, for every output that does not move while airborne (as
    long as at least :data:`MIN_ACTIVE` others do)."""
    motors = _motor_columns(table)
    if len(motors) <= MIN_ACTIVE:
        return {}
    air = _airborne(table)
    still: dict[str, str] = {}
    for c in motors:
        v = table[c].to_numpy(dtype=float)[air]
        v = v[np.isfinite(v)]
        if v.size == 0:
            still[c] = "no samples while airborne"
        elif float(np.ptp(v)) <= STILL_SPAN:
            still[c] = f"constant {float(np.median(v)):.3g} while airborne"
    if len(motors) - len(still) < MIN_ACTIVE:
        return {}
    return still


def drop_unused_outputs(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` without its trailing unused outputs (:func:`unused_outputs`), with
    ``attrs["unused_outputs"]`` and a warning naming them; unchanged when every output moves."""
    still = unused_outputs(table)
    if not still:
        return table
    motors = _motor_columns(table)
    active = [c for c in motors if c not in still]
    last = int(active[-1][1:])
    trailing = [c for c in motors if int(c[1:]) > last]
    inner = [c for c in still if int(c[1:]) < last]
    out = table.drop(columns=trailing) if trailing else table.copy()
    out.attrs = dict(table.attrs)
    warnings = list(out.attrs.get("warnings", []))
    layout = out.attrs.get("motor_layout")
    if trailing and isinstance(layout, dict):
        n = len(motors) - len(trailing)
        out.attrs["motor_layout"] = {k: (v[:n] if isinstance(v, list) and len(v) == len(motors)
                                         else v) for k, v in layout.items()}
    if trailing:
        out.attrs["unused_outputs"] = {c: still[c] for c in trailing}
        warnings.append(f"motor outputs {', '.join(trailing)} never move while airborne "
                        f"({'; '.join(f'{c} {still[c]}' for c in trailing)}): unused, left out "
                        f"of the rotor count ({len(motors) - len(trailing)} rotors)")
    if inner:
        warnings.append(f"motor output {', '.join(inner)} never moves while airborne while the "
                        "others do: kept (a stopped motor inside the mixer is a fault, not an "
                        "absent rotor)")
    out.attrs["warnings"] = warnings
    return out
