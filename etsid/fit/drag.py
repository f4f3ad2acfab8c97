"""Body drag per mass from the horizontal specific force in steady flight.

In body axes the rotors push along −z only, so the accelerometer's x and y read the drag
over the mass: a_x = −d_x v_x − e_x |v_x| v_x + b_x (v in body axes, air at rest; d lumps
the body's linear drag and the rotors' H-force, which grows with rotor speed and is not
separable from it at one weight; e the quadratic drag; b the accelerometer bias).
"""

from __future__ import annotations

import numpy as np

from etsid.fit.regress import LinearFit, robust_lstsq
from etsid.fit.signals import Flight


def fit_drag(flights: list[Flight]) -> dict[str, LinearFit] | None:
    """Per axis ``"x"``, ``"y"``: coefficients [−d, −e, b]; None without accelerometer and
    velocity."""
    out: dict[str, LinearFit] = {}
    for axis, name in ((0, "x"), (1, "y")):
        xs, ys = [], []
        for f in flights:
            if f.accel is None or f.vel_body is None:
                continue
            v = f.vel_body[:, axis]
            reg = f.lowpass(np.column_stack([v, np.abs(v) * v, np.ones(len(v))]))
            y = f.lowpass(f.accel[:, axis])
            xs.append(reg[f.airborne])
            ys.append(y[f.airborne])
        if not xs:
            return None
        out[name] = robust_lstsq(np.vstack(xs), np.concatenate(ys))
    return out
