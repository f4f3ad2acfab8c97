"""Where a mismatch lives: the regime of the main channel's residual (height, speed,
thrust, command rate, pack voltage or time) and, where a named effect has a physical driver
the residual bins cannot show (a wind's heading, a weak motor, the pack voltage), that
driver instead."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from etsid.gap.locate import ground_band, locate_channel, segments
from etsid.gap.signals import Flight


def locate(real: Flight, main: str, res0: dict[str, np.ndarray], sigma: float,
           radius: float | None, effective: bool,
           ground_law: Callable[[np.ndarray], np.ndarray] | None) -> dict[str, Any]:
    """The regime of the main channel's residual (from the fitted law, height → thrust
    excess, when ground effect is named) and its time segments."""
    reg = locate_channel(main, res0[main], sigma, real, radius, effective)
    basis = "residual bins"
    if ground_law is not None:
        # what the tool believes: the band where the fitted law's excess is ≥ half its peak
        reg = ground_band(main, res0[main], real, ground_law, reg.eta2, radius, effective)
        basis = "fitted law"
    with_radius = reg.variable == "alt" and radius
    return {"channel": main, "variable": reg.variable,
            "range": None if reg.variable == "none" else [reg.lo, reg.hi],
            "unit": "" if reg.variable == "none" else
            {"alt": "m", "speed": "m/s", "thrust": "1", "command_rate": "1/s", "vbat": "V",
             "time": "s"}[reg.variable],
            "z_over_r": [reg.lo / radius, reg.hi / radius] if with_radius else None,
            "radius": None if not with_radius else
            {"value": radius, "unit": "m",
             "source": "fitted effective" if effective else "vehicle"},
            "basis": basis, "description": reg.description,
            "segments": segments(res0[main], sigma, real)}


def located_by_driver(effects: list[dict[str, Any]], real: Flight) -> dict[str, Any] | None:
    """The regime stated by the named effect's own physical driver, where it has one that
    the residual bins cannot show: a steady wind by the heading relative to it, a weak
    motor by the motor, a battery sag by the measured voltage."""
    named = {e["name"]: e for e in effects}
    if "wind" in named:
        p = {k: v["value"] for k, v in named["wind"]["parameters"].items()}
        towards = float(np.degrees(np.arctan2(p["east"], p["north"]))) % 360.0
        yaw = np.degrees(np.unwrap(real.att[real.airborne, 2])) % 360.0
        rel = (yaw - towards + 180.0) % 360.0 - 180.0
        return {"variable": "heading", "unit": "deg", "basis": "fitted law",
                "range": [float(np.min(rel)), float(np.max(rel))],
                "description": f"the horizontal force follows the heading relative to a steady "
                               f"wind towards {towards:.0f}° (flown at {np.min(rel):.0f}° to "
                               f"{np.max(rel):.0f}° from it): drag on the air-relative "
                               "velocity, in earth axes"}
    if "weak_motor" in named:
        k = int(named["weak_motor"]["parameters"]["motor"]["value"])
        return {"variable": "motor", "unit": "", "basis": "fitted law", "range": [k, k],
                "description": f"motor {k}: its thrust at a given command differs from the "
                               "others' (the trims hold the differential)"}
    if "battery_sag" in named and "vbat" in real.have:
        v = real.vbat[real.airborne]
        return {"variable": "vbat", "unit": "V", "basis": "fitted law",
                "range": [float(np.nanmin(v)), float(np.nanmax(v))],
                "description": f"thrust and torque follow the measured pack voltage "
                               f"({np.nanmin(v):.2f}–{np.nanmax(v):.2f} V)"}
    return None
