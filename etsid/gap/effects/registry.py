"""The registry: every vocabulary effect declared once (forms from the law library of
:mod:`etsid.gap.candidates`, priors, words, look-alikes)."""

from __future__ import annotations

from etsid.gap.candidates import LIBRARY
from etsid.gap.effects.base import Effect, Prior

LN = "lognormal"
HALF = "halfnormal"
NORMAL = "normal"


def _forms(name: str) -> tuple:
    return tuple(c for c in LIBRARY if c.name == name)


def _effect(name: str, words: str, priors: dict[str, Prior],
            family: tuple[str, ...] = ()) -> Effect:
    return Effect(name, words, _forms(name), priors, family)


# Prior widths: a scale's log-normal width is the spread of that quantity between two
# builds of one airframe (±20 % thrust, ±30 % inertia); an offset's width is a quarter of
# its search bound; a delay's or lag's half-normal width is a typical logging/ESC latency.
REGISTRY: tuple[Effect, ...] = (
    _effect("ground_effect", "ground effect",
            {"R": Prior(HALF, 0.5), "exponent": Prior(LN, 0.5), "excess": Prior(HALF, 0.3),
             "decay": Prior(HALF, 0.5), "arm": Prior(HALF, 0.5)}),
    _effect("rotor_drag", "rotor drag",
            {"drag": Prior(HALF, 0.5), "moment": Prior(NORMAL, 1.0)}, ("wind",)),
    _effect("motor_lag", "motor lag", {"tau": Prior(LN, 1.0)}, ("time_delay",)),
    _effect("time_delay", "time delay", {"delay": Prior(HALF, 0.04)}, ("motor_lag",)),
    _effect("battery_sag", "battery sag", {"exponent": Prior(HALF, 2.0)}, ("thrust_scale",)),
    _effect("thrust_scale", "thrust scale", {"scale": Prior(LN, 0.2)},
            ("mass", "battery_sag")),
    _effect("mass", "mass (payload)", {"ratio": Prior(LN, 0.2)}, ("thrust_scale",)),
    _effect("inertia_scale", "inertia scale", {"scale": Prior(LN, 0.3)}, ("rate_damping",)),
    _effect("torque_offset", "torque offset",
            {"p_offset": Prior(NORMAL, 5.0), "q_offset": Prior(NORMAL, 5.0),
             "r_offset": Prior(NORMAL, 5.0)}, ("weak_motor",)),
    _effect("gyro_bias", "gyro bias",
            {"bx": Prior(NORMAL, 0.1), "by": Prior(NORMAL, 0.1), "bz": Prior(NORMAL, 0.1),
             "lean": Prior(HALF, 1.0)}, ("accel_bias",)),
    _effect("accel_bias", "accelerometer bias",
            {"bx": Prior(NORMAL, 0.75), "by": Prior(NORMAL, 0.75), "bz": Prior(NORMAL, 0.75)},
            ("gyro_bias",)),
    _effect("yaw_torque_scale", "yaw torque scale", {"scale": Prior(LN, 0.3)},
            ("rotor_inertia",)),
    _effect("rotor_inertia", "rotor inertia",
            {"scale": Prior(LN, 0.7), "added": Prior(HALF, 5.0)}, ("yaw_torque_scale",)),
    _effect("rate_damping", "rate damping",
            {"damping": Prior(NORMAL, 5.0), "yaw": Prior(NORMAL, 5.0)}, ("inertia_scale",)),
    _effect("wind", "wind",
            {"north": Prior(NORMAL, 4.0), "east": Prior(NORMAL, 4.0),
             "lift": Prior(HALF, 0.005)}, ("rotor_drag",)),
    _effect("weak_motor", "weak motor",
            {"scale": Prior(LN, 0.2), "torque_scale": Prior(LN, 0.2)}, ("torque_offset",)),
)

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
