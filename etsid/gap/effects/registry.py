"""The registry: every vocabulary effect declared once, in one block: its forms (the laws
of :mod:`etsid.gap.candidates`), a prior per parameter, its words, its look-alikes and the
sentence that says a fitted instance in its own terms.

A block is a function decorated by :func:`_declare`: the function is the sentence
(``p`` the fitted parameters by name, ``sim`` and ``real`` the two logs' names), the
decorator's arguments the rest. Adding an effect is adding its law to
:data:`etsid.gap.candidates.LIBRARY` and one block here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from etsid.gap.candidates import LIBRARY
from etsid.gap.effects.base import Effect, Prior, Sentence

LN = "lognormal"
HALF = "halfnormal"
NORMAL = "normal"

_DECLARED: list[Effect] = []


def _declare(name: str, words: str, priors: dict[str, Prior],
             family: tuple[str, ...] = ()) -> Callable[[Sentence], Sentence]:
    """Register effect ``name`` with the decorated function as its sentence."""
    def register(said: Sentence) -> Sentence:
        forms = tuple(c for c in LIBRARY if c.name == name)
        _DECLARED.append(Effect(name, words, forms, priors, family, said))
        return said
    return register


# Prior widths: a scale's log-normal width is the spread of that quantity between two
# builds of one airframe (±20 % thrust, ±30 % inertia); an offset's width is a quarter of
# its search bound; a delay's or lag's half-normal width is a typical logging/ESC latency.

@_declare("ground_effect", "ground effect",
          {"R": Prior(HALF, 0.5), "exponent": Prior(LN, 0.5), "excess": Prior(HALF, 0.3),
           "decay": Prior(HALF, 0.5), "arm": Prior(HALF, 0.5)})
def _ground_effect(p: dict[str, float], sim: str, real: str) -> str:
    if "excess" in p:
        return (f"ground effect (exponential law, ×{1 + p['excess']:.3g} thrust at the ground "
                f"decaying over {p['decay']:.2g} m)")
    return (f"ground effect (generalised Cheeseman–Bennett, fitted R = {p['R']:.2g} m, "
            f"exponent = {p['exponent']:.3g})")


@_declare("rotor_drag", "rotor drag",
          {"drag": Prior(HALF, 0.5), "moment": Prior(NORMAL, 1.0), "yaw": Prior(HALF, 1.0)},
          ("wind",))
def _rotor_drag(p: dict[str, float], sim: str, real: str) -> str:
    return (f"horizontal drag {p['drag']:.2g} 1/s against the body velocity, with a moment "
            f"of {p['moment']:+.2g} rad/s² per m/s and yaw damping {p.get('yaw', 0.0):.2g} 1/s "
            f"(rotor drag)")


@_declare("motor_lag", "motor lag", {"tau": Prior(LN, 1.0)}, ("time_delay",))
def _motor_lag(p: dict[str, float], sim: str, real: str) -> str:
    return (f"the motors follow their commands with a first-order lag of "
            f"τ = {1000 * p['tau']:.0f} ms (motor lag)")


@_declare("time_delay", "time delay", {"delay": Prior(HALF, 0.04)}, ("motor_lag",))
def _time_delay(p: dict[str, float], sim: str, real: str) -> str:
    return f"{real} responds {1000 * p['delay']:.0f} ms later than {sim} (time delay)"


@_declare("battery_sag", "battery sag", {"exponent": Prior(HALF, 2.0)}, ("thrust_scale",))
def _battery_sag(p: dict[str, float], sim: str, real: str) -> str:
    return (f"thrust and torque follow the measured pack voltage as (V/V_sim)^"
            f"{p['exponent']:.2g} (battery sag)")


@_declare("thrust_scale", "thrust scale", {"scale": Prior(LN, 0.2)}, ("mass", "battery_sag"))
def _thrust_scale(p: dict[str, float], sim: str, real: str) -> str:
    return (f"×{p['scale']:.3g} thrust at the same command (thrust scale; from "
            f"accelerations alone the same as a {1 / p['scale']:.3g}× heavier vehicle: "
            f"thrust-to-weight ×{p['scale']:.3g})")


@_declare("mass", "mass (payload)", {"ratio": Prior(LN, 0.2)}, ("thrust_scale",))
def _mass(p: dict[str, float], sim: str, real: str) -> str:
    return (f"×{p['ratio']:.3g} mass at the same thrust (a payload; thrust-to-weight "
            f"×{1 / p['ratio']:.3g}, roll/pitch authority unchanged; mass)")


@_declare("inertia_scale", "inertia scale", {"scale": Prior(LN, 0.3)}, ("rate_damping",))
def _inertia_scale(p: dict[str, float], sim: str, real: str) -> str:
    return f"×{p['scale']:.3g} inertia (angular accelerations ÷{p['scale']:.3g}; inertia scale)"


@_declare("torque_offset", "torque offset",
          {"p_offset": Prior(NORMAL, 5.0), "q_offset": Prior(NORMAL, 5.0),
           "r_offset": Prior(NORMAL, 5.0)}, ("weak_motor", "rotor_twist"))
def _torque_offset(p: dict[str, float], sim: str, real: str) -> str:
    yaw = abs(p["r_offset"]) > max(abs(p["p_offset"]), abs(p["q_offset"]))
    twist = ("; mostly yaw, which rotors twisted on their arms also give at a steady thrust "
             "(only a change of thrust tells the two apart)" if yaw else "")
    return (f"a constant angular acceleration of ({p['p_offset']:+.2f}, "
            f"{p['q_offset']:+.2f}, {p['r_offset']:+.2f}) rad/s² about roll, pitch, yaw "
            f"(torque offset){twist}")


@_declare("gyro_bias", "gyro bias",
          {"bx": Prior(NORMAL, 0.1), "by": Prior(NORMAL, 0.1), "bz": Prior(NORMAL, 0.1),
           "lean": Prior(HALF, 1.0)}, ("accel_bias",))
def _gyro_bias(p: dict[str, float], sim: str, real: str) -> str:
    tilt = 1000 * p.get("lean", 0.0) * float(np.hypot(p["bx"], p["by"]))
    lean = (f", and the attitude estimate leans {tilt:.0f} mrad with it (gravity correction "
            f"time {p['lean']:.2g} s; the accelerometer shows it against the velocity)"
            if tilt >= 1.0 else "")
    return (f"the gyro reads ({1000 * p['bx']:+.0f}, {1000 * p['by']:+.0f}, "
            f"{1000 * p['bz']:+.0f}) mrad/s the attitude does not follow{lean} (gyro bias)")


@_declare("accel_bias", "accelerometer bias",
          {"bx": Prior(NORMAL, 0.75), "by": Prior(NORMAL, 0.75), "bz": Prior(NORMAL, 0.75)},
          ("gyro_bias",))
def _accel_bias(p: dict[str, float], sim: str, real: str) -> str:
    return (f"the accelerometer reads ({p['bx']:+.2f}, {p['by']:+.2f}, {p['bz']:+.2f}) "
            "m/s² the velocity does not follow (accelerometer bias)")


@_declare("yaw_torque_scale", "yaw torque scale", {"scale": Prior(LN, 0.3)},
          ("rotor_inertia",))
def _yaw_torque_scale(p: dict[str, float], sim: str, real: str) -> str:
    return f"×{p['scale']:.3g} yaw torque at the same command (yaw torque scale)"


@_declare("rotor_inertia", "rotor inertia",
          {"scale": Prior(LN, 0.7), "added": Prior(HALF, 5.0)}, ("yaw_torque_scale",))
def _rotor_inertia(p: dict[str, float], sim: str, real: str) -> str:
    if "added" in p:
        return (f"a yaw spin-up torque of {p['added']:+.2g} rad/s² per unit rotor-speed rate "
                f"that {sim} lacks (rotor inertia)")
    return (f"×{p['scale']:.3g} the rotors' spin-up torque in yaw (rotor inertia "
            f"{p['scale']:.3g}× SIM's)")


@_declare("rotor_twist", "rotors twisted on their arms",
          {"yaw": Prior(NORMAL, 25.0)}, ("weak_motor", "torque_offset"))
def _rotor_twist(p: dict[str, float], sim: str, real: str) -> str:
    sense = "nose right (clockwise from above)" if p["yaw"] > 0 else "nose left"
    return (f"a yaw acceleration of {abs(p['yaw']):.2g} rad/s² {sense} at hover thrust, in "
            f"proportion to the thrust: rotor axes twisted about their arms in one sense "
            f"(rotors twisted on their arms)")


@_declare("rate_damping", "rate damping",
          {"damping": Prior(NORMAL, 5.0), "yaw": Prior(NORMAL, 5.0)}, ("inertia_scale",))
def _rate_damping(p: dict[str, float], sim: str, real: str) -> str:
    return (f"roll and pitch rates damped by {p['damping']:+.2g} 1/s, yaw rate by "
            f"{p['yaw']:+.2g} 1/s more than in {sim} (rate damping)")


@_declare("wind", "wind",
          {"north": Prior(NORMAL, 4.0), "east": Prior(NORMAL, 4.0), "lift": Prior(HALF, 0.005)},
          ("rotor_drag",))
def _wind(p: dict[str, float], sim: str, real: str) -> str:
    speed = float(np.hypot(p["north"], p["east"]))
    towards = float(np.degrees(np.arctan2(p["east"], p["north"]))) % 360.0
    return (f"a steady wind of {speed:.1f} m/s blowing towards {towards:.0f}° "
            "(from north, clockwise; wind)")


@_declare("weak_motor", "weak motor",
          {"scale": Prior(LN, 0.2), "torque_per_thrust": Prior(LN, 0.2)},
          ("torque_offset", "rotor_twist"))
def _weak_motor(p: dict[str, float], sim: str, real: str) -> str:
    ratio = p.get("torque_per_thrust", 1.0)
    own = (f", and ×{ratio:.3g} its reaction torque per unit thrust"
           if abs(ratio - 1.0) > 0.005 else "")
    return (f"motor {p['motor']:.0f} gives ×{p['scale']:.3g} the thrust of the others at "
            f"the same command{own} (weak motor)")


REGISTRY: tuple[Effect, ...] = tuple(_DECLARED)
"""Every effect, in declaration order (the order of gap.json's enum and the docs table)."""

UNEXPLAINED = "unexplained"
"""Not an effect: structure found that no effect explains."""


def vocabulary() -> tuple[str, ...]:
    """Every name a gap.json effect may carry (the registry's, then ``unexplained``)."""
    return (*(e.name for e in REGISTRY), UNEXPLAINED)


def effect(name: str) -> Effect:
    """The registry entry of ``name`` (KeyError if none)."""
    for e in REGISTRY:
        if e.name == name:
            return e
    raise KeyError(name)


def docs_table() -> str:
    """docs/gap.md's vocabulary table (Markdown), generated from the registry."""
    rows = ["| name | what | channels | parameters (prior) | look-alikes |",
            "|---|---|---|---|---|"]
    for e in REGISTRY:
        params = sorted({(p.name, p.unit) for c in e.forms for p in c.params})
        text = ", ".join(f"{n} [{u}] ({e.priors[n].kind} {e.priors[n].width:g})"
                         for n, u in params)
        rows.append(f"| `{e.name}` | {e.words} | {', '.join(e.channels)} | {text} | "
                    f"{', '.join(e.family) or '–'} |")
    return "\n".join(rows)
