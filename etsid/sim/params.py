"""Flat float64 parameter vector handed to the numba kernels, and the state layout.

Numba reads the module-level integer indices below as compile-time constants, so the
kernels can take one ``P`` array instead of fifty scalars. :func:`pack` fills it from a
:class:`~etsid.sim.vehicle.Vehicle` and the run options.
"""

from __future__ import annotations

import math

import numpy as np

from etsid.sim.ground import CHEESEMAN_BENNETT, SANCHEZ_CUEVAS
from etsid.sim.vehicle import Vehicle

# --- state vector x -------------------------------------------------------------------
X_POS = 0   # NED position, m (3)
X_VEL = 3   # NED velocity, m/s (3)
X_Q = 6     # attitude quaternion body->NED, scalar first (4)
X_W = 10    # body rate p q r, rad/s (3)
X_SOC = 13  # battery state of charge, 0..1
X_OM = 14   # rotor speeds, rad/s (N)

# --- physics ----------------------------------------------------------------------------
MASS = 0
GRAV = 1
RHO = 2
RADIUS = 3
SIGMA = 4
LIFT = 5
TH0 = 6
TWIST = 7
CD0 = 8
KAPPA = 9
J_ROT = 10
TAU_M = 11
W_MAX = 12
W_IDLE = 13
V_REF = 14
CELLS = 15
CAP_AH = 16
R_INT = 17
EFF = 18
SAG = 19
SOC0 = 20
DRAG_L = 21  # 3
DRAG_Q = 24  # 3
ROTOR_DRAG = 27
GE_ON = 28
GE_MODEL = 29
K_BODY = 30
GE_MAXR = 31
GE_MINH = 32
GEAR_H = 33
K_CONTACT = 34
C_CONTACT = 35
ARM = 36
WIND = 37  # 3, NED m/s
DT = 40
# --- controller ---------------------------------------------------------------------------
RATE_KP = 41  # 3
RATE_KI = 44  # 3
RATE_KD = 47  # 3
DCUT = 50
ANGLE_KP = 51
MAX_TILT = 52
MAX_RATE = 53
MAX_YAW_RATE = 54
YAW_MIX = 55
ALT_KP = 56
VZ_KP = 57
VZ_KI = 58
MAX_CLIMB = 59
THR_HOVER = 60
ALT_HOLD = 61
PILOT_KV = 62
PILOT_KI = 63
PILOT_KPSI = 64
PILOT_TAU = 65
# --- optional effects (vehicle [effects]; neutral values reproduce the plain model) -------
TAU_DN = 66        # s, spin-down time constant (TAU_M is spin-up)
THRUST_SCALE = 67
TORQUE_SCALE = 68
CG = 69            # 3, m, CG position from the geometric centre, body FRD
M_OFF = 72         # 3, N m, constant body moment
GYRO_BIAS = 75     # 3, rad/s
ACCEL_BIAS = 78    # 3, m/s^2
EST_ON = 81        # 1: Mahony attitude estimator feeds the controller and the log
EST_KP = 82
EST_KI = 83
GE_TORQUE = 84     # 1: reaction torque from the in-ground-effect inflow
DELAY = 85         # command -> motor transport delay, in physics steps (fractional)
LOOP_INPUT = 86    # what the per-step loop commands are (LOOP_* below)
WEAK_MOTOR = 87    # 1-based rotor whose thrust and torque are scaled (0: none)
WEAK_SCALE = 88    # its thrust and torque multiplier
LOG_MEAN = 89      # 1: a log row's motor outputs are the mean over its period (0: the sample)
MOUNT_SIN = 90     # sin of every rotor axis's twist about its arm (+: a nose-right yaw)
N_PARAMS = 91

# LOOP_INPUT values: how the per-step command array ``exc`` is read
LOOP_STICKS = 0    # added to the pilot's sticks (pilot off: the sticks), angle mode
LOOP_RATES = 1     # body-rate setpoints, rad/s (pilot and angle loop bypassed)
LOOP_TORQUE = 2    # normalised torque demands -1..1 (pilot, angle and rate loops bypassed)
LOOP_MOTORS = 3    # motor outputs 0..1 from the per-step motor array (whole controller off)

# --- noise columns (pre-scaled by their standard deviations) ----------------------------
NZ_GYRO = 0
NZ_ATT = 3
NZ_VEL = 6
NZ_ALT = 9
NZ_ACC = 10
NZ_VBAT = 13
N_NOISE = 14


def open_circuit_voltage(cells: float, soc: float) -> float:
    """Open-circuit LiPo pack voltage, V: cells · (3.5 + 0.7 soc) (linear 3.5–4.2 V/cell)."""
    return cells * (3.5 + 0.7 * soc)


def pack(
    vehicle: Vehicle, *, dt: float, ground_effect: bool, thr_hover: float, alt_hold: bool,
    wind: tuple[float, float, float] = (0.0, 0.0, 0.0), pilot_kv: float = 0.08,
    pilot_ki: float = 0.02, pilot_kpsi: float = 0.3, pilot_tau: float = 0.3,
    gyro_bias: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0),
    loop_input: int = LOOP_STICKS,
) -> np.ndarray:
    """Build the parameter vector ``P`` for the kernels.

    Parameters
    ----------
    vehicle : Vehicle
        Validated vehicle.
    dt : float
        Integration (and control) step, s.
    ground_effect : bool
        Apply the vehicle's ground-effect model.
    thr_hover : float
        Hover collective command (0..1) the altitude controller starts from.
    alt_hold : bool
        Altitude hold on (else the collective follows the manual throttle reference).
    wind : tuple of float
        Constant wind, NED m/s.
    pilot_kv, pilot_ki, pilot_kpsi, pilot_tau : float
        Simulated pilot: stick per m/s of velocity error, stick per m of integrated error,
        yaw stick per rad of heading error, stick low-pass time constant (s).
    gyro_bias : array-like
        Gyro bias of this flight, rad/s (the vehicle's ``effects.gyro_bias`` if set, else
        a draw from ``sensors.gyro_bias_std``: chosen by the caller).
    loop_input : int
        How the per-step loop commands are read (``LOOP_STICKS`` … ``LOOP_MOTORS``).
    """
    r = vehicle["rotor"]
    m = vehicle["motor"]
    b = vehicle["battery"]
    d = vehicle["drag"]
    g = vehicle["ground"]
    c = vehicle["controller"]
    e = vehicle["environment"]
    p = np.zeros(N_PARAMS)
    p[MASS] = vehicle.mass
    p[GRAV] = e["gravity"]
    p[RHO] = e["air_density"]
    p[RADIUS] = r["radius"]
    p[SIGMA] = vehicle.solidity
    p[LIFT] = r["lift_slope"]
    p[TH0] = vehicle.theta_0
    p[TWIST] = r["twist"]
    p[CD0] = r["cd0"]
    p[KAPPA] = r["kappa"]
    p[J_ROT] = r["inertia"]
    p[TAU_M] = m["time_constant"]
    p[W_MAX] = m["omega_max"]
    p[W_IDLE] = m["omega_idle"]
    p[V_REF] = m["v_ref"]
    p[CELLS] = b["cells"]
    p[CAP_AH] = b["capacity_ah"]
    p[R_INT] = b["r_internal"]
    p[EFF] = b["efficiency"]
    p[SAG] = 1.0 if b["sag"] else 0.0
    p[SOC0] = b["soc0"]
    p[DRAG_L:DRAG_L + 3] = d["linear"]
    p[DRAG_Q:DRAG_Q + 3] = d["quadratic"]
    p[ROTOR_DRAG] = d["rotor_drag"]
    p[GE_ON] = 1.0 if ground_effect else 0.0
    p[GE_MODEL] = SANCHEZ_CUEVAS if g["model"] == "sanchez-cuevas" else CHEESEMAN_BENNETT
    p[K_BODY] = g["k_body"]
    p[GE_MAXR] = g["max_ratio"]
    p[GE_MINH] = g["min_height_ratio"]
    p[GEAR_H] = g["gear_height"]
    p[K_CONTACT] = g["contact_stiffness"]
    p[C_CONTACT] = g["contact_damping"]
    p[ARM] = vehicle["frame"]["arm_length"]
    p[WIND:WIND + 3] = wind
    p[DT] = dt
    p[RATE_KP:RATE_KP + 3] = c["rate_kp"]
    p[RATE_KI:RATE_KI + 3] = c["rate_ki"]
    p[RATE_KD:RATE_KD + 3] = c["rate_kd"]
    p[DCUT] = c["dterm_cutoff_hz"]
    p[ANGLE_KP] = c["angle_kp"]
    p[MAX_TILT] = math.radians(c["max_tilt_deg"])
    p[MAX_RATE] = math.radians(c["max_rate_deg"])
    p[MAX_YAW_RATE] = math.radians(c["max_yaw_rate_deg"])
    p[YAW_MIX] = c["yaw_mix_limit"]
    p[ALT_KP] = c["alt_kp"]
    p[VZ_KP] = c["vz_kp"]
    p[VZ_KI] = c["vz_ki"]
    p[MAX_CLIMB] = c["max_climb"]
    p[THR_HOVER] = thr_hover
    p[ALT_HOLD] = 1.0 if alt_hold else 0.0
    p[PILOT_KV] = pilot_kv
    p[PILOT_KI] = pilot_ki
    p[PILOT_KPSI] = pilot_kpsi
    p[PILOT_TAU] = pilot_tau
    fx = vehicle.effects
    lag = fx["motor_lag"]
    p[TAU_DN] = m["time_constant"] if lag is None else lag[1]
    if lag is not None:
        p[TAU_M] = lag[0]
    p[THRUST_SCALE] = fx["thrust_scale"]
    p[TORQUE_SCALE] = fx["torque_scale"]
    p[CG:CG + 3] = fx["cg_offset"]
    p[M_OFF:M_OFF + 3] = fx["torque_offset"]
    p[GYRO_BIAS:GYRO_BIAS + 3] = gyro_bias
    p[ACCEL_BIAS:ACCEL_BIAS + 3] = fx["accel_bias"]
    p[EST_ON] = 1.0 if fx["estimator"] == "mahony" else 0.0
    p[EST_KP] = fx["estimator_kp"]
    p[EST_KI] = fx["estimator_ki"]
    p[GE_TORQUE] = 1.0 if fx["ground_effect_torque"] else 0.0
    steps = fx["time_delay"] / dt
    p[DELAY] = round(steps) if abs(steps - round(steps)) < 1e-9 else steps
    p[LOOP_INPUT] = loop_input
    weak = fx["weak_motor"]
    p[WEAK_MOTOR], p[WEAK_SCALE] = (0.0, 1.0) if weak is None else (weak[0], weak[1])
    p[MOUNT_SIN] = math.sin(math.radians(fx["rotor_twist"]))
    return p


def effective_inertia(vehicle: Vehicle) -> np.ndarray:
    """Inertia tensor with ``effects.inertia_scale`` applied, kg m².

    A scalar s gives s·J; three factors (sx, sy, sz) give S J S with S = diag(√s), so each
    principal moment scales by its factor and the tensor stays positive definite.
    """
    scale = vehicle.effects["inertia_scale"]
    inertia = vehicle.inertia
    if isinstance(scale, list):
        root = np.sqrt(np.asarray(scale))
        return inertia * root[:, None] * root[None, :]
    return inertia if scale == 1.0 else inertia * scale


def geometry(vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rotor positions (N,3), spins (N,), hub-to-hub distances (N,N), mixer (N,4)."""
    pos = vehicle.rotor_positions
    diff = pos[:, None, :2] - pos[None, :, :2]
    dists = np.sqrt(np.sum(diff**2, axis=-1))
    return pos, vehicle.spin, dists, vehicle.mixer
