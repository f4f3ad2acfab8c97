"""``run_control``: fly a scenario with the eTS or PID controller and write the RUN_DIR."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from etsid.control.ets_controller import ETSController, ETSSettings
from etsid.control.loop import ControlFlight, fly
from etsid.control.metrics import flight_metrics
from etsid.control.pid import PIDController
from etsid.control.plant import Plant
from etsid.control.rundir import write_run
from etsid.control.scenarios import Scenario, get_scenario
from etsid.errors import ControlError

CONTROLLERS = ("ets", "pid")
CONTROL_HZ = 50.0
"""Rate of the vertical loop, Hz (the rangefinder's rate)."""


@dataclass
class ControlResult:
    """A finished control experiment: the flight, its scores and where it was written."""

    flight: ControlFlight
    metrics: dict[str, Any]
    config: dict[str, Any]
    run_dir: Path | None = None


def make_controller(name: str, plant: Plant) -> ETSController | PIDController:
    """The controller called ``name`` (``ets`` or ``pid``) for ``plant``."""
    if name == "ets":
        return ETSController(plant.dt, plant.hover_command)
    if name == "pid":
        return PIDController(plant.dt, plant.hover_command)
    raise ControlError(f"unknown controller {name!r}; choose one of {', '.join(CONTROLLERS)}")


def controller_settings(controller: ETSController | PIDController) -> dict[str, Any]:
    """The settings of a controller as a JSON-ready dict."""
    if isinstance(controller, ETSController):
        return {"ets": dataclasses.asdict(controller.settings)}
    return {"pid": dataclasses.asdict(controller.feedback.gains)}


def evaluate(flight: ControlFlight) -> dict[str, Any]:
    """metrics.json of a flight: scores, rule counts, timing, stability."""
    sc = flight.scenario
    m = flight_metrics(flight.table, sc.step_times() or None)
    ctrl = flight.controller
    m["controller"] = ctrl.name
    m["scenario"] = sc.name
    m["stable"] = not flight.diverged
    m["duration_s"] = flight.timing["flight_s"]
    if isinstance(ctrl, ETSController):
        events = ctrl.model.history.events
        m["rules_final"] = ctrl.model.n_rules
        m["rule_births"] = sum(e["kind"] == "birth" for e in events)
        m["rule_replacements"] = sum(e["kind"] == "replace" for e in events)
        m["rule_removals"] = sum(e["kind"] == "removal" for e in events)
        m["learned_samples"] = ctrl.learned
    else:
        m["rules_final"] = None
        m["rule_births"] = m["rule_replacements"] = m["rule_removals"] = None
    m["timing"] = flight.timing
    return m


def run_control(scenario: str | Scenario, controller: str = "ets", *,
                plant: Plant | None = None, vehicle: str | Path | None = None,
                duration: float | None = None, seed: int = 0,
                out: str | Path | None = None) -> ControlResult:
    """Fly ``scenario`` with ``controller`` and (if ``out`` is given) write the RUN_DIR.

    Parameters
    ----------
    scenario : str or Scenario
        Name in :data:`etsid.control.scenarios.SCENARIOS` or a Scenario.
    controller : {"ets", "pid"}
        The eTS controller learning from zero rules, or the PID baseline.
    plant : Plant, optional
        The vehicle; default the simulator (:class:`etsid.control.simplant.SimPlant`)
        with ``vehicle`` and ``seed``.
    vehicle : str or Path, optional
        Packaged vehicle name or TOML file (default tarot680).
    duration : float, optional
        Flight time, s (default: the scenario's).
    seed : int
        Seed of the sensor noise.
    out : str or Path, optional
        RUN_DIR to write.

    Returns
    -------
    ControlResult
    """
    sc = scenario if isinstance(scenario, Scenario) else get_scenario(scenario)
    if controller not in CONTROLLERS:
        raise ControlError(f"unknown controller {controller!r}; choose one of "
                           f"{', '.join(CONTROLLERS)}")
    if duration is not None and not duration > 0:
        raise ControlError(f"duration must be positive, got {duration!r}")
    if plant is None:
        from etsid.control.simplant import SimPlant

        plant = SimPlant(vehicle=vehicle, seed=seed, dt=1.0 / CONTROL_HZ)
    ctrl = make_controller(controller, plant)
    flight = fly(sc, ctrl, plant, duration)
    metrics = evaluate(flight)
    config = {
        "scenario": dataclasses.asdict(sc),
        "controller": controller,
        "settings": controller_settings(ctrl),
        "plant": getattr(plant, "describe", lambda: {"type": type(plant).__name__})(),
        "seed": seed,
        "duration": flight.timing["flight_s"],
        "control_hz": 1.0 / plant.dt,
        "hover_command": plant.hover_command,
    }
    if controller == "ets":
        config["rules"] = {
            "what": "inverse model of the vertical loop: u_thrust = f(h, w, a)",
            "inputs": {"h": "height over the learning window, m",
                       "w": "climb rate over the window, m/s",
                       "a": "climb acceleration over the window, m/s^2"},
            "output": "u_thrust: mean collective (level-flight units) that produced them"}
    flight.table.attrs.update({"seed": seed, "vehicle": config["plant"].get("vehicle")})
    result = ControlResult(flight=flight, metrics=metrics, config=config)
    if out is not None:
        model = ctrl.model if isinstance(ctrl, ETSController) else None
        times = ctrl.learn_times if isinstance(ctrl, ETSController) else None
        result.run_dir = write_run(out, flight.table, metrics, config, model, times)
    return result


__all__ = ["CONTROLLERS", "ControlResult", "ETSSettings", "run_control"]
