"""One declaration of every simulator setting: its kind, unit and physical range.

The vehicle loader (:mod:`etsid.sim.vehicle`), ``--set vehicle.*`` / ``--set scenario.*``,
the CLI options that set the same quantities (``--duration``, ``--rate``) and ``etsid fit``
(which writes vehicle files) all read this module; nothing else states a range.

A range is what a multirotor can physically be, from a 20 g micro quad to a 200 kg
heavy-lift octocopter, with room on both sides; it is not a plausibility judgement. Its job
is that every value the simulator accepts gives finite physics at the step it integrates
with (a 1e-300 s motor constant or 10⁴ rotors are refused here, with the field named).
Units are SI (kg, m, s, rad/s, V, A h) except where the field name says otherwise
(``_deg``, ``_hz``). The numbers are in docs/physics.md ("Ranges").

This module imports nothing heavy (no numpy): ``etsid fit`` and the CLI read it cheaply.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

MAX_ROTORS = 16
"""Most rotors a vehicle may have (an octocopter coaxial X8 has 8; 16 leaves room)."""
MIN_ROTORS = 3


@dataclass(frozen=True)
class Param:
    """One setting: its kind (how the value is shaped), unit and closed range.

    ``kind``: ``"num"`` a number; ``"int"`` an integer; ``"bool"``; ``"str"``; ``"choice"``
    one of ``choices``; ``"vec3"`` three numbers; ``"pair"`` two numbers; ``"scale3"`` one
    number or three; ``"angles"`` rotor arm angles (``MIN_ROTORS``…``MAX_ROTORS`` of them);
    ``"spin"`` ``cw``/``ccw`` per rotor; ``"weak"`` ``[rotor number, multiplier]``.
    ``low``/``high`` bound every number of the value (``low_open``: strictly above
    ``low``). ``default`` is used when an optional setting is absent (``[effects]`` and
    scenario settings); vehicle fields without one are required.
    """

    kind: str
    unit: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    doc: str = ""
    default: Any = None
    choices: tuple[str, ...] = ()
    optional: bool = False

    def describe(self) -> str:
        """The range in words, e.g. ``"in (0, 1000] kg"``."""
        if self.kind in ("str", "bool", "spin"):
            return {"str": "a non-empty string", "bool": "true or false",
                    "spin": "'cw' or 'ccw' per rotor"}[self.kind]
        if self.kind == "choice":
            return f"one of {', '.join(self.choices)}"
        left = "(" if self.low_open else "["
        unit = f" {self.unit}" if self.unit and self.unit != "1" else ""
        return f"in {left}{_fmt(self.low)}, {_fmt(self.high)}]{unit}"


def _fmt(value: float | None) -> str:
    if value is None:
        return "-inf"
    return f"{value:g}"


def _n(unit: str, low: float, high: float, doc: str = "", low_open: bool = False,
       **kw: Any) -> Param:
    return Param("num", unit, low, high, low_open, doc, **kw)


def _pos(unit: str, low: float, high: float, doc: str = "", **kw: Any) -> Param:
    """A positive number: ``low`` > 0 is its smallest physical value."""
    return Param("num", unit, low, high, False, doc, **kw)


VEHICLE: dict[str, dict[str, Param]] = {
    "": {
        "name": Param("str", "", doc="vehicle name"),
        "mass": _pos("kg", 0.005, 500.0, "take-off mass"),
    },
    "inertia": {
        "ixx": _pos("kg m^2", 1e-7, 1e3, "roll moment of inertia about the CG"),
        "iyy": _pos("kg m^2", 1e-7, 1e3, "pitch moment of inertia"),
        "izz": _pos("kg m^2", 1e-7, 1e3, "yaw moment of inertia"),
        "ixy": _n("kg m^2", -1e3, 1e3, "product of inertia"),
        "ixz": _n("kg m^2", -1e3, 1e3, "product of inertia"),
        "iyz": _n("kg m^2", -1e3, 1e3, "product of inertia"),
    },
    "frame": {
        "arm_length": _pos("m", 0.01, 5.0, "CG-to-hub distance"),
        "hub_z": _n("m", -2.0, 2.0, "hub height below the CG (FRD z)"),
        "angles_deg": Param("angles", "deg", -360.0, 360.0,
                            doc="arm angle of each rotor from forward, clockwise seen from "
                                "above"),
        "spin": Param("spin", "", doc="spin direction of each rotor"),
    },
    "rotor": {
        "radius": _pos("m", 0.01, 5.0, "rotor radius"),
        "blades": Param("int", "1", 1, 8, doc="blades per rotor"),
        "chord": _pos("m", 0.001, 1.0, "blade chord"),
        "lift_slope": _pos("1/rad", 1.0, 7.0, "blade section lift slope (thin aerofoil: 2 pi)"),
        "theta_75": _n("rad", 0.0, 0.8, "blade pitch at 75 % radius", low_open=True),
        "twist": _n("rad", -1.0, 1.0, "linear blade twist root to tip"),
        "cd0": _n("1", 0.0, 0.2, "blade profile drag coefficient"),
        "kappa": _pos("1", 1.0, 2.0, "induced power factor"),
        "inertia": _n("kg m^2", 0.0, 1.0, "rotor + motor bell inertia about the shaft"),
    },
    "motor": {
        "omega_max": _pos("rad/s", 10.0, 10_000.0, "rotor speed at full command"),
        "omega_idle": _n("rad/s", 0.0, 10_000.0, "rotor speed at zero command"),
        "time_constant": _pos("s", 1e-3, 2.0, "first-order speed time constant"),
        "v_ref": _pos("V", 1.0, 100.0, "battery voltage omega_max is quoted at"),
    },
    "battery": {
        "cells": Param("int", "1", 1, 24, doc="LiPo cells in series"),
        "capacity_ah": _pos("A h", 0.01, 100.0, "capacity"),
        "r_internal": _n("ohm", 0.0, 1.0, "internal resistance"),
        "soc0": _n("1", 0.0, 1.0, "state of charge at take-off", low_open=True),
        "efficiency": _n("1", 0.0, 1.0, "electrical-to-shaft efficiency", low_open=True),
        "sag": Param("bool", "", doc="voltage sag under load on"),
    },
    "drag": {
        "linear": Param("vec3", "N s/m", 0.0, 100.0, doc="linear body drag per axis"),
        "quadratic": Param("vec3", "N s^2/m^2", 0.0, 100.0, doc="quadratic body drag per axis"),
        "rotor_drag": _n("N s/m per rad/s", 0.0, 1.0, "rotor (H-force) drag coefficient"),
    },
    "ground": {
        "model": Param("choice", "", choices=("cheeseman-bennett", "sanchez-cuevas"),
                       doc="ground-effect model"),
        "k_body": _n("1", 0.0, 10.0, "body (fountain) ground-effect factor"),
        "max_ratio": _n("1", 1.0, 10.0, "largest IGE/OGE thrust ratio", low_open=True),
        "min_height_ratio": _pos("1", 0.01, 10.0, "smallest z/R the model is evaluated at"),
        "gear_height": _n("m", 0.0, 5.0, "CG height when standing on the gear"),
        "contact_stiffness": _pos("N/m", 1.0, 1e7, "ground contact spring"),
        "contact_damping": _n("N s/m", 0.0, 1e5, "ground contact damper"),
    },
    "controller": {
        "rate_kp": Param("vec3", "1/(rad/s)", 0.0, 100.0, doc="rate loop P gains"),
        "rate_ki": Param("vec3", "1/rad", 0.0, 100.0, doc="rate loop I gains"),
        "rate_kd": Param("vec3", "s/rad", 0.0, 100.0, doc="rate loop D gains"),
        "dterm_cutoff_hz": _pos("Hz", 0.1, 1000.0, "D-term low-pass cutoff"),
        "angle_kp": _pos("1/s", 1e-3, 100.0, "angle loop P gain"),
        "max_tilt_deg": _pos("deg", 0.1, 89.0, "largest commanded tilt"),
        "max_rate_deg": _pos("deg/s", 0.1, 3600.0, "largest commanded roll/pitch rate"),
        "max_yaw_rate_deg": _pos("deg/s", 0.1, 3600.0, "largest commanded yaw rate"),
        "yaw_mix_limit": _n("1", 0.0, 1.0, "share of the mixer yaw may take", low_open=True),
        "alt_kp": _pos("1/s", 1e-3, 100.0, "altitude P gain"),
        "vz_kp": _pos("1/(m/s)", 1e-4, 100.0, "climb-rate P gain"),
        "vz_ki": _n("1/m", 0.0, 100.0, "climb-rate I gain"),
        "max_climb": _pos("m/s", 0.01, 50.0, "largest commanded climb rate"),
    },
    "sensors": {
        "gyro_std": _n("rad/s", 0.0, 10.0, "gyro white noise"),
        "gyro_bias_std": _n("rad/s", 0.0, 1.0, "spread of the per-flight gyro bias"),
        "accel_std": _n("m/s^2", 0.0, 100.0, "accelerometer white noise"),
        "att_std": _n("rad", 0.0, 1.0, "attitude noise"),
        "vel_std": _n("m/s", 0.0, 100.0, "velocity noise"),
        "alt_std": _n("m", 0.0, 100.0, "altitude noise"),
        "vbat_std": _n("V", 0.0, 10.0, "battery voltage noise"),
        "rangefinder_hz": _pos("Hz", 0.5, 1000.0, "rangefinder sample rate"),
    },
    "environment": {
        "air_density": _pos("kg/m^3", 0.01, 2.0, "air density"),
        "gravity": _pos("m/s^2", 0.1, 30.0, "gravitational acceleration"),
    },
}
"""Every field of a vehicle TOML file, by section (``""``: top level)."""

EFFECTS: dict[str, Param] = {
    "time_delay": _n("s", 0.0, 1.0, "command-to-motor transport delay", default=0.0),
    "motor_lag": Param("pair", "s", 1e-3, 2.0,
                       doc="[spin-up, spin-down] time constants (default: motor.time_constant "
                           "both ways)"),
    "thrust_scale": _pos("1", 0.05, 20.0, "multiplier on every rotor's thrust", default=1.0),
    "torque_scale": _pos("1", 0.05, 20.0, "multiplier on every rotor's reaction torque",
                         default=1.0),
    "cg_offset": Param("vec3", "m", -2.0, 2.0, doc="CG position from the geometric centre, FRD",
                       default=[0.0, 0.0, 0.0]),
    "torque_offset": Param("vec3", "N m", -100.0, 100.0, doc="constant body moment, FRD",
                           default=[0.0, 0.0, 0.0]),
    "inertia_scale": Param("scale3", "1", 0.05, 20.0,
                           doc="multiplier on the inertia tensor (or per axis)", default=1.0),
    "gyro_bias": Param("vec3", "rad/s", -10.0, 10.0,
                       doc="exact constant gyro bias (default: drawn from "
                           "sensors.gyro_bias_std)"),
    "accel_bias": Param("vec3", "m/s^2", -50.0, 50.0, doc="constant accelerometer bias",
                        default=[0.0, 0.0, 0.0]),
    "estimator": Param("choice", "", choices=("none", "mahony"), default="none",
                       doc="'none': truth + noise; 'mahony': complementary filter"),
    "estimator_kp": _pos("rad/s", 1e-4, 100.0, "estimator correction gain", default=0.2),
    "estimator_ki": _n("rad/s^2", 0.0, 100.0, "estimator gyro-bias learning gain",
                       default=0.05),
    "ground_effect_torque": Param("bool", "", default=False,
                                  doc="reaction torque follows the IGE inflow"),
    "rotor_twist": _n("deg", -30.0, 30.0, "every rotor axis twisted about its arm in one "
                      "sense (+: the thrusts' side components yaw the nose right)", default=0.0),
    "weak_motor": Param("weak", "1", 0.0, 20.0, low_open=True,
                        doc="[rotor number 1..N, thrust and torque multiplier]"),
}
"""The optional ``[effects]`` of a vehicle file, each off (neutral) by default."""

SCENARIO: dict[str, Param] = {
    "duration": _n("s", 0.0, 3600.0, "flight time", low_open=True),
    "altitude": _n("m", 0.0, 1000.0, "CG height held", low_open=True),
    "amplitude": _n("1", 0.0, 1.0, "peak roll/pitch stick excitation"),
    "yaw_amplitude": _n("1", 0.0, 1.0, "peak yaw stick excitation"),
    "f_min": _n("Hz", 0.0, 100.0, "lowest excitation frequency", low_open=True),
    "f_max": _n("Hz", 0.0, 500.0, "highest excitation frequency", low_open=True),
    "alt_wander": _n("m", 0.0, 100.0, "altitude-setpoint wander amplitude"),
    "settle": _n("s", 0.0, 3600.0, "quiet flight before the excitation"),
    "throttle": _n("1", 0.0, 1.0, "fixed collective when alt_hold is off"),
    "wind": Param("vec3", "m/s", -50.0, 50.0, doc="constant wind, NED"),
    "alt_amplitude": _n("m", 0.0, 1000.0, "altitude sine amplitude"),
    "alt_period": _n("s", 0.0, 3600.0, "altitude sine period", low_open=True),
    "speed": _n("m/s", 0.0, 50.0, "forward speed target"),
    "ramp": _n("s", 0.0, 3600.0, "time to reach the speed", low_open=True),
    "high_altitudes": Param("list", "m", 0.0, 1000.0, low_open=True,
                            doc="out-of-ground-effect dwell heights"),
    "dwell": _n("s", 0.0, 3600.0, "dwell time per height", low_open=True),
    "transition": _n("s", 0.0, 3600.0, "climb/descent time between dwells", low_open=True),
}
"""Scenario settings with a number in them (``--set scenario.KEY``); ``--duration`` is
``duration``."""

RUN: dict[str, Param] = {
    "rate": _n("Hz", 1.0, 10_000.0, "sensor/table rate"),
    "duration": SCENARIO["duration"],
}
"""Options of ``etsid simulate`` that set the same quantities (the CLI ranges)."""


def is_number(value: Any) -> bool:
    """A finite int or float (not a bool)."""
    return (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value))


def in_range(param: Param, value: float) -> bool:
    """``value`` lies within ``param``'s range."""
    if param.low is not None and (value < param.low or (param.low_open and value == param.low)):
        return False
    return param.high is None or value <= param.high


def check_number(param: Param, value: Any) -> str:
    """What is wrong with ``value`` as a number of ``param`` ("" if nothing)."""
    if not is_number(value):
        return "must be a finite number"
    if not in_range(param, float(value)):
        return f"must lie {param.describe()}"
    return ""


def vehicle_param(section: str, name: str) -> Param:
    """The declaration of vehicle field ``section.name`` (``effects.NAME`` included)."""
    if section == "effects":
        return EFFECTS[name]
    return VEHICLE[section][name]


def hover_geometry_problem(angles_deg: list[float]) -> str:
    """Why rotors at these arm angles cannot hold the CG ("" if they can).

    The CG (the origin) must lie strictly inside the polygon of the rotor hubs, or no
    combination of non-negative thrusts balances roll and pitch: so no gap between
    neighbouring arms may reach 180°. Two rotors may share an arm (a coaxial pair, as on an
    X8 octocopter); three on one arm, or two a fraction of a degree apart, are a typo.

    >>> hover_geometry_problem([45, 45, 315, 315, 225, 225, 135, 135])
    ''
    >>> hover_geometry_problem([45, 45, 45, 315, 225, 135])
    'has more than two rotors on one arm'
    """
    ring = sorted(a % 360.0 for a in angles_deg)
    arms: list[list[float]] = []
    for a in ring:
        if arms and a - arms[-1][0] < 1.0:
            arms[-1].append(a)
        else:
            arms.append([a])
    if len(arms) > 1 and ring[-1] - 360.0 > arms[0][0] - 1.0:   # wrap-around at 0°/360°
        arms[0] += arms.pop()
    if any(len(arm) > 2 for arm in arms):
        return "has more than two rotors on one arm"
    if any(len(arm) == 2 and abs(arm[1] - arm[0]) % 360.0 > 1e-6 for arm in arms):
        return "has two rotors within 1° of each other (a coaxial pair shares one angle)"
    ring = [arm[0] for arm in arms]
    if len(ring) < 3:
        return "has fewer than three arms: the CG is not inside the rotors"
    gaps = [b - a for a, b in itertools.pairwise(ring)] + [ring[0] + 360.0 - ring[-1]]
    if max(gaps) >= 180.0:
        return (f"leaves a gap of {max(gaps):.0f}° between neighbouring arms: the CG is not "
                "inside the rotors, the vehicle cannot hover")
    return ""


def ranges_markdown() -> str:
    """The ranges as a Markdown table (docs/physics.md, "Ranges", shows this output)."""
    rows = ["| setting | unit | range | meaning |", "|---|---|---|---|"]
    every = [(f"{s}.{n}" if s else n, p) for s, fields in VEHICLE.items()
             for n, p in fields.items()]
    every += [(f"effects.{n}", p) for n, p in EFFECTS.items()]
    every += [(f"scenario.{n}", p) for n, p in SCENARIO.items()]
    for name, p in every:
        shown = p.describe().removesuffix(f" {p.unit}")
        if p.kind == "angles":
            shown = f"{MIN_ROTORS} to {MAX_ROTORS} angles {shown}; CG inside the rotors"
        rows.append(f"| `{name}` | {p.unit if p.unit not in ('', '1') else '–'} | "
                    f"{shown.removeprefix('in ')} | {p.doc} |")
    return "\n".join(rows)
