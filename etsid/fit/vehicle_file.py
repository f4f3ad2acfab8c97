"""A fitted airframe as a vehicle file of the simulator's own schema.

The template vehicle (a packaged one) supplies every field a log cannot determine; the
fitted combinations are turned into the schema's fields with the declared mass, arm and
rotor torque ratio (:func:`build_vehicle`). Every field's range is the simulator's one
declaration (:mod:`etsid.sim.vehicle_params`); the result is validated by loading it back
with the simulator's own loader (:func:`etsid.sim.vehicle.vehicle_from_dict`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from etsid.fit.truth import effectiveness, vehicle_truth
from etsid.sim.vehicle import Vehicle, vehicle_from_dict
from etsid.sim.vehicle_params import in_range, is_number, vehicle_param


def build_vehicle(template: Vehicle, values: dict[str, float], layout: dict[str, Any],
                  v0: float, name: str, description: str,
                  notes: list[str] | None = None) -> Vehicle:
    """The simulator vehicle with the fitted ``values`` (keys of
    :func:`etsid.fit.truth.vehicle_truth`; absent ones keep the template's).

    Declared (not from the log): the template's mass, its rotor blades and their torque per
    thrust (so Izz follows from the yaw effectiveness), the arm where the log has no
    geometry, the rotors' H-force (lumped into linear drag), a battery at the log's median
    voltage without sag.
    """
    notes = [] if notes is None else notes
    base = vehicle_truth(template)
    data = template.to_dict()
    mass = template.mass
    arm = float(layout["arm"])
    data["name"] = name
    data["description"] = description
    data["frame"].update(arm_length=arm, angles_deg=list(layout["angles_deg"]),
                         spin=list(layout["spin"]))
    k = values.get("k", base["k"])
    idle = values.get("idle_ratio", base["idle_ratio"])
    # rotor speeds: top speed at V0 as the template's at its own trim voltage
    top = base["top"]
    k_t = base["k"] * mass / top ** 2              # template N per (rad/s)^2
    scale = k * mass / (k_t * top ** 2)
    fx = data.setdefault("effects", {})
    fx.pop("weak_motor", None)
    fx["thrust_scale"] = float(scale)
    fx["torque_scale"] = float(scale)              # torque per thrust kept (declared)
    data["motor"].update(omega_max=float(top), v_ref=float(v0),
                         omega_idle=float(idle * top),
                         time_constant=float(values.get("motor_time_constant",
                                                        base["motor_time_constant"])))
    fx.pop("motor_lag", None)
    # s; a negative delay is an offset of the log's stamps, not a transport delay
    fx["time_delay"] = max(0.0, float(values.get("time_delay", 0.0)))
    ixx = mass * arm / values.get("roll_effectiveness", mass * arm / template.inertia[0, 0])
    iyy = mass * arm / values.get("pitch_effectiveness", mass * arm / template.inertia[1, 1])
    izz = mass * base["kappa_q"] / values.get("yaw_effectiveness", base["yaw_effectiveness"])
    if not abs(ixx - iyy) < izz < ixx + iyy:
        # a rigid body's principal moments obey the triangle inequality; a yaw estimate that
        # breaks it (the weak axis) gives way to the template's Izz scaled with Ixx + Iyy
        t = template.inertia
        izz = float(t[2, 2] / (t[0, 0] + t[1, 1]) * (ixx + iyy))
        notes.append("fitted Izz (from the yaw effectiveness) breaks the rigid-body triangle "
                     "inequality: the template's Izz / (Ixx + Iyy) kept")
    data["inertia"] = {"ixx": float(ixx), "iyy": float(iyy), "izz": float(izz), "ixy": 0.0,
                       "ixz": 0.0, "iyz": 0.0}
    fx.pop("inertia_scale", None)
    drag = data["drag"]
    drag["rotor_drag"] = 0.0
    for i, ax in enumerate("xy"):
        drag["linear"][i] = float(max(values.get(f"drag_{ax}", base[f"drag_{ax}"]), 0.0) * mass)
        drag["quadratic"][i] = float(max(values.get(f"drag_quad_{ax}",
                                                    base[f"drag_quad_{ax}"]), 0.0) * mass)
    cells = max(1, round(v0 / 3.85))
    data["battery"].update(cells=int(cells), soc0=float(min(max((v0 / cells - 3.5) / 0.7,
                                                                  0.01), 1.0)), sag=False)
    _keep_in_range(data, template.to_dict(), notes)
    fitted = vehicle_from_dict(data, f"fitted {name}")
    # controller gains scaled so the loop gain per axis is the template's
    ratio = effectiveness(template, base) / effectiveness(fitted, vehicle_truth(fitted))
    ctl = data["controller"]
    for key in ("max_tilt_deg", "max_yaw_rate_deg"):
        if key in values:
            ctl[key] = float(values[key])
    for key in ("rate_kp", "rate_ki", "rate_kd"):
        ctl[key] = [float(g * r) for g, r in zip(ctl[key], np.clip(ratio, 0.05, 20.0),
                                                 strict=True)]
    _keep_in_range(data, template.to_dict(), notes)
    return vehicle_from_dict(data, f"fitted {name}")


def _keep_in_range(data: dict[str, Any], template: dict[str, Any], notes: list[str]) -> None:
    """A fitted number outside its declared physical range (:mod:`etsid.sim.vehicle_params`)
    is replaced by the template's, and said so in ``notes``."""
    for section, values in data.items():
        if not isinstance(values, dict):
            continue
        for key, value in values.items():
            try:
                param = vehicle_param(section, key)
            except KeyError:
                continue
            items = value if isinstance(value, list) else [value]
            if all(not is_number(v) or in_range(param, float(v)) for v in items):
                continue
            values[key] = template.get(section, {}).get(key, value)
            notes.append(f"{section}.{key} = {value} is outside its physical range "
                         f"({param.describe()}): the template's value is kept")


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"non-finite value {value}")
        return repr(float(f"{value:.6g}"))
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def to_toml(vehicle: Vehicle, header: list[str], comments: dict[str, str]) -> str:
    """The vehicle file's text: ``header`` lines as comments, then every section;
    ``comments[SECTION.FIELD]`` is written after that field (standard error, verdict)."""
    data = vehicle.to_dict()
    lines = [f"# {h}" for h in header]
    tables = [(k, v) for k, v in data.items() if isinstance(v, dict)]
    for key, value in data.items():
        if not isinstance(value, dict):
            note = comments.get(key)
            lines.append(f"{key} = {_toml_value(value)}" + (f"  # {note}" if note else ""))
    for section, values in tables:
        lines += ["", f"[{section}]"]
        for key, value in values.items():
            note = comments.get(f"{section}.{key}")
            lines.append(f"{key} = {_toml_value(value)}" + (f"  # {note}" if note else ""))
    return "\n".join(lines) + "\n"


def write_vehicle(path: Path, text: str) -> None:
    """Write the vehicle file and check the simulator loads it back."""
    from etsid.sim.vehicle import load_vehicle

    path.write_text(text, encoding="utf-8")
    load_vehicle(path)
