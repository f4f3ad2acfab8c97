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
N_PARAMS = 66

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
    return p


def geometry(vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rotor positions (N,3), spins (N,), hub-to-hub distances (N,N), mixer (N,4)."""
    pos = vehicle.rotor_positions
    diff = pos[:, None, :2] - pos[None, :, :2]
    dists = np.sqrt(np.sum(diff**2, axis=-1))
    return pos, vehicle.spin, dists, vehicle.mixer
