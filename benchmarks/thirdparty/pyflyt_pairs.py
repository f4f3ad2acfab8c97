"""Pairs flown in PyFlyt (PyBullet): the Crazyflie 2.x quadrotor ``cf2x`` and its cascaded PID.

Vehicle: PyFlyt's QuadX, 27 g, X layout, first-order motor ramp (``tau``), thrust ∝ (throttle
× max rpm)² with no idle offset, quadratic rotational damping and quadratic body drag
(PyFlyt's own laws), flown by PyFlyt's position cascade (flight mode 7: x, y, yaw, z) at
120 Hz on 240 Hz physics. Sensor model (:mod:`.common`): 120 Hz IMU, complementary filter
with gain 1/s, 1 cm rangefinder noise. Written as an MCAP file with MAVROS topics (ROS 2
encoding): IMU 120 Hz, motor outputs 60 Hz, velocity and range 30 Hz, battery 5 Hz.

Effects act through PyFlyt's own parameters where it has them (thrust and torque
coefficients, motor ``tau``, the URDF's mass and inertia, its wind field on the body-drag
law, the motors' thrust axes) and through a wrapper around its physics step otherwise
(command delay, rotor H-force, ground effect, torque offset, linear rate damping on top of
PyFlyt's small quadratic one, rotor spin-up torque, a 1S battery with internal resistance
whose voltage sets the motors' top speed) or the sensor model (gyro bias, accelerometer
bias, gyro scale, tilted IMU).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from .common import LEG_TURNS, Record, Sensors, bounded_walk

NAME = "pyflyt"
LOG_SUFFIX = ".mcap"
LOG_RATES = {"imu": 120.0, "rc_out": 60.0, "velocity": 30.0, "range": 30.0, "battery": 5.0}
"""MAVROS stream rates of the written MCAP files, Hz."""
LOW_FLIGHT_SUFFIX = ".parquet"
"""Ground-effect pairs fly 3-9 cm above the resting height; etsid's MAVROS writer gives its
rangefinder a 5 cm minimum range (readings below it are invalid, the resting height is
never seen), so these pairs are written as FlightTables instead (and a quarter of the
others too, chosen by their shuffled pair number, so that the format tells nothing)."""
CONTROL_HZ = 120
PHYSICS_HZ = 240
ROTOR_RADIUS = 0.023
"""Crazyflie 2.x propeller radius, m (46 mm propellers)."""
REST_HEIGHT = 0.010
"""Height of the cf2x base above the ground plane when it rests on it, m (measured)."""
V_FULL, V_EMPTY, CAPACITY_AS = 4.15, 3.55, 900.0
"""1S pack: open-circuit voltage full/empty, V, and charge, A·s (250 mAh)."""
R_NOMINAL = 0.03
"""Nominal pack internal resistance, Ω."""
CURRENT_PER_CUBE = 22.0
"""Pack current per unit of Σ throttle³, A (≈ 4 A in hover)."""
CURRENT_LIMIT = 12.0
"""Pack current limit, A (PyFlyt's cf2x has 7× its weight in thrust; the cube law alone
would draw 88 A at full throttle)."""
V_REF = 4.0
"""Voltage at which the motors reach PyFlyt's max rpm."""

LABELS: tuple[str, ...] = (
    "none", "thrust_scale", "motor_lag", "time_delay", "rotor_drag", "inertia_scale",
    "torque_offset", "gyro_bias", "battery_sag", "ground_effect", "payload", "accel_bias",
    "wind", "weak_motor", "rate_damping", "yaw_torque_scale", "rotor_inertia", "none",
    "thrust_scale+time_delay", "gyro_scale", "imu_tilt", "motor_tilt", "none", "none",
)
"""The pairs of one seed: every expressible effect of the vocabulary, 4 no-effect pairs,
one combination and three out-of-vocabulary changes."""


def _quadx_class() -> type:
    """PyFlyt's QuadX with hooks for the concealed effects (imported lazily)."""
    from PyFlyt.core.drones.quadx import QuadX

    class EffectQuadX(QuadX):
        """QuadX whose physics step carries extra laws and whose rate loop flies on the
        modelled gyro. ``fx`` holds the effect parameters (set after construction)."""

        fx: dict[str, Any]
        sensors: Sensors

        def arm_effects(self, fx: dict[str, Any], sensors: Sensors) -> None:
            self.fx = fx
            self.sensors = sensors
            self.max_rpm0 = self.motors.max_rpm.copy()
            self.pwm_queue: deque = deque()
            self.soc = fx.get("soc0", 0.95)
            self.vbat = V_FULL
            self.spin = np.sign(self.motors.torque_coef[:, 0])
            self.injection = np.zeros(3)

        def update_control(self) -> None:
            true = self.state
            meas = true.copy()
            meas[0] = self.sensors.gyro(true[0])
            self.state = meas
            try:
                super().update_control()
            finally:
                self.state = true
            if np.any(self.injection) and self.mode != -1:
                # system-identification input at the mixer (ArduPilot's SystemID mode
                # injects there too): roll, pitch and yaw commands added to the cascade's
                self.pwm = np.clip(self.pwm + self.motor_map[:, :3] @ self.injection,
                                   0.05, 1.0)

        def update_physics(self) -> None:
            fx, dt = self.fx, self.physics_period
            pwm = np.asarray(self.pwm, dtype=float).copy()
            delay = fx.get("delay_steps", 0)
            if delay:
                self.pwm_queue.append(pwm)
                pwm = self.pwm_queue.popleft() if len(self.pwm_queue) > delay else \
                    self.pwm_queue[0]
            # spin-up: the deterministic part of the motor ramp (PyFlyt's throttle noise
            # is per-step jitter, not a rotor acceleration)
            spin_up = (pwm - self.motors.throttle) / self.motors.tau * self.motors.max_rpm
            # battery: open-circuit voltage falls with charge, sags with current
            current = min(CURRENT_PER_CUBE * float(np.sum(np.clip(self.motors.throttle, 0, 1)
                                                          ** 3)), CURRENT_LIMIT)
            self.soc -= current * dt / CAPACITY_AS
            v_oc = V_EMPTY + (V_FULL - V_EMPTY) * np.clip(self.soc, 0.0, 1.0)
            self.vbat = v_oc - fx.get("r_internal", R_NOMINAL) * current
            self.motors.max_rpm = self.max_rpm0 * (self.vbat / V_REF)
            self.body.physics_update()
            self.motors.physics_update(pwm)
            airborne = len(self.p.getContactPoints()) == 0
            omega = self.motors.throttle * self.motors.max_rpm
            thrust = self.motors.thrust_coef[:, 0] * omega ** 2
            torque = -np.sign(self.state[0]) * self.drag_coef_pqr * self.state[0] ** 2
            force = np.zeros(3)
            if "torque_offset" in fx:
                torque = torque + np.asarray(fx["torque_offset"])
            if "rotor_inertia" in fx:
                torque[2] += fx["rotor_inertia"] * float(np.sum(self.spin * spin_up))
            if "rate_damping" in fx:
                torque = torque - fx["rate_damping"] * self.inertia * np.asarray(self.state[0])
            if "rotor_drag" in fx:
                v_body = self.state[2]
                force[:2] -= fx["rotor_drag"] * float(np.sum(self.motors.throttle)) * v_body[:2]
            if "ground_effect" in fx:
                a, b = fx["ground_effect"]
                for i, link in enumerate(self.motors.motor_ids):
                    z = max(self.p.getLinkState(self.Id, link)[0][2], 1e-3)
                    extra = thrust[i] * a * np.exp(-b * z / ROTOR_RADIUS)
                    self.p.applyExternalForce(self.Id, link, [0.0, 0.0, extra], [0.0, 0.0, 0.0],
                                              self.p.LINK_FRAME)
            if airborne:
                self.p.applyExternalTorque(self.Id, -1, torque.tolist(), self.p.LINK_FRAME)
                if np.any(force):
                    self.p.applyExternalForce(self.Id, -1, force.tolist(), [0.0, 0.0, 0.0],
                                              self.p.LINK_FRAME)

    return EffectQuadX


def draw_effect(label: str, rng: np.random.Generator) -> tuple[dict[str, Any], dict[str, Any],
                                                                 dict[str, Any]]:
    """(physics parameters, sensor overrides, truth) of the REAL flight for ``label``."""
    fx: dict[str, Any] = {}
    sens: dict[str, Any] = {}
    truth: dict[str, Any] = {}
    for name in label.split("+"):
        if name == "thrust_scale":
            s = rng.uniform(0.8, 0.9) if rng.random() < 0.5 else rng.uniform(1.1, 1.2)
            fx["thrust_scale"] = truth["scale"] = s
        elif name == "motor_lag":
            fx["tau_scale"] = truth["tau_scale"] = rng.uniform(2.5, 4.0)
        elif name == "time_delay":
            steps = int(rng.integers(2, 5))  # 8-17 ms (25 ms makes the rate loop ring)
            fx["delay_steps"] = steps
            truth["delay"] = steps / PHYSICS_HZ
        elif name == "rotor_drag":
            fx["rotor_drag"] = truth["h_force"] = rng.uniform(0.003, 0.0045)
        elif name == "inertia_scale":
            fx["inertia_scale"] = truth["inertia"] = rng.uniform(1.3, 1.6)
        elif name == "torque_offset":
            acc = rng.uniform(6.0, 15.0, 2) * rng.choice([-1, 1], 2)
            fx["torque_offset_acc"] = truth["offset_acc_flu"] = [acc[0], acc[1], 0.0]
        elif name == "gyro_bias":
            b = rng.uniform(0.02, 0.05, 2) * rng.choice([-1, 1], 2)
            sens["gyro_bias"] = truth["bias_frd"] = (float(b[0]), float(b[1]), 0.0)
        elif name == "battery_sag":
            fx["r_internal"] = truth["r_internal"] = R_NOMINAL * rng.uniform(1.8, 2.5)
            fx["soc0"] = truth["soc0"] = rng.uniform(0.55, 0.7)
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
            # 3-4 m/s: PyFlyt's wind acts on its body-drag law only (≈ 0.3-0.6 m/s² on 27 g)
            speed, heading = rng.uniform(3.0, 4.0), rng.uniform(0, 2 * np.pi)
            fx["wind"] = truth["wind_enu"] = [speed * np.cos(heading), speed * np.sin(heading),
                                              0.0]
        elif name == "weak_motor":
            i = int(rng.integers(0, 4))
            fx["weak_motor"] = truth["weak_motor"] = [i, rng.uniform(0.8, 0.88)]
        elif name == "rate_damping":
            fx["rate_damping"] = truth["rate_damping"] = rng.uniform(5.0, 8.0)
        elif name == "yaw_torque_scale":
            s = rng.uniform(0.55, 0.7) if rng.random() < 0.5 else rng.uniform(1.4, 1.7)
            fx["yaw_scale"] = truth["yaw_scale"] = s
        elif name == "rotor_inertia":
            fx["rotor_inertia"] = truth["rotor_inertia"] = rng.uniform(1.5e-9, 3.0e-9)
        elif name == "gyro_scale":
            sens["gyro_scale"] = truth["gyro_scale"] = rng.uniform(1.10, 1.15)
        elif name == "imu_tilt":
            sens["imu_roll"] = truth["imu_roll"] = np.radians(rng.uniform(3.0, 5.0)) * \
                rng.choice([-1, 1])
        elif name == "motor_tilt":
            fx["motor_tilt"] = truth["motor_tilt"] = np.radians(rng.uniform(4.0, 7.0))
        elif name != "none":
            raise ValueError(f"pyflyt pairs cannot express {name!r}")
    return fx, sens, truth


def _profile(kind: str, duration: float, rng: np.random.Generator, rest: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """(times, setpoints [x, y, yaw, z]) of a flight: take-off, manoeuvre, landing."""
    dt = 1.0 / CONTROL_HZ
    t = np.arange(0.0, duration, dt)
    sp = np.zeros((t.size, 4))
    t_up, t_land = 1.0, duration - 5.0
    if kind == "low":
        # hubs wandering through z/R ≈ 2-4.5 (3.5-8.5 cm above the resting height)
        wander = 1.1 * ROTOR_RADIUS
        z0 = rest + 0.035 + wander + rng.uniform(0.0, 0.01)
    else:
        z0 = rng.uniform(0.8, 1.4)
        wander = rng.uniform(0.2, 0.35)
    step_t = np.cumsum(rng.uniform(1.0, 2.2, 200)) + t_up + 3.0
    if kind == "forward":
        speed = rng.uniform(1.6, 2.0)
        heading0 = rng.uniform(-np.pi + 0.35, -0.35)
        leg = rng.uniform(2.5, 3.5)
        xy = np.zeros(2)
        yaw = heading0
        for i in range(t.size):
            if t[i] > t_up + 3.0 and t[i] < t_land - 1.0:
                k = int((t[i] - t_up - 3.0) // leg)
                yaw = heading0 + LEG_TURNS[k % 4] * np.pi / 2 + 0.3 * np.sin(0.7 * k)
                xy = xy + speed * dt * np.array([np.cos(yaw), np.sin(yaw)])
            sp[i, :2], sp[i, 2] = xy, yaw
    else:
        reach = 0.4 if kind == "low" else 1.5
        xs = rng.uniform(-reach, reach, (step_t.size, 2))
        yaws = bounded_walk(rng, step_t.size, 0.7, 1.4)
        idx = np.clip(np.searchsorted(step_t, t) - 1, 0, step_t.size - 1)
        active = (t > t_up + 3.0) & (t < t_land - 1.0)
        sp[:, :2] = np.where(active[:, None], xs[idx], 0.0)
        sp[:, 2] = np.where(active, yaws[idx], 0.0)
    zs = z0 + wander * rng.uniform(-1.0, 1.0, step_t.size)
    idx = np.clip(np.searchsorted(step_t, t) - 1, 0, step_t.size - 1)
    z_man = np.where(t > t_up + 3.0, zs[idx], max(z0, 0.4)) + 0.4 * wander * np.sin(
        2 * np.pi * t / rng.uniform(4.0, 7.0))
    ramp_up = np.clip((t - t_up) / 0.5, 0.0, 1.0)  # a firm take-off (PyFlyt's z loop is slow)
    ramp_down = np.clip((t_land - t) / 2.5, 0.0, 1.0)
    sp[:, 3] = np.minimum(ramp_up, ramp_down) * z_man - 0.05 * (t > t_land + 2.5)
    return t, sp


EXCITATION_PWM = {"roll": (0.010, 0.016), "pitch": (0.010, 0.016), "yaw": (0.04, 0.06)}
"""Amplitude range of the 3-2-1-1 inputs at the mixer, throttle units (hover ≈ 0.38):
30-50 rad/s² in roll and pitch against PyFlyt's 3-4 rad/s² of motor-noise acceleration."""
EXCITATION_PERIOD = (1.8, 3.0)
"""Time between the starts of two manoeuvres, s."""
EXCITATION_PULSE = (0.04, 0.09)
"""Unit pulse of a 3-2-1-1 input, s (the whole input lasts 7 units)."""
excite_flights = False
"""Fly the 3-2-1-1 inputs (``gap_thirdparty.py --excite``; dev set 950). The scored sets
300-309 fly without them."""
motor_noise_scale = 1.0
"""Factor on PyFlyt's motor noise (its ``noise_ratio``, 0.02 of the throttle per physics
step, added inside the motor's lag state): ``gap_thirdparty.py --motor-noise`` flies the
ablation that shows what that noise hides; every scored set flies PyFlyt's own (1)."""


def excitation(t: np.ndarray, manoeuvre: tuple[float, float], seed: int) -> np.ndarray:
    """(n, 3) roll, pitch, yaw mixer inputs, throttle units: 3-2-1-1 inputs (the flight-test
    sequence of pulses 3, 2, 1 and 1 units long with alternating sign) on one axis at a
    time, cycling roll, pitch, yaw, inside the ``manoeuvre`` window (s). Drawn from their
    own generator so that the rest of a flight is the same with or without them."""
    rng = np.random.default_rng(seed + 3571)
    out = np.zeros((t.size, 3))
    start, axis = manoeuvre[0] + rng.uniform(0.0, 1.0), int(rng.integers(0, 3))
    while start < manoeuvre[1] - 1.0:
        unit = rng.uniform(*EXCITATION_PULSE)
        amp = rng.uniform(*EXCITATION_PWM[("roll", "pitch", "yaw")[axis]]) * \
            rng.choice([-1.0, 1.0])
        edges = start + unit * np.cumsum([0, 3, 2, 1, 1])
        for k in range(4):
            inside = (t >= edges[k]) & (t < edges[k + 1])
            out[inside, axis] = amp * (-1) ** k
        start += rng.uniform(*EXCITATION_PERIOD)
        axis = (axis + 1) % 3
    return out


def fly(kind: str, duration: float, seed: int, vehicle: dict[str, float],
        fx: dict[str, Any], sensors: Sensors) -> Record:
    """One flight of ``duration`` s (profile ``kind``: hover, low or forward) with physics
    effects ``fx``; true state logged at the control rate."""
    from PyFlyt.core import Aviary

    rng = np.random.default_rng(seed)
    cls = _quadx_class()
    env = Aviary(start_pos=np.array([[0.0, 0.0, 0.05]]), start_orn=np.zeros((1, 3)),
                 drone_type="effquad", drone_type_mappings={"effquad": cls},
                 drone_options={"control_hz": CONTROL_HZ}, render=False,
                 physics_hz=PHYSICS_HZ, seed=seed)
    try:
        return _fly(env, kind, duration, rng, vehicle, fx, sensors, seed)
    finally:
        env.disconnect()


def _fly(env: Any, kind: str, duration: float, rng: np.random.Generator,
         vehicle: dict[str, float], fx: dict[str, Any], sensors: Sensors, seed: int
         ) -> Record:
    drone = env.drones[0]
    mass, inertia = env.getDynamicsInfo(drone.Id, -1)[0], np.array(
        env.getDynamicsInfo(drone.Id, -1)[2])
    mass *= vehicle["mass"] * fx.get("mass_scale", 1.0)
    inertia = inertia * vehicle["inertia"] * fx.get("inertia_scale", 1.0)
    env.changeDynamics(drone.Id, -1, mass=mass, localInertiaDiagonal=inertia.tolist())
    motors = drone.motors
    motors.tau = motors.tau * vehicle["tau"] * fx.get("tau_scale", 1.0)
    motors.noise_ratio = motors.noise_ratio * motor_noise_scale
    motors.thrust_coef = motors.thrust_coef * fx.get("thrust_scale", 1.0)
    motors.torque_coef = motors.torque_coef * fx.get("yaw_scale", 1.0)
    if "weak_motor" in fx:
        i, s = fx["weak_motor"]
        motors.thrust_coef[int(i)] *= s
    if "motor_tilt" in fx:
        # every rotor axis twisted about its arm in the same sense (yaw torque, side force)
        d = fx["motor_tilt"]
        pos = np.array([env.getLinkState(drone.Id, i)[0][:2] for i in motors.motor_ids])
        pos = pos - pos.mean(axis=0)
        tang = np.column_stack([-pos[:, 1], pos[:, 0]]) / np.linalg.norm(pos, axis=1)[:, None]
        unit = np.column_stack([np.sin(d) * tang, np.full(4, np.cos(d))])
        motors.thrust_unit = unit[:, :, None]
    # PyFlyt's cf2x gains close its loops near 100 rad/s on a vehicle with 7x its weight in
    # thrust: the z-velocity loop (kp 2, kd 0.05) limit-cycles in plain hover (pwm
    # 0.05 <-> 0.8 at ~30 Hz) and a 4 ms command delay makes the rate loop diverge. These
    # pairs fly PyFlyt's cascade with the rate loop at 3/8 of its gain and no D term, and
    # the z-velocity loop at kp 0.3, ki 0.3, kd 0 (chosen on no-effect flights, seed 900).
    drone.Kp_ang_vel = np.array([0.015, 0.015, 0.03])
    drone.Kd_ang_vel = np.zeros(3)
    drone.z_PIDs[0].kp = np.array([0.3])
    drone.z_PIDs[0].ki = np.array([0.3])
    drone.z_PIDs[0].kd = np.zeros(1)
    phys = dict(fx)
    if "torque_offset_acc" in fx:
        phys["torque_offset"] = (inertia * np.asarray(fx["torque_offset_acc"])).tolist()
    drone.arm_effects(phys, sensors)
    drone.inertia = inertia
    if "wind" in fx:
        wind = np.asarray(fx["wind"], dtype=float)
        env.register_wind_field_function(lambda t, pos: np.tile(wind, (len(pos), 1)))
    env.set_mode(7)
    t, sp = _profile(kind, duration, rng, REST_HEIGHT)
    n = t.size
    pos, vel, rot = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3, 3))
    rates, pwm, vbat = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros(n)
    idle_from = duration - 2.0  # landed: the motors are stopped (direct pwm mode)
    inputs = excitation(t, (4.0, duration - 6.0), seed) if excite_flights and \
        kind != "low" else np.zeros((n, 3))
    for i in range(n):
        drone.injection = inputs[i]
        if t[i] >= idle_from and drone.mode != -1:
            env.set_mode(-1)
        env.set_setpoint(0, sp[i] if t[i] < idle_from else np.zeros(4))
        env.step()
        p_, q_ = env.getBasePositionAndOrientation(drone.Id)
        v_, _ = env.getBaseVelocity(drone.Id)
        pos[i], vel[i] = p_, v_
        rot[i] = np.array(env.getMatrixFromQuaternion(q_)).reshape(3, 3)
        rates[i] = drone.state[0]
        pwm[i] = drone.pwm
        vbat[i] = drone.vbat
    acc = np.gradient(vel, t, axis=0)
    acc[:, 2] += 9.81
    spec = np.einsum("nji,nj->ni", rot, acc)
    return Record(t=t, pos=pos, vel=vel, rot=rot, rates=rates, spec_force=spec, motors=pwm,
                  vbat=vbat, ground_height=REST_HEIGHT, extra={"setpoint": sp})


def random_vehicle(rng: np.random.Generator) -> dict[str, float]:
    """Per-pair vehicle spread shared by SIM and REAL: mass, inertia and motor ramp."""
    return {"mass": float(rng.uniform(0.92, 1.08)), "inertia": float(rng.uniform(0.9, 1.1)),
            "tau": float(rng.uniform(0.8, 1.2))}


def sensors(rng: np.random.Generator, noisier: bool, overrides: dict[str, Any]) -> Sensors:
    """The PyFlyt set's sensor model; the "recording" has 10-30 % more IMU noise."""
    k = rng.uniform(1.1, 1.3) if noisier else 1.0
    return Sensors(gyro_std=0.015 * k, accel_std=0.25 * k, filter_gain=1.0,
                   reference_std=0.008, alt_std=0.004, vel_std=0.03, vbat_std=0.005,
                   **overrides)


def flight_kind(label: str, rng: np.random.Generator) -> tuple[str, str]:
    """(SIM profile, REAL profile): low hover for ground effect, forward flight for drag
    and wind, hover with position, yaw and height steps otherwise."""
    if "ground_effect" in label:
        return "low", "low"
    if "rotor_drag" in label or "wind" in label:
        return "forward", "forward"
    return "hover", "hover"
