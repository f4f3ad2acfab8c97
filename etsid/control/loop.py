"""Fly one scenario closed loop: controller ↔ plant, recorded at the control rate."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import pandas as pd

from etsid import progress
from etsid.control.pid import Command
from etsid.control.plant import Observation, Plant
from etsid.control.scenarios import Scenario
from etsid.errors import ControlError

DIVERGED_ERROR = 10.0
"""Height error (m) beyond which a flight is stopped and reported as diverged."""


class Controller(Protocol):
    """A vertical-loop controller: one decision per control period."""

    name: str

    def update(self, t: float, obs: Observation, scenario: Scenario) -> Command:
        """The collective for the next period, from the observation at ``t``."""
        ...


@dataclass
class ControlFlight:
    """A closed-loop flight.

    Attributes
    ----------
    table : pandas.DataFrame
        FlightTable at the control rate (index ``t``, s): ``alt``, ``vz``, ``roll``,
        ``pitch``, ``u_thrust`` plus ``alt_ref`` (m), ``alt_ref_rate`` (m/s),
        ``true_alt`` (m), ``u_ff``, ``u_fb`` (collective parts) and ``mass`` (kg).
    scenario : Scenario
        The task flown.
    controller : Controller
        The controller after the flight (the eTS one holds its learnt model).
    timing : dict
        CPU seconds spent in the controller and in the plant (``time.process_time``, so
        other processes on the machine do not count), per control period in µs, the
        flight time and the real-time factor (flight time / CPU time).
    diverged : bool
        True if the height error exceeded :data:`DIVERGED_ERROR` and the flight was stopped.
    """

    table: pd.DataFrame
    scenario: Scenario
    controller: Any
    timing: dict[str, float] = field(default_factory=dict)
    diverged: bool = False


COLUMNS = ("alt", "vz", "roll", "pitch", "u_thrust", "alt_ref", "alt_ref_rate", "true_alt",
           "u_ff", "u_fb", "mass")


def fly(scenario: Scenario, controller: Controller, plant: Plant,
        duration: float | None = None) -> ControlFlight:
    """Fly ``scenario`` with ``controller`` closing the vertical loop of ``plant``.

    Parameters
    ----------
    scenario : Scenario
        Reference, start height and events.
    controller : Controller
        Decides the collective every ``plant.dt`` seconds.
    plant : Plant
        The vehicle (attitude loops its own).
    duration : float, optional
        Flight time, s (default: the scenario's).

    Returns
    -------
    ControlFlight
    """
    duration = scenario.duration if duration is None else float(duration)
    dt = plant.dt
    n = round(duration / dt)
    if n < 2:
        raise ControlError(f"duration {duration:g} s is shorter than two control periods")
    rows = np.full((n, len(COLUMNS)), np.nan)
    obs = plant.reset(scenario.start)
    mass_done = scenario.mass_change is None
    t_ctrl = t_plant = 0.0
    diverged = False
    label = f"control: flying {scenario.name} with {controller.name} (flight s)"
    every = max(1, round(1.0 / dt))
    with progress.progress(round(duration), label, progress.enabled()) as bar:
        for k in range(n):
            t = k * dt
            if k and k % every == 0:
                bar.update(1)
            if not mass_done and t >= scenario.mass_change[0]:
                plant.set_mass(obs.mass + scenario.mass_change[1])
                mass_done = True
            c0 = time.process_time()
            cmd = controller.update(t, obs, scenario)
            c1 = time.process_time()
            r, rd, _ = scenario.at(t)
            rows[k] = (obs.alt, obs.vz, obs.roll, obs.pitch, cmd.u, r, rd, obs.true_alt,
                       cmd.u_ff, cmd.u_fb, obs.mass)
            if abs(r - obs.true_alt) > DIVERGED_ERROR or not np.isfinite(obs.true_alt):
                diverged = True
                rows = rows[: k + 1]
                break
            obs = plant.step(cmd.u)
            t_plant += time.process_time() - c1
            t_ctrl += c1 - c0
    index = pd.Index(np.arange(rows.shape[0]) * dt, name="t")
    table = pd.DataFrame(rows, index=index, columns=list(COLUMNS))
    table.attrs = {"source": "etsid.control", "format": "sim", "scenario": scenario.name,
                   "controller": controller.name, "rate_hz": 1.0 / dt}
    steps = max(rows.shape[0], 1)
    timing = {"flight_s": rows.shape[0] * dt, "controller_s": t_ctrl, "plant_s": t_plant,
              "controller_us_per_step": 1e6 * t_ctrl / steps,
              "plant_us_per_step": 1e6 * t_plant / steps}
    timing["realtime_factor"] = timing["flight_s"] / max(t_ctrl + t_plant, 1e-12)
    return ControlFlight(table=table, scenario=scenario, controller=controller,
                         timing=timing, diverged=diverged)
