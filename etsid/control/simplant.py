"""The simulated hexacopter as a :class:`~etsid.control.plant.Plant`.

Built on the simulator's stepping API (:class:`etsid.sim.stepper.Simulator`): every
control period advances the whole 6-DOF model (blade-element rotors with Glauert inflow,
ground effect, motors, battery, quaternion rigid body) by ``dt`` of 1 ms RK4 steps with
the simulator's own attitude and rate loops running on zero sticks, its altitude hold off
and its pilot off, so the collective command goes straight to the mixer. A payload is
:meth:`Simulator.set_mass` between periods.

The vertical loop runs at the rangefinder's rate (50 Hz) and its sensors are sampled at
the control instant, the end of each period: height = true CG height + white noise of the
vehicle's ``alt_std``, vertical speed = true NED v_z + ``vel_std`` noise, roll and pitch =
truth + ``att_std`` noise (the levels of the vehicle file's ``[sensors]``, drawn from a
generator seeded with ``seed``). The simulator's own records would hand the controller a
rangefinder sample one period old (it samples at the start of a period), which a real
autopilot would time-stamp; sampling at the instant keeps both controllers free of that
artefact. The true height is kept for scoring only.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from etsid.control.plant import Observation
from etsid.errors import ControlError
from etsid.sim.stepper import SimState, Simulator
from etsid.sim.vehicle import Vehicle

PHYSICS_HZ = 1000.0
"""Physics (RK4) rate inside a control period, Hz."""


class SimPlant:
    """The hexacopter simulator, stepped one control period at a time.

    Parameters
    ----------
    vehicle : str, Path, Vehicle or None
        Packaged vehicle name, TOML file or Vehicle (None: tarot680).
    seed : int
        Seed of the sensor noise.
    dt : float
        Control period, s (a whole number ≥ 2 of 1 ms physics steps).
    ground_effect : bool
        Model ground effect (on in every documented experiment).
    """

    def __init__(self, vehicle: str | Path | Vehicle | None = None, seed: int = 0,
                 dt: float = 0.02, ground_effect: bool = True) -> None:
        self.n_sub = round(dt * PHYSICS_HZ)
        if self.n_sub < 2 or abs(self.n_sub / PHYSICS_HZ - dt) > 1e-9:
            raise ControlError(f"control period {dt!r} s is not a whole number (≥ 2) of "
                               f"{1e3 / PHYSICS_HZ:g} ms physics steps")
        self.dt = self.n_sub / PHYSICS_HZ
        self.seed = int(seed)
        self.ground_effect = bool(ground_effect)
        self.sim = Simulator(vehicle, physics_hz=PHYSICS_HZ, ground_effect=self.ground_effect,
                             alt_hold=False, pilot=False, noise=True, seed=self.seed)
        self.hover_command = float(self.sim.hover_command)
        sensors = self.sim.vehicle["sensors"]
        self.noise_std = np.array([sensors["alt_std"], sensors["vel_std"],
                                   sensors["att_std"], sensors["att_std"]], dtype=float)
        self._rng = np.random.default_rng(self.seed)
        self.state: SimState | None = None

    def describe(self) -> dict[str, Any]:
        """What the plant is, for config.json."""
        veh = self.sim.vehicle
        return {"type": "etsid.sim.stepper.Simulator (6-DOF hexacopter)",
                "vehicle": veh.name, "vehicle_source": str(veh.source),
                "physics_hz": PHYSICS_HZ, "ground_effect": self.ground_effect,
                "seed": self.seed, "mass": veh.mass,
                "altitude_hold": "off (collective from outside)",
                "attitude_loops": "simulator's own, zero sticks, pilot off"}

    # ------------------------------------------------------------------ protocol
    def reset(self, altitude: float) -> Observation:
        """Trimmed level hover with the CG at ``altitude`` m (ground effect included).

        Resetting restarts the noise generators, so a seed reproduces a flight bit for bit.
        """
        self.sim.rng = np.random.default_rng(self.seed)
        self._rng = np.random.default_rng([self.seed, 1])
        self.sim.set_mass(self.sim.vehicle.mass)
        self.state = self.sim.hover(float(altitude))
        return self._observe()

    def step(self, u_thrust: float) -> Observation:
        """Fly one control period with the collective ``u_thrust`` (0..1)."""
        if self.state is None:
            raise ControlError("SimPlant.step before reset")
        if not math.isfinite(u_thrust):
            raise ControlError(f"collective command is not finite: {u_thrust!r}")
        self.state, _ = self.sim.step(self.state, self.n_sub, thrust=float(u_thrust),
                                      record_every=self.n_sub)
        return self._observe()

    def _observe(self) -> Observation:
        """Sensors sampled now (see the module docstring)."""
        st = self.state
        noise = self._rng.standard_normal(4) * self.noise_std
        roll, pitch, _ = st.euler
        h = st.altitude
        return Observation(t=st.t, alt=h + noise[0], vz=float(st.velocity[2]) + noise[1],
                           roll=roll + noise[2], pitch=pitch + noise[3], true_alt=h,
                           mass=self.sim.mass)

    def set_mass(self, mass: float) -> None:
        """Payload: the vehicle's mass (kg) from the next period on (inertia unchanged)."""
        if not (math.isfinite(mass) and mass > 0):
            raise ControlError(f"mass must be positive, got {mass!r}")
        self.sim.set_mass(float(mass))
