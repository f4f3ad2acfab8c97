"""Pairs flown in the ``multirotor`` package: its Tarot T18 octocopter and its cascaded PID.

Vehicle: the package's ``tarott18`` model (8 × 18-inch rotors on 0.635 m arms, 10.7 kg,
thrust k ω², yaw torque k_d ω²; the package ships it with rotor speeds taking effect at
once, the pairs add a 40 ms first-order lag), integrated by the package (``odeint`` over
10 ms steps, state rounded to 1e-4) and
flown by its ArduPilot-style cascade (position → velocity → attitude → rate, altitude →
climb rate; gains set here) at 100 Hz through its control allocation. Added around it (the
package has no ground, drag or battery): a ground plane with landing gear, quadratic body
drag, a 6S pack with internal resistance whose voltage sets the rotor speed an ESC reaches.
Sensor model (:mod:`.common`): 100 Hz IMU, complementary filter with gain 3/s, 2 cm
rangefinder noise. Written as a MAVLink telemetry log: HIGHRES_IMU 100 Hz, ATTITUDE and
SERVO_OUTPUT_RAW 50 Hz, LOCAL_POSITION_NED 25 Hz, DISTANCE_SENSOR 20 Hz, SYS_STATUS 2 Hz.

Effects act through the package's parameters where it has them (k_thrust, k_drag, the
vehicle's mass and inertia — hidden from the controller, which keeps the nominal ones) and
otherwise through a wrapper around its dynamics (command delay, first-order motor lag,
rotor H-force, ground effect, torque offset, rate damping, rotor spin-up torque, battery
sag, steady wind on the body-drag law, tilted rotor axes) or the sensor model.
"""

from __future__ import annotations

from collections import deque
from copy import deepcopy
from typing import Any

import numpy as np

from .common import LEG_TURNS, Record, Sensors, bounded_walk

NAME = "multirotor"
LOG_SUFFIX = ".tlog"
LOG_RATES = {"HIGHRES_IMU": 100.0, "ATTITUDE": 50.0, "SERVO_OUTPUT_RAW": 50.0,
             "LOCAL_POSITION_NED": 25.0, "DISTANCE_SENSOR": 20.0, "SYS_STATUS": 2.0}
"""MAVLink stream rates of the written telemetry logs, Hz."""
DT = 0.01
"""Simulation and control step, s."""
OMEGA_MAX = 700.0
"""Rotor speed at motor output 1, rad/s (output = commanded speed / OMEGA_MAX)."""
OMEGA_MIN = 60.0
"""Idle rotor speed, rad/s."""
MOTOR_TAU = 0.04
"""First-order rotor speed lag, s, of every flight (the package ships the T18 with speeds
taking effect at once; with no lag a rotor's spin-up torque is an impulse train)."""
ROTOR_RADIUS = 0.2286
"""18-inch propeller radius, m."""
GEAR = 0.3
"""Height of the centre of gravity (and rotor hubs) above the ground when landed, m."""
BODY_DRAG = 0.25
"""Quadratic body drag, N/(m/s)²."""
V_FULL, V_EMPTY, CAPACITY_AS = 25.2, 21.0, 16000.0 * 3.6
"""6S pack: open-circuit voltage full/empty, V, and charge, A·s (16 Ah)."""
R_NOMINAL = 0.01
"""Nominal pack internal resistance, Ω."""
CURRENT_PER_CUBE = 60.0
"""Pack current per unit of Σ (ω/OMEGA_MAX)³, A (≈ 65 A in hover)."""
V_REF = 24.0
"""Pack voltage at which a commanded rotor speed is reached exactly."""

LABELS: tuple[str, ...] = (
    "none", "thrust_scale", "motor_lag", "time_delay", "rotor_drag", "inertia_scale",
    "torque_offset", "gyro_bias", "battery_sag", "ground_effect", "payload", "accel_bias",
    "wind", "weak_motor", "rate_damping", "yaw_torque_scale", "rotor_inertia", "none",
    "thrust_scale+time_delay", "gyro_scale", "imu_tilt", "motor_tilt", "none", "none",
)
"""The pairs of one seed (as :data:`.pyflyt_pairs.LABELS`)."""


def draw_effect(label: str, rng: np.random.Generator) -> tuple[dict[str, Any], dict[str, Any],
                                                                 dict[str, Any]]:
    """(physics parameters, sensor overrides, truth) of the REAL flight for ``label``."""
    fx: dict[str, Any] = {}
    sens: dict[str, Any] = {}
    truth: dict[str, Any] = {}
    for name in label.split("+"):
        if name == "thrust_scale":
            s = rng.uniform(0.82, 0.9) if rng.random() < 0.5 else rng.uniform(1.1, 1.2)
            fx["thrust_scale"] = truth["scale"] = s
        elif name == "motor_lag":
            fx["motor_tau"] = truth["tau"] = rng.uniform(0.1, 0.15)
        elif name == "time_delay":
            steps = int(rng.integers(2, 5))
            fx["delay_steps"] = steps
            truth["delay"] = steps * DT
        elif name == "rotor_drag":
            fx["rotor_drag"] = truth["h_force"] = rng.uniform(3.5e-4, 5.5e-4)
        elif name == "inertia_scale":
            fx["inertia_scale"] = truth["inertia"] = rng.uniform(1.3, 1.6)
        elif name == "torque_offset":
            acc = rng.uniform(0.5, 1.5, 2) * rng.choice([-1, 1], 2)
            fx["torque_offset_acc"] = truth["offset_acc_flu"] = [acc[0], acc[1], 0.0]
        elif name == "gyro_bias":
            b = rng.uniform(0.02, 0.05, 2) * rng.choice([-1, 1], 2)
            sens["gyro_bias"] = truth["bias_frd"] = (float(b[0]), float(b[1]), 0.0)
        elif name == "battery_sag":
            fx["r_internal"] = truth["r_internal"] = R_NOMINAL * rng.uniform(4.0, 6.0)
            fx["soc0"] = truth["soc0"] = rng.uniform(0.35, 0.55)
        elif name == "ground_effect":
            fx["ground_effect"] = truth["ge_law"] = [rng.uniform(0.35, 0.45),
                                                     rng.uniform(0.5, 0.65)]
        elif name == "payload":
            fx["mass_scale"] = truth["mass_scale"] = rng.uniform(1.15, 1.25)
        elif name == "accel_bias":
            bz = rng.uniform(0.4, 0.8) * rng.choice([-1, 1])
            bxy = rng.uniform(-0.15, 0.15, 2)
            sens["accel_bias"] = truth["bias_frd"] = (float(bxy[0]), float(bxy[1]), float(bz))
        elif name == "wind":
            # 5-7 m/s on the quadratic body drag: 0.6-1.1 m/s² on the T18
            speed, heading = rng.uniform(5.0, 7.0), rng.uniform(0, 2 * np.pi)
            fx["wind"] = truth["wind_enu"] = [speed * np.cos(heading), speed * np.sin(heading),
                                              0.0]
        elif name == "weak_motor":
            i = int(rng.integers(0, 8))
            fx["weak_motor"] = truth["weak_motor"] = [i, rng.uniform(0.8, 0.88)]
        elif name == "rate_damping":
            fx["rate_damping"] = truth["rate_damping"] = rng.uniform(2.0, 4.0)
        elif name == "yaw_torque_scale":
            s = rng.uniform(0.55, 0.7) if rng.random() < 0.5 else rng.uniform(1.4, 1.7)
            fx["yaw_scale"] = truth["yaw_scale"] = s
        elif name == "rotor_inertia":
            fx["rotor_inertia"] = truth["rotor_inertia"] = rng.uniform(0.6e-3, 1.2e-3)
        elif name == "gyro_scale":
            sens["gyro_scale"] = truth["gyro_scale"] = rng.uniform(1.10, 1.15)
        elif name == "imu_tilt":
            sens["imu_roll"] = truth["imu_roll"] = np.radians(rng.uniform(3.0, 5.0)) * \
                rng.choice([-1, 1])
        elif name == "motor_tilt":
            fx["motor_tilt"] = truth["motor_tilt"] = np.radians(rng.uniform(4.0, 7.0))
        elif name != "none":
            raise ValueError(f"multirotor pairs cannot express {name!r}")
    return fx, sens, truth


def _vehicle_class() -> type:
    """The package's Multirotor with true mass, inertia and force laws the controller does
    not see, and a rate loop that flies on the modelled gyro (imported lazily)."""
    from multirotor.coords import angular_to_euler_rate
    from multirotor.physics import apply_forces_torques
    from multirotor.simulation import Multirotor

    class EffectMultirotor(Multirotor):
        true_mass: float
        true_inertia: np.ndarray
        thrust_k: np.ndarray
        drag_k: np.ndarray
        thrust_unit: np.ndarray
        sensors: Sensors

        def rotor_loads(self, speeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """Force and torque (body FLU) of rotor speeds ``speeds`` (rad/s)."""
            thrust = self.thrust_k * speeds ** 2
            vec = self.thrust_unit * thrust[:, None]
            arms = self.params.propeller_vectors.T
            torque = np.cross(arms, vec).sum(axis=0)
            torque[2] += float(np.sum(self.params.clockwise * self.drag_k * speeds ** 2))
            return vec.sum(axis=0), torque

        def dxdt_speeds(self, t: float, x: np.ndarray, u: np.ndarray,
                        disturb_forces: np.ndarray = 0.0, disturb_torques: np.ndarray = 0.0,
                        params: Any = None) -> np.ndarray:
            forces, torques = self.rotor_loads(np.asarray(u, dtype=float))
            dxdt = apply_forces_torques(
                forces + disturb_forces, torques + disturb_torques, x.astype(self.dtype),
                self.simulation.g, self.true_mass, self.true_inertia,
                np.linalg.inv(self.true_inertia))
            return np.around(dxdt, self.dxdt_decimals)

        @property
        def euler_rate(self) -> np.ndarray:
            return angular_to_euler_rate(self.sensors.gyro(self.angular_rate), self.orientation)

    return EffectMultirotor


def _controller(vehicle: Any) -> Any:
    """The package's cascade with gains for the T18 (chosen here on no-effect flights)."""
    from multirotor.controller import (
        AltController,
        AltRateController,
        AttController,
        Controller,
        PosController,
        RateController,
        VelController,
    )

    def pid(kp: float, ki: float, kd: float, imax: float = 1.0) -> dict[str, Any]:
        return {"k_p": kp, "k_i": ki, "k_d": kd, "max_err_i": imax, "vehicle": vehicle}

    # the package stores k_i × (clipped integral) as the next integral, so k_i = 1 is the
    # one value that integrates (k_i < 1 leaks, k_i > 1 runs to the clip): I terms use 1
    ctrl = Controller(
        PosController(**pid(1.0, 0.0, 0.0), max_velocity=7.0, max_acceleration=2.0,
                      square_root_scaling=True, leashing=True),
        VelController(**pid(0.25, 0.0, 0.0), max_tilt=np.pi / 9),
        AttController(**pid(3.5, 0.0, 0.0)),
        RateController(**pid(10.0, 1.0, 0.0, 0.5), max_acceleration=10.0),
        AltController(**pid(1.2, 0.0, 0.0), max_velocity=2.0),
        AltRateController(**pid(3.0, 1.0, 0.0, 3.0)),
        period_p=0.1, period_a=DT, period_z=0.05)
    # yaw softer: the allocation has no axis priority, and a yaw demand beyond the
    # octocopter's ≈ 1 N m of yaw authority starves half the rotors (a flip on a yaw step)
    ctrl.ctrl_a.k_p[2] = 1.0
    ctrl.ctrl_r.k_p[2] = 3.0
    return ctrl


def _profile(kind: str, duration: float, rng: np.random.Generator) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """(times, references [x, y, z, yaw]) of a flight: take-off, manoeuvre, landing."""
    t = np.arange(0.0, duration, DT)
    ref = np.zeros((t.size, 4))
    t_up, t_land = 1.0, duration - 7.0
    start = t_up + 5.0
    if kind == "low":
        wander = 1.2 * ROTOR_RADIUS
        z0 = max(rng.uniform(2.8, 3.5) * ROTOR_RADIUS, GEAR + wander + 0.06)
    else:
        z0 = rng.uniform(4.0, 8.0)
        wander = rng.uniform(0.6, 1.0)
    step_t = np.cumsum(rng.uniform(2.5, 4.5, 100)) + start
    idx = np.clip(np.searchsorted(step_t, t) - 1, 0, step_t.size - 1)
    active = (t > start) & (t < t_land - 2.0)
    if kind == "forward":
        speed = rng.uniform(5.0, 6.5)
        heading0, leg = rng.uniform(-np.pi + 0.35, -0.35), rng.uniform(5.0, 7.0)
        xy, yaw = np.zeros(2), heading0
        for i in range(t.size):
            if active[i]:
                k = int((t[i] - start) // leg)
                yaw = heading0 + LEG_TURNS[k % 4] * np.pi / 2 + 0.3 * np.sin(0.7 * k)
                xy = xy + speed * DT * np.array([np.cos(yaw), np.sin(yaw)])
            ref[i, :2], ref[i, 3] = xy, yaw
    else:
        reach = 1.0 if kind == "low" else 2.5
        xs = rng.uniform(-reach, reach, (step_t.size, 2))
        yaws = bounded_walk(rng, step_t.size, 0.35, 1.4)
        ref[:, :2] = np.where(active[:, None], xs[idx], 0.0)
        ref[:, 3] = np.where(active, yaws[idx], 0.0)
    zs = z0 + wander * rng.uniform(-1.0, 1.0, step_t.size)
    z_man = np.where(t > start, zs[idx], max(z0, 2.0)) + 0.4 * wander * np.sin(
        2 * np.pi * t / rng.uniform(5.0, 9.0))
    ramp_up = np.clip((t - t_up) / 4.0, 0.0, 1.0)
    ramp_down = np.clip((t_land - t) / 5.0, 0.0, 1.0)
    ref[:, 2] = GEAR + np.minimum(ramp_up, ramp_down) * (z_man - GEAR) - 0.3 * (t > t_land + 5.0)
    return t, ref


def fly(kind: str, duration: float, seed: int, vehicle: dict[str, float],
        fx: dict[str, Any], sensors: Sensors) -> Record:
    """One flight of ``duration`` s (profile ``kind``: hover, low or forward) with physics
    effects ``fx``; true state logged every 10 ms step."""
    from multirotor.models.tarott18 import VP
    from multirotor.vehicle import SimulationParams

    rng = np.random.default_rng(seed)
    params = deepcopy(VP)
    params.mass = VP.mass * vehicle["mass"]
    params.inertia_matrix = np.asarray(VP.inertia_matrix, dtype=float) * vehicle["inertia"]
    sim = SimulationParams(dt=DT, g=9.81, dtype=np.float64)
    veh = _vehicle_class()(params, sim)
    n_rot = len(params.propellers)
    veh.sensors = sensors
    veh.true_mass = params.mass * fx.get("mass_scale", 1.0)
    veh.true_inertia = params.inertia_matrix * fx.get("inertia_scale", 1.0)
    veh.thrust_k = np.array([p.k_thrust for p in params.propellers]) * fx.get("thrust_scale", 1.0)
    veh.drag_k = np.array([p.k_drag for p in params.propellers]) * fx.get("yaw_scale", 1.0)
    if "weak_motor" in fx:
        i, s = fx["weak_motor"]
        veh.thrust_k[int(i)] *= s
    arms = params.propeller_vectors.T
    unit = np.tile([0.0, 0.0, 1.0], (n_rot, 1))
    if "motor_tilt" in fx:
        # every rotor axis tilted outward along its arm (the octocopter's yaw authority,
        # ≈ 1 N m, cannot hold the yaw torque of a tangential tilt of even 1°)
        d = fx["motor_tilt"]
        radial = arms[:, :2] / np.linalg.norm(arms[:, :2], axis=1)[:, None]
        unit = np.column_stack([np.sin(d) * radial, np.full(n_rot, np.cos(d))])
    veh.thrust_unit = unit
    ctrl = _controller(veh)
    veh.state[2] = GEAR
    t, ref = _profile(kind, duration, rng)
    n = t.size
    out = {k: np.zeros((n, 3)) for k in ("pos", "vel", "rates", "force")}
    rot, motors, vbat = np.zeros((n, 3, 3)), np.zeros((n, n_rot)), np.zeros(n)
    queue: deque = deque()
    speed = np.full(n_rot, OMEGA_MIN)
    soc, volts = fx.get("soc0", 0.95), V_FULL
    torque_offset = veh.true_inertia @ np.asarray(fx.get("torque_offset_acc", [0.0, 0.0, 0.0]))
    wind = np.asarray(fx.get("wind", [0.0, 0.0, 0.0]))
    from multirotor.coords import direction_cosine_matrix

    for i in range(n):
        grounded = veh.state[2] <= GEAR + 1e-6
        if grounded:  # landed: the autopilot holds its integrators at zero
            for loop in (ctrl.ctrl_vz, ctrl.ctrl_r, ctrl.ctrl_v):
                loop.err_i *= 0.0
        action = ctrl.step(ref[i])
        cmd = np.clip(veh.allocate_control(action[0], action[1:4]), OMEGA_MIN, OMEGA_MAX)
        if grounded and ref[i, 2] <= GEAR + 0.02:
            cmd = np.full(n_rot, OMEGA_MIN)  # on the ground, nothing to climb to: idle
        motors[i] = cmd / OMEGA_MAX
        if fx.get("delay_steps"):
            queue.append(cmd)
            cmd = queue.popleft() if len(queue) > fx["delay_steps"] else queue[0]
        # battery: an ESC without governor reaches the commanded speed at V_REF only
        current = CURRENT_PER_CUBE * float(np.sum((speed / OMEGA_MAX) ** 3))
        soc -= current * DT / CAPACITY_AS
        volts = V_EMPTY + (V_FULL - V_EMPTY) * np.clip(soc, 0.0, 1.0) - fx.get(
            "r_internal", R_NOMINAL) * current
        target = cmd * volts / V_REF
        last = speed
        tau = fx.get("motor_tau", MOTOR_TAU)
        speed = speed + (target - speed) * min(1.0, DT / tau)
        r_wb = direction_cosine_matrix(*veh.orientation).T
        v_world = r_wb @ veh.velocity
        v_air = v_world - wind
        f_body = r_wb.T @ (-BODY_DRAG * np.linalg.norm(v_air) * v_air)
        m_body = torque_offset - fx.get("rate_damping", 0.0) * (veh.true_inertia @
                                                                  veh.angular_rate)
        if "rotor_drag" in fx:
            f_body[:2] -= fx["rotor_drag"] * float(np.sum(speed)) * veh.velocity[:2]
        if "rotor_inertia" in fx:
            m_body[2] += fx["rotor_inertia"] * float(np.sum(params.clockwise * (speed - last)) / DT)
        if "ground_effect" in fx:
            a, b = fx["ground_effect"]
            hub_z = veh.position[2] + (arms @ r_wb.T)[:, 2]
            extra = veh.thrust_k * speed ** 2 * a * np.exp(-b * np.maximum(hub_z, 0.05)
                                                            / ROTOR_RADIUS)
            f_body[2] += float(np.sum(extra))
            m_body += np.cross(arms, np.column_stack([0 * extra, 0 * extra, extra])).sum(axis=0)
        loads_f, _ = veh.rotor_loads(speed)
        veh.step_speeds(speed, disturb_forces=f_body, disturb_torques=m_body)
        if veh.state[2] < GEAR:  # the ground: the gear stops the fall, the vehicle rests level
            veh.state[2] = GEAR
            veh.state[3:6] = 0.0
            veh.state[6:8] = 0.0
            veh.state[9:12] = 0.0
        r_wb = direction_cosine_matrix(*veh.orientation).T
        out["pos"][i] = veh.position
        out["vel"][i] = r_wb @ veh.velocity
        out["rates"][i] = veh.angular_rate
        out["force"][i] = (loads_f + f_body) / veh.true_mass
        rot[i], vbat[i] = r_wb, volts
    on_ground = out["pos"][:, 2] <= GEAR + 1e-6
    out["force"][on_ground] = [0.0, 0.0, 9.81]
    return Record(t=t, pos=out["pos"], vel=out["vel"], rot=rot, rates=out["rates"],
                  spec_force=out["force"], motors=motors, vbat=vbat, ground_height=GEAR,
                  extra={"reference": ref})


def random_vehicle(rng: np.random.Generator) -> dict[str, float]:
    """Per-pair vehicle spread shared by SIM and REAL: mass and inertia."""
    return {"mass": float(rng.uniform(0.9, 1.1)), "inertia": float(rng.uniform(0.9, 1.1))}


def sensors(rng: np.random.Generator, noisier: bool, overrides: dict[str, Any]) -> Sensors:
    """The octocopter set's sensor model; the "recording" has 10-30 % more IMU noise."""
    k = rng.uniform(1.1, 1.3) if noisier else 1.0
    return Sensors(gyro_std=0.006 * k, accel_std=0.12 * k, filter_gain=3.0,
                   reference_std=0.004, alt_std=0.02, vel_std=0.05, vbat_std=0.05,
                   **overrides)


def flight_kind(label: str, rng: np.random.Generator) -> tuple[str, str]:
    """(SIM profile, REAL profile), as :func:`.pyflyt_pairs.flight_kind`."""
    if "ground_effect" in label:
        return "low", "low"
    if "rotor_drag" in label or "wind" in label:
        return "forward", "forward"
    return "hover", "hover"
