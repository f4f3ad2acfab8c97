"""Body drag per mass from the horizontal specific force in steady flight.

In body axes the rotors push along −z only, so the accelerometer's x and y read the drag
over the mass (v in body axes, air at rest, b the accelerometer bias):

    a_x = −d_x v_x − h_x (s − 1) v_x − e_x |v_x| v_x + b_x,    s = Ω̄ / Ω̄_hover.

d lumps the body's linear drag and the rotors' H-force at the hover rotor speed (the two are
not separable at one weight, and the vehicle file holds them lumped); e is the quadratic
drag. The H-force of a rotor is linear in its speed times the hub's edgewise speed (blade
flapping and induced drag, c Ω v), so the lumped linear drag is only constant while the
rotors turn at their hover speed. In forward flight they do not: translational lift lets
them turn 3–5 % slower at 4–8 m/s, and since Ω falls as the speed rises, the part of
the linear drag that scales with Ω bends the curve like a negative quadratic term. Fitted
without the (s − 1) v column, that omitted variable moved the linear coefficient up
(+1–2 %) and the quadratic one down (−4–7 %) on every forward flight of etsid's simulator —
a bias of up to one standard error that no error estimate of the residuals can see. With
the column the model is the simulator's physics and the bias is gone (< 1 %); h (the
H-force share of d) is a nuisance, not reported.
"""

from __future__ import annotations

import numpy as np

from etsid.fit.regress import LinearFit, robust_lstsq
from etsid.fit.signals import Flight, motor_state


def fit_drag(flights: list[Flight], rotor_speed: list[np.ndarray] | None = None
             ) -> dict[str, LinearFit] | None:
    """Per axis ``"x"``, ``"y"``: coefficients [−d, −e, b] (then −h when ``rotor_speed``
    is given); None without accelerometer and velocity.

    ``rotor_speed``: per flight, the mean rotor speed over its hover value, s (n,), from
    the fitted motor law; without it the H-force is taken as constant (s = 1).
    """
    out: dict[str, LinearFit] = {}
    for axis, name in ((0, "x"), (1, "y")):
        xs, ys = [], []
        for i, f in enumerate(flights):
            if f.accel is None or f.vel_body is None:
                continue
            v = f.vel_body[:, axis]
            cols = [v, np.abs(v) * v, np.ones(len(v))]
            if rotor_speed is not None:
                cols.append((rotor_speed[i] - 1.0) * v)
            reg = f.lowpass(np.column_stack(cols))
            y = f.lowpass(f.accel[:, axis])
            xs.append(reg[f.airborne])
            ys.append(y[f.airborne])
        if not xs:
            return None
        out[name] = robust_lstsq(np.vstack(xs), np.concatenate(ys))
    return out


def rotor_speed_ratio(flight: Flight, idle: float, tau: float, delay: float,
                      hover: float) -> np.ndarray:
    """Mean rotor speed over its hover value, s = mean_j x_j / x_hover (n,), with x_j =
    Ω_j/Ω_top from the motor law (:func:`etsid.fit.signals.motor_state`) and ``hover`` the
    rotor speed that carries the weight, √(g / (n K))."""
    return motor_state(flight, idle, tau, delay).mean(axis=1) / hover
