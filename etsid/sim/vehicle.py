"""Vehicle description: a TOML file turned into a validated, immutable :class:`Vehicle`.

The packaged vehicles live in ``etsid/sim/vehicles/`` (``tarot680`` is the default
hexacopter, ``quad250`` a small quadrotor); any other TOML file with the same
fields can be given by path. Every field, unit and source is listed in
docs/physics.md.
"""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from etsid.errors import SimError

VEHICLE_DIR = Path(__file__).parent / "vehicles"
DEFAULT_VEHICLE = "tarot680"
GROUND_MODELS = ("cheeseman-bennett", "sanchez-cuevas")

# kind of each field: "pos" > 0, "nonneg" >= 0, "real", "int", "bool", "str",
# "vec3pos"/"vec3nonneg" (three numbers), "ratio" in (0, 1], "angles", "spin", "ground_model"
_SCHEMA: dict[str, dict[str, str]] = {
    "": {"name": "str", "mass": "pos"},
    "inertia": {
        "ixx": "pos", "iyy": "pos", "izz": "pos", "ixy": "real", "ixz": "real", "iyz": "real",
    },
    "frame": {"arm_length": "pos", "hub_z": "real", "angles_deg": "angles", "spin": "spin"},
    "rotor": {
        "radius": "pos", "blades": "int", "chord": "pos", "lift_slope": "pos",
        "theta_75": "pos", "twist": "real", "cd0": "nonneg", "kappa": "pos", "inertia": "nonneg",
    },
    "motor": {"omega_max": "pos", "omega_idle": "nonneg", "time_constant": "pos", "v_ref": "pos"},
    "battery": {
        "cells": "int", "capacity_ah": "pos", "r_internal": "nonneg", "soc0": "ratio",
        "efficiency": "ratio", "sag": "bool",
    },
    "drag": {"linear": "vec3nonneg", "quadratic": "vec3nonneg", "rotor_drag": "nonneg"},
    "ground": {
        "model": "ground_model", "k_body": "nonneg", "max_ratio": "pos",
        "min_height_ratio": "pos", "gear_height": "nonneg", "contact_stiffness": "pos",
        "contact_damping": "nonneg",
    },
    "controller": {
        "rate_kp": "vec3nonneg", "rate_ki": "vec3nonneg", "rate_kd": "vec3nonneg",
        "dterm_cutoff_hz": "pos", "angle_kp": "pos", "max_tilt_deg": "pos",
        "max_rate_deg": "pos", "max_yaw_rate_deg": "pos", "yaw_mix_limit": "ratio",
        "alt_kp": "pos", "vz_kp": "pos", "vz_ki": "nonneg", "max_climb": "pos",
    },
    "sensors": {
        "gyro_std": "nonneg", "gyro_bias_std": "nonneg", "accel_std": "nonneg",
        "att_std": "nonneg", "vel_std": "nonneg", "alt_std": "nonneg", "vbat_std": "nonneg",
        "rangefinder_hz": "pos",
    },
    "environment": {"air_density": "pos", "gravity": "pos"},
}

ESTIMATORS = ("none", "mahony")

# [effects]: optional physical effects, every one off by default (a vehicle file without the
# section flies exactly as before). kind as above plus "vec3" (three numbers of any sign),
# "lag" (two positive time constants), "scale3" (one positive number or three), "estimator";
# None as default means "not set" (motor_lag: motor.time_constant both ways; gyro_bias:
# drawn per flight from sensors.gyro_bias_std). Units and equations: docs/physics.md.
EFFECTS: dict[str, tuple[str, Any]] = {
    "time_delay": ("nonneg", 0.0),             # s, command -> motor transport delay
    "motor_lag": ("lag", None),                # [spin-up, spin-down] time constants, s
    "thrust_scale": ("pos", 1.0),              # multiplier on every rotor's thrust
    "torque_scale": ("pos", 1.0),              # multiplier on every rotor's reaction torque
    "cg_offset": ("vec3", [0.0, 0.0, 0.0]),    # m, CG position from the geometric centre, FRD
    "torque_offset": ("vec3", [0.0, 0.0, 0.0]),  # N m, constant body moment, FRD
    "inertia_scale": ("scale3", 1.0),          # multiplier on the inertia tensor (or per axis)
    "gyro_bias": ("vec3", None),               # rad/s, exact constant gyro bias
    "accel_bias": ("vec3", [0.0, 0.0, 0.0]),   # m/s^2, constant accelerometer bias
    "estimator": ("estimator", "none"),        # "none": truth + noise; "mahony": filter
    "estimator_kp": ("pos", 0.2),              # rad/s per unit error (tilt and heading)
    "estimator_ki": ("nonneg", 0.05),          # rad/s^2 per unit error (gyro-bias learning)
    "ground_effect_torque": ("bool", False),   # reaction torque follows the IGE inflow
    "weak_motor": ("weak", None),              # [rotor (1-based), thrust/torque multiplier]
}


@dataclass(frozen=True)
class Vehicle:
    """A multirotor: mass properties, rotor blade data, motors, battery, controller gains.

    Parameters are grouped as in the TOML file; ``params[section][field]`` holds the
    validated values (SI units: kg, m, s, rad, N, V, A h). Derived geometry is
    available as properties.

    Examples
    --------
    >>> v = load_vehicle("quad250")
    >>> v.n_rotors, round(v.rotor_area, 5)
    (4, 0.01267)
    """

    name: str
    description: str
    source: str
    params: dict[str, dict[str, Any]] = field(repr=False)

    def __getitem__(self, section: str) -> dict[str, Any]:
        return self.params[section]

    @property
    def effects(self) -> dict[str, Any]:
        """The optional effects (``[effects]``), every key present, defaults filled in."""
        return self.params["effects"]

    def to_dict(self) -> dict[str, Any]:
        """The vehicle as a TOML-like dict (``vehicle_from_dict(v.to_dict())`` rebuilds it)."""
        data: dict[str, Any] = copy.deepcopy(self.params[""])
        data["description"] = self.description
        for section, values in self.params.items():
            if section and section != "effects":
                data[section] = copy.deepcopy(values)
        data["effects"] = {k: copy.deepcopy(v) for k, v in self.params["effects"].items()
                           if v is not None}
        return data

    def with_settings(self, settings: dict[str, Any]) -> Vehicle:
        """A copy with some fields changed, validated like a vehicle file.

        Parameters
        ----------
        settings : dict
            ``{key: value}`` with keys ``mass``, ``SECTION.FIELD`` (``rotor.radius``,
            ``motor.time_constant`` …), an effect name (``thrust_scale``, ``time_delay``,
            ``gyro_bias`` … or ``effects.NAME``) or ``battery_sag`` (= ``battery.sag``).

        Raises
        ------
        SimError
            Unknown key or invalid value (one line naming the key).

        Examples
        --------
        >>> v = load_vehicle("tarot680").with_settings({"thrust_scale": 1.1, "mass": 4.5})
        >>> v.effects["thrust_scale"], v.mass
        (1.1, 4.5)
        """
        data = self.to_dict()
        for key, value in settings.items():
            section, name = resolve_vehicle_key(key)
            table = data if section == "" else data.setdefault(section, {})
            table[name] = value
        return vehicle_from_dict(data, f"{self.source} with settings")

    @property
    def mass(self) -> float:
        """Take-off mass, kg."""
        return float(self.params[""]["mass"])

    @property
    def n_rotors(self) -> int:
        """Number of rotors."""
        return len(self.params["frame"]["angles_deg"])

    @property
    def rotor_area(self) -> float:
        """Disc area of one rotor, m²."""
        return math.pi * self.params["rotor"]["radius"] ** 2

    @property
    def solidity(self) -> float:
        """Rotor solidity σ = N_b c / (π R), dimensionless."""
        r = self.params["rotor"]
        return r["blades"] * r["chord"] / (math.pi * r["radius"])

    @property
    def theta_0(self) -> float:
        """Blade pitch extrapolated to the rotor axis, rad (θ = θ_0 + θ_tw r/R)."""
        r = self.params["rotor"]
        return r["theta_75"] - 0.75 * r["twist"]

    @property
    def inertia(self) -> np.ndarray:
        """Full 3×3 inertia tensor about the CG in body FRD, kg m²."""
        i = self.params["inertia"]
        return np.array(
            [
                [i["ixx"], -i["ixy"], -i["ixz"]],
                [-i["ixy"], i["iyy"], -i["iyz"]],
                [-i["ixz"], -i["iyz"], i["izz"]],
            ]
        )

    @property
    def rotor_positions(self) -> np.ndarray:
        """Rotor hub positions in body FRD, shape (N, 3), m."""
        f = self.params["frame"]
        a = np.radians(np.asarray(f["angles_deg"], dtype=float))
        arm = f["arm_length"]
        return np.column_stack([arm * np.cos(a), arm * np.sin(a), np.full(a.size, f["hub_z"])])

    @property
    def spin(self) -> np.ndarray:
        """Spin direction per rotor: +1 counter-clockwise seen from above, −1 clockwise."""
        return np.array([1.0 if s == "ccw" else -1.0 for s in self.params["frame"]["spin"]])

    @property
    def mixer(self) -> np.ndarray:
        """Mixer matrix (N, 4): columns thrust, roll, pitch, yaw contributions per motor."""
        pos = self.rotor_positions
        roll = -pos[:, 1] / np.max(np.abs(pos[:, 1]))
        pitch = pos[:, 0] / np.max(np.abs(pos[:, 0]))
        return np.column_stack([np.ones(self.n_rotors), roll, pitch, self.spin])


def resolve_vehicle_key(key: str) -> tuple[str, str]:
    """``(section, field)`` of a vehicle setting key (see :meth:`Vehicle.with_settings`).

    Raises
    ------
    SimError
        The key names no vehicle field or effect.
    """
    if key in EFFECTS:
        return "effects", key
    if key == "battery_sag":
        return "battery", "sag"
    if key in _SCHEMA[""]:
        return "", key
    section, _, name = key.partition(".")
    if section == "effects" and name in EFFECTS:
        return section, name
    if section in _SCHEMA and section and name in _SCHEMA[section]:
        return section, name
    raise SimError(f"unknown vehicle setting {key!r}: give an effect ({', '.join(EFFECTS)}), "
                   "battery_sag, mass or SECTION.FIELD of the vehicle file (e.g. rotor.radius)")


def _fail(path: str, name: str, what: str, value: Any) -> SimError:
    return SimError(f"{path}: field '{name}' {what}, got {value!r}")


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check(path: str, name: str, kind: str, value: Any, n_rotors: int | None) -> Any:
    if kind == "str":
        if not isinstance(value, str) or not value:
            raise _fail(path, name, "must be a non-empty string", value)
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise _fail(path, name, "must be true or false", value)
        return value
    if kind == "int":
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise _fail(path, name, "must be a positive integer", value)
        return value
    if kind == "ground_model":
        if value not in GROUND_MODELS:
            raise _fail(path, name, f"must be one of {', '.join(GROUND_MODELS)}", value)
        return value
    if kind == "estimator":
        if value not in ESTIMATORS:
            raise _fail(path, name, f"must be one of {', '.join(ESTIMATORS)}", value)
        return value
    if kind == "vec3":
        if not (isinstance(value, list) and len(value) == 3 and all(_number(v) for v in value)):
            raise _fail(path, name, "must be a list of three numbers", value)
        return [float(v) for v in value]
    if kind == "lag":
        ok = isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value)
        if not ok or min(value) <= 0:
            raise _fail(path, name, "must be two positive time constants [spin_up, spin_down] "
                        "in s", value)
        return [float(v) for v in value]
    if kind == "weak":
        ok = (isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value)
              and float(value[0]).is_integer() and value[1] > 0)
        if not ok or not 1 <= value[0] <= (n_rotors or 99):
            raise _fail(path, name, "must be [rotor number 1..N, positive thrust multiplier]",
                        value)
        return [float(value[0]), float(value[1])]
    if kind == "scale3":
        if isinstance(value, list):
            ok = len(value) == 3 and all(_number(v) for v in value)
            if not ok or min(value) <= 0:
                raise _fail(path, name, "must be a positive number or three", value)
            return [float(v) for v in value]
        if not _number(value) or value <= 0:
            raise _fail(path, name, "must be a positive number or three", value)
        return float(value)
    if kind.startswith("vec3"):
        ok = isinstance(value, list) and len(value) == 3 and all(_number(v) for v in value)
        if not ok or min(value) < 0:
            raise _fail(path, name, "must be a list of three non-negative numbers", value)
        return [float(v) for v in value]
    if kind == "angles":
        if not isinstance(value, list) or len(value) < 3 or not all(_number(v) for v in value):
            raise _fail(path, name, "must be a list of at least three angles in degrees", value)
        return [float(v) for v in value]
    if kind == "spin":
        ok = isinstance(value, list) and all(v in ("cw", "ccw") for v in value)
        if not ok or len(value) != n_rotors:
            raise _fail(path, name, f"must list 'cw' or 'ccw' for each of {n_rotors} rotors", value)
        return list(value)
    if not _number(value):
        raise _fail(path, name, "must be a number", value)
    value = float(value)
    if kind == "pos" and value <= 0:
        raise _fail(path, name, "must be positive", value)
    if kind == "nonneg" and value < 0:
        raise _fail(path, name, "must not be negative", value)
    if kind == "ratio" and not 0 < value <= 1:
        raise _fail(path, name, "must lie in (0, 1]", value)
    return value


def vehicle_from_dict(data: dict[str, Any], source: str = "<dict>") -> Vehicle:
    """Validate a parsed vehicle description and build a :class:`Vehicle`.

    Parameters
    ----------
    data : dict
        Content of a vehicle TOML file.
    source : str
        File name used in error messages.

    Raises
    ------
    SimError
        A field is missing, has the wrong type or an invalid value; the message names
        ``source`` and the dotted field name.
    """
    params: dict[str, dict[str, Any]] = {}
    n_rotors: int | None = None
    for section, fields in _SCHEMA.items():
        table = data if section == "" else data.get(section)
        if not isinstance(table, dict):
            raise SimError(f"{source}: section [{section}] is missing or not a table")
        params[section] = {}
        for name, kind in fields.items():
            dotted = f"{section}.{name}" if section else name
            if name not in table:
                raise SimError(f"{source}: field '{dotted}' is missing")
            params[section][name] = _check(source, dotted, kind, table[name], n_rotors)
            if kind == "angles":
                n_rotors = len(params[section][name])
    effects = data.get("effects", {})
    if not isinstance(effects, dict):
        raise SimError(f"{source}: section [effects] is not a table")
    unknown = sorted(set(effects) - set(EFFECTS))
    if unknown:
        raise SimError(f"{source}: unknown field(s) [effects] {', '.join(unknown)}; known: "
                       f"{', '.join(sorted(EFFECTS))}")
    params["effects"] = {}
    for name, (kind, default) in EFFECTS.items():
        value = copy.deepcopy(effects.get(name, default))
        if name in effects:
            value = _check(source, f"effects.{name}", kind, value, n_rotors)
        params["effects"][name] = value
    for section, fields in _SCHEMA.items():  # a typo must not silently be ignored
        table = data if section == "" else data[section]
        known = set(fields) | ({"description", "effects"} | set(_SCHEMA) if not section
                               else set())
        unknown = sorted(set(table) - known)
        if unknown:
            where = f"[{section}] " if section else ""
            raise SimError(f"{source}: unknown field(s) {where}{', '.join(unknown)}; known: "
                           f"{', '.join(sorted(fields))}")
    g = params["ground"]
    if g["max_ratio"] <= 1.0:
        raise _fail(source, "ground.max_ratio", "must be greater than 1", g["max_ratio"])
    m = params["motor"]
    if m["omega_idle"] >= m["omega_max"]:
        raise _fail(source, "motor.omega_idle", "must be below motor.omega_max", m["omega_idle"])
    desc = data.get("description", "")
    return Vehicle(name=params[""]["name"], description=str(desc), source=source, params=params)


def load_vehicle(vehicle: str | Path | Vehicle | None = None) -> Vehicle:
    """Load a vehicle by packaged name (``"tarot680"``, ``"quad250"``) or TOML path.

    Parameters
    ----------
    vehicle : str, Path, Vehicle or None
        None gives the default hexacopter ``tarot680``; a :class:`Vehicle` is returned as is.

    Returns
    -------
    Vehicle
        The validated vehicle.

    Raises
    ------
    SimError
        Unknown name, unreadable file, invalid TOML or an invalid field.
    """
    if isinstance(vehicle, Vehicle):
        return vehicle
    if vehicle is None:
        vehicle = DEFAULT_VEHICLE
    path = Path(vehicle)
    if path.suffix != ".toml" and not path.exists():
        path = VEHICLE_DIR / f"{vehicle}.toml"
        if not path.exists():
            known = ", ".join(sorted(p.stem for p in VEHICLE_DIR.glob("*.toml")))
            raise SimError(f"unknown vehicle {str(vehicle)!r}: give a TOML file or one of {known}")
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except OSError as err:
        raise SimError(f"{path}: cannot read vehicle file ({err.strerror})") from err
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise SimError(f"{path}: invalid TOML ({err})") from err
    return vehicle_from_dict(data, str(path))


def list_vehicles() -> list[str]:
    """Names of the packaged vehicles."""
    return sorted(p.stem for p in VEHICLE_DIR.glob("*.toml"))
