"""Stepping API: advance a simulated vehicle from a full state, a few physics steps at a time.

For code that closes its own loop around the simulator (the eTS autopilot of
``etsid control``, replay, fitting): the simulator's attitude and rate loops run inside
every step, and the caller supplies the loop commands — stick (attitude) commands, and the
collective ``u_thrust`` straight to the mixer when the altitude hold is off.

>>> from etsid.sim.stepper import Simulator
>>> sim = Simulator("tarot680", alt_hold=False, noise=False)
>>> state = sim.hover(altitude=1.0)
>>> heights = []
>>> for k in range(250):                        # 5 s in 20 ms outer-loop steps
...     if k == 100:
...         sim.set_mass(4.6)                    # payload picked up at t = 2 s
...     h, climb = state.altitude, -state.velocity[2]
...     u = sim.hover_command + 0.15 * (1.5 - h) - 0.1 * climb   # the caller's own P-D loop
...     state, rec = sim.step(state, 20, thrust=u, record_every=20)
...     heights.append(float(rec["true_alt"][-1]))
>>> round(state.t, 3), round(heights[99], 2), round(heights[-1], 2)  # P-D: payload sags it
(5.0, 1.52, 1.31)

One call costs tens of microseconds of Python/numba dispatch plus about 3 µs per physics
step (Tarot, 1 kHz): a 20-step call runs at well over 100× real time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import SimError
from etsid.sim.body import quat_to_euler
from etsid.sim.controller import N_CS
from etsid.sim.engine import MEAS_COLUMNS, ROTOR_BLOCKS, TRUTH_COLUMNS, advance, state_offsets
from etsid.sim.estimator import EST_B, EST_Q, N_EST
from etsid.sim.params import (
    LOOP_MOTORS,
    LOOP_RATES,
    LOOP_STICKS,
    LOOP_TORQUE,
    MASS,
    N_NOISE,
    X_OM,
    X_POS,
    X_Q,
    X_SOC,
    X_VEL,
    X_W,
)
from etsid.sim.plant import Plant, initial_state, make_plant
from etsid.sim.vehicle import Vehicle, load_vehicle, resolve_vehicle_key

LOOP_INPUTS = {"sticks": LOOP_STICKS, "rates": LOOP_RATES, "torque": LOOP_TORQUE,
               "motors": LOOP_MOTORS}


@dataclass
class SimState:
    """Full state of the simulated vehicle between two calls (copy it to branch).

    ``vector`` holds, in order: rigid body and battery and rotor speeds (layout in
    :mod:`etsid.sim.params`), rotor inflow warm start, controller state (rate and climb
    integrators, D-term filters, pilot), estimator (quaternion, gyro-bias estimate, last
    accelerometer sample), rangefinder hold, step counter, motor-command delay line.
    """

    vector: np.ndarray
    n_rotors: int
    dt: float

    def copy(self) -> SimState:
        """An independent copy."""
        return SimState(self.vector.copy(), self.n_rotors, self.dt)

    @property
    def _offsets(self) -> tuple[int, int, int, int, int]:
        return state_offsets(self.n_rotors)

    @property
    def t(self) -> float:
        """Time since the start, s."""
        return float(self.vector[self._offsets[3] + 1]) * self.dt

    @property
    def position(self) -> np.ndarray:
        """NED position of the CG, m."""
        return self.vector[X_POS:X_POS + 3].copy()

    @property
    def altitude(self) -> float:
        """CG height above the ground, m."""
        return float(-self.vector[X_POS + 2])

    @property
    def velocity(self) -> np.ndarray:
        """NED velocity, m/s."""
        return self.vector[X_VEL:X_VEL + 3].copy()

    @property
    def quaternion(self) -> np.ndarray:
        """Attitude quaternion body → NED (w, x, y, z)."""
        return self.vector[X_Q:X_Q + 4].copy()

    @property
    def euler(self) -> tuple[float, float, float]:
        """True roll, pitch, yaw, rad."""
        return tuple(float(a) for a in quat_to_euler(self.vector[X_Q:X_Q + 4]))

    @property
    def rates(self) -> np.ndarray:
        """True body rates p, q, r, rad/s."""
        return self.vector[X_W:X_W + 3].copy()

    @property
    def rotor_speeds(self) -> np.ndarray:
        """Rotor speeds, rad/s."""
        return self.vector[X_OM:X_OM + self.n_rotors].copy()

    @property
    def soc(self) -> float:
        """Battery state of charge, 0..1."""
        return float(self.vector[X_SOC])

    @property
    def controller(self) -> np.ndarray:
        """Controller state (``etsid.sim.controller.CS_*`` layout), a view."""
        o = self._offsets[1]
        return self.vector[o:o + N_CS]

    @property
    def estimated_euler(self) -> tuple[float, float, float]:
        """The attitude estimator's roll, pitch, yaw, rad (meaningful when it is on)."""
        o = self._offsets[2]
        return tuple(float(a) for a in quat_to_euler(self.vector[o + EST_Q:o + EST_Q + 4]))

    @property
    def gyro_bias_estimate(self) -> np.ndarray:
        """The estimator's gyro-bias estimate, rad/s."""
        o = self._offsets[2]
        return self.vector[o + EST_B:o + EST_B + 3].copy()


@dataclass
class StepRecord:
    """Signals recorded during one :meth:`Simulator.step` call, one row per recorded step.

    ``record["alt"]`` is a measured column (names of the FlightTable, motors ``m1..mN``),
    ``record["true_alt"]`` a true one (``true_`` + the names of ``simulate().truth``).
    """

    t: np.ndarray
    meas: np.ndarray
    truth: np.ndarray
    meas_columns: tuple[str, ...]
    truth_columns: tuple[str, ...]

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self.meas_columns:
            return self.meas[:, self.meas_columns.index(name)]
        if name in self.truth_columns:
            return self.truth[:, self.truth_columns.index(name)]
        raise KeyError(name)

    def frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        """Measured and true signals as DataFrames indexed by ``t`` (s)."""
        index = pd.Index(self.t, name="t")
        return (pd.DataFrame(self.meas, index=index, columns=list(self.meas_columns)),
                pd.DataFrame(self.truth, index=index.copy(), columns=list(self.truth_columns)))


def _per_step(value: Any, n: int, width: int, name: str) -> np.ndarray:
    """``value`` as a C-contiguous (n,) or (n, width) float array (scalars/rows held)."""
    arr = np.asarray(value, dtype=float)
    shape = (n,) if width == 0 else (n, width)
    if arr.shape == shape and arr.flags.c_contiguous and arr.flags.writeable:
        return arr
    out = np.empty(shape)
    try:
        out[...] = arr
    except ValueError:
        raise SimError(f"step: {name} must be a scalar/row or have shape {shape}, "
                       f"got {np.shape(value)}") from None
    return out


class Simulator:
    """A vehicle to step through time with externally supplied loop commands.

    Parameters
    ----------
    vehicle : str, Path, Vehicle or None
        Packaged name, TOML file or :class:`Vehicle` (default ``tarot680``).
    physics_hz : float
        Physics and control rate, Hz (RK4; 1000 as ``simulate()``).
    ground_effect : bool
        Vehicle's ground-effect model on.
    alt_hold : bool
        The simulator's altitude hold on (it tracks ``alt_sp``); off: ``thrust`` goes
        straight to the mixer as the collective ``u_thrust``.
    pilot : bool
        The simulated pilot (position and heading hold) adds its sticks; off: the sticks
        are exactly the ``sticks`` given.
    loop_input : str
        What ``sticks`` are: ``"sticks"`` (angle-mode roll/pitch, yaw-rate stick, −1..1),
        ``"rates"`` (body-rate setpoints, rad/s), ``"torque"`` (torque demands −1..1), or
        ``"motors"`` (the motor outputs are given instead, whole controller off).
    wind : tuple of float
        Constant wind, NED m/s.
    noise : bool
        Sensor noise of the vehicle file (``[sensors]``); off: exact measurements.
    seed : int
        Seed of the noise generator.
    settings : mapping, optional
        Vehicle settings as for :meth:`Vehicle.with_settings` (effects, mass,
        ``SECTION.FIELD``), with or without the ``vehicle.`` prefix.

    Notes
    -----
    The gyro bias is ``effects.gyro_bias`` (zero when unset: no random draw here).
    """

    def __init__(
        self, vehicle: str | Path | Vehicle | None = None, *, physics_hz: float = 1000.0,
        ground_effect: bool = True, alt_hold: bool = True, pilot: bool = False,
        loop_input: str = "sticks", wind: tuple[float, float, float] = (0.0, 0.0, 0.0),
        noise: bool = True, seed: int = 0, settings: Mapping[str, Any] | None = None,
    ) -> None:
        if loop_input not in LOOP_INPUTS:
            raise SimError(f"loop_input must be one of {', '.join(LOOP_INPUTS)}, "
                           f"got {loop_input!r}")
        if not (isinstance(physics_hz, int | float) and 10.0 <= physics_hz <= 100_000.0):
            raise SimError(f"physics_hz must be a number in 10..100000, got {physics_hz!r}")
        veh_settings = {str(k).removeprefix("vehicle."): v for k, v in (settings or {}).items()}
        for key in veh_settings:
            resolve_vehicle_key(key)
        veh = load_vehicle(vehicle)
        if veh_settings:
            veh = veh.with_settings(veh_settings)
        self.ground_effect = ground_effect
        self.loop_input = loop_input
        self.plant: Plant = make_plant(veh, dt=1.0 / physics_hz, ground_effect=ground_effect,
                                       alt_hold=alt_hold, pilot=pilot, wind=wind,
                                       loop_input=LOOP_INPUTS[loop_input])
        if not noise:
            self.plant.noise_std = np.zeros(N_NOISE)
        self.rng = np.random.default_rng(seed)
        self.alt_sp = 0.0
        n = veh.n_rotors
        self.meas_columns = (*MEAS_COLUMNS, *(f"m{i + 1}" for i in range(n)))
        self.truth_columns = (*(f"true_{c}" for c in TRUTH_COLUMNS),
                              *(f"true_{b}{i + 1}" for b in ROTOR_BLOCKS for i in range(n)))

    @property
    def vehicle(self) -> Vehicle:
        """The vehicle flown (effects included)."""
        return self.plant.vehicle

    @property
    def dt(self) -> float:
        """Physics step, s."""
        return self.plant.dt

    @property
    def hover_command(self) -> float:
        """Collective that hovers the vehicle out of ground effect at its file mass."""
        return self.plant.trim_oge.command

    @property
    def mass(self) -> float:
        """Current mass, kg."""
        return float(self.plant.P[MASS])

    def set_mass(self, mass: float) -> None:
        """Change the mass from the next step on (payload picked up or dropped), kg.

        The inertia and the controller's hover collective stay those of the vehicle file,
        as on a real vehicle whose autopilot is not told.
        """
        if not (isinstance(mass, int | float) and mass > 0):
            raise SimError(f"mass must be a positive number of kg, got {mass!r}")
        self.plant.P[MASS] = float(mass)

    def hover(self, altitude: float, yaw: float = 0.0) -> SimState:
        """State of a steady level hover at CG height ``altitude`` (m), heading ``yaw`` (rad).

        Also sets the default altitude setpoint of :meth:`step` to ``altitude``.
        """
        if not (isinstance(altitude, int | float) and altitude > 0):
            raise SimError(f"altitude must be a positive number of m, got {altitude!r}")
        S = initial_state(self.plant, float(altitude), ground_effect=self.ground_effect)
        if yaw:
            from etsid.sim.plant import set_attitude

            set_attitude(S, 0.0, 0.0, yaw, self.plant.n_rotors)
        self.alt_sp = float(altitude)
        return SimState(S, self.plant.n_rotors, self.plant.dt)

    def step(
        self, state: SimState, n_steps: int, *, sticks: Any = (0.0, 0.0, 0.0),
        thrust: Any = None, alt_sp: Any = None, alt_rate: Any = 0.0,
        vel_sp: Any = (0.0, 0.0), motors: Any = None, record_every: int = 1,
    ) -> tuple[SimState, StepRecord]:
        """Advance ``state`` by ``n_steps`` physics steps.

        Parameters
        ----------
        state : SimState
            Start state (not modified).
        n_steps : int
            Physics steps to fly (``n_steps · dt`` seconds).
        sticks : array-like
            Loop commands, (3,) held or (n_steps, 3) per step, as ``loop_input`` says.
        thrust : float or array-like, optional
            Collective ``u_thrust`` 0..1 to the mixer when the altitude hold is off
            (default: :attr:`hover_command`).
        alt_sp, alt_rate : float or array-like
            Altitude setpoint (m; default: the last :meth:`hover` altitude) and its rate
            (m/s) for the altitude hold.
        vel_sp : array-like
            Pilot speed target forward/right, m/s (pilot on only).
        motors : array-like, optional
            Motor outputs 0..1, (N,) held or (n_steps, N), when ``loop_input="motors"``.
        record_every : int
            Record every ``record_every``-th step (the first step is always recorded).

        Returns
        -------
        state : SimState
            The state after the last step.
        record : StepRecord
            Measured and true signals of the recorded steps.
        """
        n = int(n_steps)
        if n < 1 or record_every < 1:
            raise SimError(f"step: n_steps and record_every must be ≥ 1, got {n_steps!r}, "
                           f"{record_every!r}")
        plant = self.plant
        n_rot = plant.n_rotors
        exc = _per_step(sticks, n, 3, "sticks")
        thr = _per_step(self.hover_command if thrust is None else thrust, n, 0, "thrust")
        asp = _per_step(self.alt_sp if alt_sp is None else alt_sp, n, 0, "alt_sp")
        arate = _per_step(alt_rate, n, 0, "alt_rate")
        vel = _per_step(vel_sp, n, 2, "vel_sp")
        if self.loop_input == "motors":
            if motors is None:
                raise SimError("step: loop_input='motors' needs motors")
            mot = _per_step(motors, n, n_rot, "motors")
        else:
            mot = np.zeros((0, n_rot))
        noise = plant.draw_noise(self.rng, n) if np.any(plant.noise_std) \
            else np.zeros((n, N_NOISE))
        n_rec = (n + record_every - 1) // record_every
        meas = np.empty((n_rec, len(self.meas_columns)))
        truth = np.empty((n_rec, len(self.truth_columns)))
        S = state.vector.copy()
        t0 = state.t
        advance(S, plant.P, plant.inertia, plant.rpos, plant.spin, plant.dists, plant.mix, exc,
                asp, arate, vel, thr, mot, noise, int(record_every), plant.rf_every, meas, truth)
        t = t0 + np.arange(n_rec) * record_every * plant.dt
        return (SimState(S, n_rot, plant.dt),
                StepRecord(t, meas, truth, self.meas_columns, self.truth_columns))


__all__ = ["LOOP_INPUTS", "N_EST", "SimState", "Simulator", "StepRecord"]
