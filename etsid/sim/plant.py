"""The simulated vehicle as the compiled loop sees it: parameters, geometry, initial state.

:class:`Plant` gathers what stays fixed during a flight (parameter vector ``P``, inertia,
rotor geometry, mixer, noise levels, physics step); :func:`initial_state` builds the full
state vector ``S`` of :func:`etsid.sim.engine.advance` for a steady hover. ``simulate()``,
the stepping API (:mod:`etsid.sim.stepper`) and replay (:mod:`etsid.sim.replay`) all fly
through these two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from etsid.sim.body import euler_to_quat
from etsid.sim.controller import CS_IVZ, INT_LIMIT
from etsid.sim.engine import state_offsets
from etsid.sim.estimator import EST_F, EST_FL, EST_Q, N_EST
from etsid.sim.params import (
    DELAY,
    GRAV,
    LOOP_STICKS,
    N_NOISE,
    NZ_ACC,
    NZ_ALT,
    NZ_ATT,
    NZ_GYRO,
    NZ_VBAT,
    NZ_VEL,
    X_OM,
    X_POS,
    X_Q,
    X_SOC,
    effective_inertia,
    geometry,
    pack,
)
from etsid.sim.trim import HoverTrim, hover_trim
from etsid.sim.vehicle import Vehicle

NO_PILOT = {"pilot_kv": 0.0, "pilot_ki": 0.0, "pilot_kpsi": 0.0}


@dataclass
class Plant:
    """A vehicle ready to fly: everything the compiled loop needs besides the state.

    Attributes
    ----------
    vehicle : Vehicle
        The vehicle (effects included).
    P : ndarray
        Parameter vector (:mod:`etsid.sim.params`); change entries between calls to model a
        change in flight (e.g. ``P[MASS]`` for a payload).
    inertia : ndarray
        Inertia tensor about the CG with ``effects.inertia_scale`` applied, kg m².
    rpos, spin, dists, mix : ndarray
        Rotor hub positions (N, 3) m, spin signs, hub distances, mixer (N, 4).
    dt : float
        Physics (and control) step, s.
    noise_std : ndarray
        (N_NOISE,) standard deviation of each measurement-noise column.
    rf_every : int
        Rangefinder period in physics steps.
    trim_oge : HoverTrim
        Hover trim out of ground effect (its command is the controller's hover collective).
    delay_capacity : int
        Slots of the motor-command delay line in the state vector.
    """

    vehicle: Vehicle
    P: np.ndarray
    inertia: np.ndarray
    rpos: np.ndarray
    spin: np.ndarray
    dists: np.ndarray
    mix: np.ndarray
    dt: float
    noise_std: np.ndarray
    rf_every: int
    trim_oge: HoverTrim
    delay_capacity: int = field(default=1)

    @property
    def n_rotors(self) -> int:
        """Number of rotors."""
        return self.rpos.shape[0]

    def draw_noise(self, rng: np.random.Generator, n_steps: int) -> np.ndarray:
        """(n_steps, N_NOISE) measurement noise in physical units."""
        return rng.standard_normal((n_steps, N_NOISE)) * self.noise_std


def noise_levels(vehicle: Vehicle) -> dict[str, float]:
    """Sensor noise levels of the vehicle file (``[sensors]``)."""
    s = vehicle["sensors"]
    return {k: float(s[k]) for k in ("gyro_std", "gyro_bias_std", "accel_std", "att_std",
                                       "vel_std", "alt_std", "vbat_std", "rangefinder_hz")}


def noise_std(vehicle: Vehicle) -> np.ndarray:
    """(N_NOISE,) standard deviations of the measurement-noise columns."""
    lv = noise_levels(vehicle)
    std = np.zeros(N_NOISE)
    std[NZ_GYRO:NZ_GYRO + 3] = lv["gyro_std"]
    std[NZ_ATT:NZ_ATT + 3] = lv["att_std"]
    std[NZ_VEL:NZ_VEL + 3] = lv["vel_std"]
    std[NZ_ALT] = lv["alt_std"]
    std[NZ_ACC:NZ_ACC + 3] = lv["accel_std"]
    std[NZ_VBAT] = lv["vbat_std"]
    return std


def make_plant(
    vehicle: Vehicle, *, dt: float, ground_effect: bool = True, alt_hold: bool = True,
    pilot: bool = True, wind: tuple[float, float, float] = (0.0, 0.0, 0.0),
    gyro_bias: np.ndarray | None = None, loop_input: int = LOOP_STICKS,
) -> Plant:
    """Build the :class:`Plant` of ``vehicle`` for physics step ``dt`` (s).

    Parameters
    ----------
    vehicle : Vehicle
        Vehicle with its effects.
    dt : float
        Physics step, s.
    ground_effect, alt_hold, pilot : bool
        Ground-effect model, altitude hold (off: the per-step collective goes straight to
        the mixer), simulated pilot (off: the loop commands are the sticks).
    wind : tuple of float
        Constant wind, NED m/s.
    gyro_bias : ndarray, optional
        Gyro bias of the flight, rad/s; None: the vehicle's ``effects.gyro_bias`` or zero.
    loop_input : int
        How the per-step loop commands are read (``params.LOOP_*``).
    """
    if gyro_bias is None:
        fixed = vehicle.effects["gyro_bias"]
        gyro_bias = np.zeros(3) if fixed is None else np.asarray(fixed, dtype=float)
    trim_oge = hover_trim(vehicle)
    P = pack(vehicle, dt=dt, ground_effect=ground_effect, thr_hover=trim_oge.command,
             alt_hold=alt_hold, wind=wind, gyro_bias=gyro_bias, loop_input=loop_input,
             **({} if pilot else NO_PILOT))
    pos, spin, dists, mix = geometry(vehicle)
    rf_hz = float(vehicle["sensors"]["rangefinder_hz"])
    return Plant(vehicle=vehicle, P=P, inertia=effective_inertia(vehicle), rpos=pos,
                 spin=spin, dists=dists, mix=mix, dt=dt, noise_std=noise_std(vehicle),
                 rf_every=max(1, round(1.0 / (rf_hz * dt))), trim_oge=trim_oge,
                 delay_capacity=int(P[DELAY]) + 2)


def initial_state(plant: Plant, altitude: float, *, ground_effect: bool = True,
                  command: float | None = None) -> np.ndarray:
    """Full state vector of a steady level hover at CG height ``altitude`` (m).

    Rotor speeds and inflow from the hover trim at that height (ground effect if on), the
    altitude integrator pre-loaded with the trim's offset from the out-of-ground-effect
    hover command, estimator aligned with the truth, delay line filled with ``command``
    (default: the trim command).
    """
    veh = plant.vehicle
    trim = hover_trim(veh, altitude) if ground_effect else plant.trim_oge
    n_rot = plant.n_rotors
    o_lam, o_cs, o_est, _, o_buf = state_offsets(n_rot)
    S = np.zeros(o_buf + plant.delay_capacity * n_rot)
    S[X_POS + 2] = -altitude
    S[X_Q] = 1.0
    S[X_SOC] = veh["battery"]["soc0"]
    S[X_OM:X_OM + n_rot] = trim.omega
    S[o_lam:o_cs] = trim.lam_i
    S[o_cs + CS_IVZ] = np.clip(trim.command - plant.trim_oge.command, -INT_LIMIT, INT_LIMIT)
    est = S[o_est:o_est + N_EST]
    est[EST_Q:EST_Q + 4] = S[X_Q:X_Q + 4]
    est[EST_F + 2] = -plant.P[GRAV]
    est[EST_FL + 2] = -plant.P[GRAV]
    S[o_buf:] = trim.command if command is None else command
    return S


def set_attitude(S: np.ndarray, roll: float, pitch: float, yaw: float, n_rot: int) -> None:
    """Set the true attitude (rad) of a state vector, and align the estimator with it."""
    q = euler_to_quat(roll, pitch, yaw)
    S[X_Q:X_Q + 4] = q
    o_est = state_offsets(n_rot)[2]
    S[o_est + EST_Q:o_est + EST_Q + 4] = q
