"""eTS autopilot experiments: the vertical loop of the simulated hexacopter closed by an
eTS controller that learns from zero rules, compared with a PID baseline.

>>> from etsid.control import SCENARIOS, CONTROLLERS
>>> sorted(SCENARIOS), CONTROLLERS
(['altitude-steps', 'hover-ige', 'ige-sine', 'mass-change', 'sine-altitude'], ('ets', 'pid'))
"""

from __future__ import annotations

from etsid.control.ets_controller import ETSController, ETSSettings
from etsid.control.loop import ControlFlight, fly
from etsid.control.pid import PID_GAINS, Gains, PIDController
from etsid.control.plant import Observation, Plant
from etsid.control.run import CONTROLLERS, ControlResult, run_control
from etsid.control.scenarios import SCENARIOS, Scenario

__all__ = [
    "CONTROLLERS",
    "PID_GAINS",
    "SCENARIOS",
    "ControlFlight",
    "ControlResult",
    "ETSController",
    "ETSSettings",
    "Gains",
    "Observation",
    "PIDController",
    "Plant",
    "Scenario",
    "fly",
    "run_control",
]
