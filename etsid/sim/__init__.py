"""Multirotor physics simulator: blade-element rotors with Glauert inflow, ground effect,
6-DOF quaternion rigid body, cascaded flight controller, pilot-like excitation, optional
physical effects (vehicle ``[effects]``), a stepping API and replay of recorded flights.

>>> from etsid.sim import SCENARIOS
>>> sorted(SCENARIOS)
['forward-flight', 'hover-ige', 'hover-oge', 'ige-oge', 'sine-altitude', 'steps']
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from etsid.sim.flight import SimFlight, simulate
    from etsid.sim.replay import ReplayResult, replay, replay_many
    from etsid.sim.scenarios import SCENARIOS
    from etsid.sim.stepper import SimState, Simulator, StepRecord
    from etsid.sim.trim import HoverTrim, hover_trim
    from etsid.sim.vehicle import Vehicle, list_vehicles, load_vehicle

_LAZY = {**dict.fromkeys(("SimFlight", "simulate"), "etsid.sim.flight"),
         **dict.fromkeys(("ReplayResult", "replay", "replay_many"), "etsid.sim.replay"),
         "SCENARIOS": "etsid.sim.scenarios",
         **dict.fromkeys(("SimState", "Simulator", "StepRecord"), "etsid.sim.stepper"),
         **dict.fromkeys(("HoverTrim", "hover_trim"), "etsid.sim.trim"),
         **dict.fromkeys(("Vehicle", "list_vehicles", "load_vehicle"), "etsid.sim.vehicle")}
"""Public names → the module that defines them, imported when the name is first used:
importing the package (or a light module of it such as :mod:`etsid.sim.vehicle_params`, the
ranges of ``etsid simulate --help``) loads no numpy or scipy."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'etsid.sim' has no attribute {name!r}")


class _Package(types.ModuleType):
    """This package's module type: ``etsid.sim.replay`` stays the function when the
    submodule of the same name is imported (Python then sets the package attribute to the
    module), as it was when the package imported the function eagerly."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and _LAZY.get(name) == value.__name__:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


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
