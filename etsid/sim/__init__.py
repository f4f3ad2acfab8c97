"""Multirotor physics simulator: blade-element rotors with Glauert inflow, ground effect,
6-DOF quaternion rigid body, cascaded flight controller, pilot-like excitation, optional
physical effects (vehicle ``[effects]``), a stepping API and replay of recorded flights.

>>> from etsid.sim import SCENARIOS
>>> sorted(SCENARIOS)
['forward-flight', 'hover-ige', 'hover-oge', 'sine-altitude', 'steps']
"""

from __future__ import annotations

from etsid.sim.flight import SimFlight, simulate
from etsid.sim.replay import ReplayResult, replay, replay_many
from etsid.sim.scenarios import SCENARIOS
from etsid.sim.stepper import SimState, Simulator, StepRecord
from etsid.sim.trim import HoverTrim, hover_trim
from etsid.sim.vehicle import Vehicle, list_vehicles, load_vehicle

__all__ = [
    "SCENARIOS",
    "HoverTrim",
    "ReplayResult",
    "SimFlight",
    "SimState",
    "Simulator",
    "StepRecord",
    "Vehicle",
    "hover_trim",
    "list_vehicles",
    "load_vehicle",
    "replay",
    "replay_many",
    "simulate",
]
