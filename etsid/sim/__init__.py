"""Multirotor physics simulator: blade-element rotors with Glauert inflow, ground effect,
6-DOF quaternion rigid body, cascaded flight controller, pilot-like excitation.

>>> from etsid.sim import SCENARIOS
>>> sorted(SCENARIOS)
['forward-flight', 'hover-ige', 'hover-oge', 'sine-altitude', 'steps']
"""

from __future__ import annotations

from etsid.sim.flight import SimFlight, simulate
from etsid.sim.scenarios import SCENARIOS
from etsid.sim.trim import HoverTrim, hover_trim
from etsid.sim.vehicle import Vehicle, list_vehicles, load_vehicle

__all__ = [
    "SCENARIOS",
    "HoverTrim",
    "SimFlight",
    "Vehicle",
    "hover_trim",
    "list_vehicles",
    "load_vehicle",
    "simulate",
]
