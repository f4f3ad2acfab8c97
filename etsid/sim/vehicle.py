"""Vehicle description: a TOML file turned into a validated, immutable :class:`Vehicle`.

The packaged vehicles live in ``etsid/sim/vehicles/`` (``tarot680`` is the default
hexacopter, ``quad250`` a small quadrotor); any other TOML file with the same
fields can be given by path. Every field, unit and source is listed in
docs/physics.md.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from etsid.errors import SimError
from etsid.escape import clean
from etsid.files import read_toml
from etsid.sim.vehicle_params import EFFECTS as EFFECT_PARAMS
from etsid.sim.vehicle_params import (
    MAX_ROTORS,
    MIN_ROTORS,
    VEHICLE,
    Param,
    check_number,
    hover_geometry_problem,
    is_number,
)

VEHICLE_DIR = Path(__file__).parent / "vehicles"
DEFAULT_VEHICLE = "tarot680"
GROUND_MODELS = VEHICLE["ground"]["model"].choices

# every field, its unit and physical range: one declaration (etsid/sim/vehicle_params.py)
_SCHEMA: dict[str, dict[str, Param]] = VEHICLE
ESTIMATORS = EFFECT_PARAMS["estimator"].choices

# [effects]: optional physical effects, every one off by default (a vehicle file without the
# section flies exactly as before); None as default means "not set" (motor_lag:
# motor.time_constant both ways; gyro_bias: drawn per flight from sensors.gyro_bias_std).
# Units and equations: docs/physics.md; kinds and ranges: etsid/sim/vehicle_params.py.
EFFECTS: dict[str, tuple[str, Any]] = {name: (p.kind, p.default)
                                       for name, p in EFFECT_PARAMS.items()}


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


def _numbers(path: str, name: str, param: Param, values: list[Any], what: str) -> list[float]:
    for v in values:
        wrong = check_number(param, v)
        if wrong:
            raise _fail(path, name, f"{what}: each {wrong}", v if len(values) > 1 else values)
    return [float(v) for v in values]


def _check(path: str, name: str, param: Param, value: Any, n_rotors: int | None) -> Any:
    """``value`` of field ``name`` checked against its declaration (kind and range)."""
    kind = param.kind
    if kind == "str":
        if not isinstance(value, str) or not value or len(value) > 200:
            raise _fail(path, name, "must be a non-empty string of at most 200 characters",
                        value if not isinstance(value, str) else value[:40])
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise _fail(path, name, "must be true or false", value)
        return value
    if kind == "choice":
        if value not in param.choices:
            raise _fail(path, name, f"must be {param.describe()}", value)
        return value
    if kind == "int":
        if not isinstance(value, int) or isinstance(value, bool):
            raise _fail(path, name, "must be an integer", value)
        wrong = check_number(param, value)
        if wrong:
            raise _fail(path, name, wrong, value)
        return value
    if kind in ("vec3", "pair"):
        size, word = (3, "three") if kind == "vec3" else (2, "two")
        if not (isinstance(value, list) and len(value) == size):
            raise _fail(path, name, f"must be a list of {word} numbers", value)
        return _numbers(path, name, param, value, f"{word} numbers {param.describe()}")
    if kind == "weak":
        ok = (isinstance(value, list) and len(value) == 2 and all(is_number(v) for v in value)
              and float(value[0]).is_integer() and 1 <= value[0] <= (n_rotors or MAX_ROTORS))
        if not ok or check_number(param, value[1]):
            raise _fail(path, name, "must be [rotor number 1..N, thrust multiplier "
                        f"{param.describe()}]", value)
        return [float(value[0]), float(value[1])]
    if kind == "scale3":
        if isinstance(value, list):
            if len(value) != 3:
                raise _fail(path, name, "must be one number or three", value)
            return _numbers(path, name, param, value, f"three numbers {param.describe()}")
        wrong = check_number(param, value)
        if wrong:
            raise _fail(path, name, wrong, value)
        return float(value)
    if kind == "angles":
        if (not isinstance(value, list) or not MIN_ROTORS <= len(value) <= MAX_ROTORS
                or not all(is_number(v) for v in value)):
            shown = value if not isinstance(value, list) else f"a list of {len(value)}"
            raise _fail(path, name, f"must be a list of {MIN_ROTORS} to {MAX_ROTORS} angles in "
                        "degrees", shown)
        angles = _numbers(path, name, param, value, f"angles {param.describe()}")
        problem = hover_geometry_problem(angles)
        if problem:
            raise _fail(path, name, problem, value)
        return angles
    if kind == "spin":
        ok = isinstance(value, list) and all(v in ("cw", "ccw") for v in value)
        if not ok or len(value) != n_rotors:
            raise _fail(path, name, f"must list 'cw' or 'ccw' for each of {n_rotors} rotors", value)
        return list(value)
    wrong = check_number(param, value)
    if wrong:
        raise _fail(path, name, wrong, value)
    return float(value)


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
        for name, param in fields.items():
            dotted = f"{section}.{name}" if section else name
            if name not in table:
                raise SimError(f"{source}: field '{dotted}' is missing")
            params[section][name] = _check(source, dotted, param, table[name], n_rotors)
            if param.kind == "angles":
                n_rotors = len(params[section][name])
    effects = data.get("effects", {})
    if not isinstance(effects, dict):
        raise SimError(f"{source}: section [effects] is not a table")
    unknown = sorted(set(effects) - set(EFFECTS))
    if unknown:
        raise SimError(f"{source}: unknown field(s) [effects] {', '.join(unknown)}; known: "
                       f"{', '.join(sorted(EFFECTS))}")
    params["effects"] = {}
    for name, param in EFFECT_PARAMS.items():
        value = copy.deepcopy(effects.get(name, param.default))
        if name in effects:
            value = _check(source, f"effects.{name}", param, value, n_rotors)
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
    i = params["inertia"]
    tensor = np.array([[i["ixx"], -i["ixy"], -i["ixz"]], [-i["ixy"], i["iyy"], -i["iyz"]],
                       [-i["ixz"], -i["iyz"], i["izz"]]])
    moments = np.linalg.eigvalsh(tensor)
    if moments[0] <= 0 or 2 * moments.max() > moments.sum() * (1 + 1e-9):
        raise SimError(f"{source}: [inertia] is not the inertia of a rigid body (principal "
                       f"moments {', '.join(f'{m:.3g}' for m in moments)} kg m^2: each must be "
                       "positive and none larger than the sum of the other two)")
    desc = data.get("description", "")
    if not isinstance(desc, str) or len(desc) > 2000:
        raise SimError(f"{source}: field 'description' must be a string of at most 2000 "
                       "characters")
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
    data = read_toml(path, "vehicle", SimError, "TOML vehicle file")
    return vehicle_from_dict(clean(data), str(path))


def list_vehicles() -> list[str]:
    """Names of the packaged vehicles."""
    return sorted(p.stem for p in VEHICLE_DIR.glob("*.toml"))
