"""The simulated hexacopter as a :class:`~etsid.control.plant.Plant`.

Built on the simulator's full-state engine (:func:`etsid.sim.engine.advance`): every
control period advances the whole 6-DOF model (blade-element rotors with Glauert inflow,
ground effect, motors, battery, quaternion rigid body) by ``dt / h`` RK4 physics steps
(h = 1 ms) with the simulator's own attitude and rate loops running on zero sticks, its
altitude hold off and the pilot off, so the collective command goes straight to the
mixer. A payload is a change of ``P[MASS]`` between periods.

The observation handed to the controller is exactly what the simulator's sensors read at
the first physics step of the next period: the rangefinder (sample-and-hold at its rate,
with its noise), the NED vertical speed with its noise and the attitude estimate — the
noise rows are drawn ahead from the seeded generator and then fed to the engine, so the
controller and the simulated autopilot see the same numbers and a seed reproduces a
flight bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from etsid.control.plant import Observation
from etsid.errors import ControlError
from etsid.sim.body import quat_to_euler
from etsid.sim.engine import (
    MEAS_COLUMNS,
    MISC_ALT,
    MISC_STEP,
    TRUTH_COLUMNS,
    advance,
    state_offsets,
)
from etsid.sim.params import MASS, NZ_ALT, NZ_ATT, NZ_VEL, X_POS, X_Q, X_VEL
from etsid.sim.plant import initial_state, make_plant, noise_levels
from etsid.sim.trim import hover_trim
from etsid.sim.vehicle import Vehicle, load_vehicle

PHYSICS_HZ = 1000.0
"""Physics (RK4) rate inside a control period, Hz."""


class SimPlant:
    """The hexacopter simulator, stepped one control period at a time.

    Parameters
    ----------
    vehicle : str, Path, Vehicle or None
        Packaged vehicle name, TOML file or Vehicle (None: tarot680).
    seed : int
        Seed of the sensor noise and the gyro bias.
    dt : float
        Control period, s (a whole number of 1 ms physics steps).
    ground_effect : bool
        Model ground effect (on in every documented experiment).
    """

    def __init__(self, vehicle: str | Path | Vehicle | None = None, seed: int = 0,
                 dt: float = 0.02, ground_effect: bool = True) -> None:
        self.vehicle = load_vehicle(vehicle)
        self.n_sub = max(1, round(dt * PHYSICS_HZ))
        if abs(self.n_sub / PHYSICS_HZ - dt) > 1e-9:
            raise ControlError(f"control period {dt!r} s is not a whole number of "
                               f"{1e3 / PHYSICS_HZ:g} ms physics steps")
        self.dt = self.n_sub / PHYSICS_HZ
        self.seed = int(seed)
        self.ground_effect = bool(ground_effect)
        self._rng = np.random.default_rng(self.seed)
        bias = self._rng.normal(0.0, noise_levels(self.vehicle)["gyro_bias_std"], 3)
        if self.vehicle.effects["gyro_bias"] is not None:
            bias = np.asarray(self.vehicle.effects["gyro_bias"], dtype=float)
        self.plant = make_plant(self.vehicle, dt=1.0 / PHYSICS_HZ,
                                ground_effect=self.ground_effect, alt_hold=False,
                                pilot=False, gyro_bias=bias)
        self.hover_command = float(self.plant.trim_oge.command)
        n, n_rot = self.n_sub, self.plant.n_rotors
        self._exc = np.zeros((n, 3))
        self._zeros = np.zeros(n)
        self._vel_sp = np.zeros((n, 2))
        self._thr = np.zeros(n)
        self._motors = np.zeros((0, n_rot))
        self._meas = np.empty((1, len(MEAS_COLUMNS) + n_rot))
        self._truth = np.empty((1, len(TRUTH_COLUMNS) + 5 * n_rot))
        self._o_misc = state_offsets(n_rot)[3]
        self.S = np.zeros(0)
        self.t = 0.0

    def describe(self) -> dict[str, Any]:
        """What the plant is, for config.json."""
        return {"type": "etsid.sim (6-DOF hexacopter, full-state engine)",
                "vehicle": self.vehicle.name, "physics_hz": PHYSICS_HZ,
                "ground_effect": self.ground_effect, "seed": self.seed,
                "mass": self.vehicle.mass, "altitude_hold": "off (collective from outside)",
                "attitude_loops": "simulator's own, zero sticks"}

    # ------------------------------------------------------------------ protocol
    def reset(self, altitude: float) -> Observation:
        """Trimmed level hover with the CG at ``altitude`` m (ground effect included)."""
        self._rng = np.random.default_rng(self.seed + 1)
        self.plant.P[MASS] = self.vehicle.mass
        trim = hover_trim(self.vehicle, altitude if self.ground_effect else None)
        self.S = initial_state(self.plant, altitude, ground_effect=self.ground_effect,
                               command=trim.command)
        self.S[self._o_misc + MISC_ALT] = altitude
        self.t = 0.0
        self._noise = self.plant.draw_noise(self._rng, self.n_sub)
        return self._observe()

    def step(self, u_thrust: float) -> Observation:
        """Fly one control period with the collective ``u_thrust`` (0..1)."""
        if not math.isfinite(u_thrust):
            raise ControlError(f"collective command is not finite: {u_thrust!r}")
        self._thr[:] = u_thrust
        p = self.plant
        advance(self.S, p.P, p.inertia, p.rpos, p.spin, p.dists, p.mix, self._exc,
                self._zeros, self._zeros, self._vel_sp, self._thr, self._motors, self._noise,
                self.n_sub, p.rf_every, self._meas, self._truth)
        self.t += self.dt
        self._noise = self.plant.draw_noise(self._rng, self.n_sub)
        return self._observe()

    def set_mass(self, mass: float) -> None:
        """Payload: the vehicle's mass (kg) from the next period on (inertia unchanged)."""
        if not (math.isfinite(mass) and mass > 0):
            raise ControlError(f"mass must be positive, got {mass!r}")
        self.plant.P[MASS] = mass

    # ------------------------------------------------------------------ sensors
    def _observe(self) -> Observation:
        """The sensor readings of the next physics step (same noise row the engine uses)."""
        S, nz = self.S, self._noise[0]
        true_alt = -S[X_POS + 2]
        alt = S[self._o_misc + MISC_ALT]
        if int(S[self._o_misc + MISC_STEP]) % self.plant.rf_every == 0:
            alt = true_alt + nz[NZ_ALT]
        roll, pitch, _ = quat_to_euler(S[X_Q:X_Q + 4])
        return Observation(t=self.t, alt=float(alt), vz=float(S[X_VEL + 2] + nz[NZ_VEL + 2]),
                           roll=float(roll + nz[NZ_ATT]), pitch=float(pitch + nz[NZ_ATT + 1]),
                           true_alt=float(true_alt), mass=float(self.plant.P[MASS]))
