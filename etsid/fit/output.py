"""Writing a fit: the vehicle file (with each fitted field's standard error and verdict as
a comment) and ``fit.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

from etsid.errors import FitError
from etsid.fit.result import FitResult
from etsid.fit.vehicle_file import to_toml, write_vehicle
from etsid.sim.vehicle import vehicle_from_dict

FIELD_OF = {
    "motor_time_constant": "motor.time_constant",
    "time_delay": "effects.time_delay",
    "roll_effectiveness": "inertia.ixx", "pitch_effectiveness": "inertia.iyy",
    "yaw_effectiveness": "inertia.izz", "thrust_to_weight": "effects.thrust_scale",
    "idle_ratio": "motor.omega_idle", "drag_x": "drag.linear",
    "drag_quad_x": "drag.quadratic",
    "mass": "mass", "max_tilt_deg": "controller.max_tilt_deg",
    "max_yaw_rate_deg": "controller.max_yaw_rate_deg", "arm_length": "frame.arm_length",
    "kappa_q": "effects.torque_scale",
}
"""Fitted parameter → the vehicle-file field it sets."""


def write_fit(result: FitResult, out: Path) -> tuple[Path, Path]:
    """Write ``out`` (vehicle TOML) and ``fit.json`` beside it; returns both paths.

    Raises
    ------
    FitError
        The directory cannot be written.
    """
    comments: dict[str, str] = {}
    for name, field in FIELD_OF.items():
        p = result.params.get(name)
        if p is None:
            continue
        se = f" ± {p.se:.3g}" if math.isfinite(p.se) else ""
        text = f"{p.name} = {p.value:.4g}{se} {p.unit}: {p.verdict}"
        comments[field] = comments[field] + "; " + text if field in comments else text
    header = ["Fitted by `etsid fit` from: " + ", ".join(Path(s).name for s in result.sources),
              "Every fitted field carries its estimate, standard error and verdict; fields",
              "without a comment are the template's declared defaults (docs/fit.md)."]
    header += [f"note: {n}" for n in result.notes]
    vehicle = vehicle_from_dict(result.vehicle, str(out))
    text = to_toml(vehicle, header, comments)
    json_path = out.with_name(out.stem + ".fit.json")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_vehicle(out, text)
        json_path.write_text(json.dumps(result.to_json(), indent=1), encoding="utf-8")
    except OSError as err:
        raise FitError(f"{out}: cannot write ({err.strerror or err})") from err
    return out, json_path
