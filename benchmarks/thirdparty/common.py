"""What the third-party pair generators share: labels, sensor model, FlightTable conversion.

A simulator module flies a vehicle and returns a :class:`Record` of its *true* state in the
simulator's own frames (world ENU-like, z up; body FLU). :func:`to_table` applies a
:class:`Sensors` model (gyro and accelerometer noise, biases, scale, a tilted IMU, a
complementary attitude filter, rangefinder and velocity noise) and returns a FlightTable
(NED/FRD, SI) that etsid's writers turn into real log formats. Effect labels and the names
``etsid gap`` is expected to answer with live here and in ``benchmarks/gap_thirdparty.py``
only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from etsid.frames import ENU_TO_NED, FLU_TO_FRD, matrix_to_euler

EXPECTED: dict[str, str] = {
    "none": "consistent",
    "thrust_scale": "thrust_scale",
    "motor_lag": "motor_lag",
    "time_delay": "time_delay",
    "rotor_drag": "rotor_drag",
    "inertia_scale": "inertia_scale",
    "torque_offset": "torque_offset",
    "gyro_bias": "gyro_bias",
    "battery_sag": "battery_sag",
    "ground_effect": "ground_effect",
    "payload": "mass",
    "accel_bias": "accel_bias",
    "wind": "wind",
    "weak_motor": "weak_motor",
    "rate_damping": "rate_damping",
    "yaw_torque_scale": "yaw_torque_scale",
    "rotor_inertia": "rotor_inertia",
    "thrust_scale+time_delay": "thrust_scale+time_delay",
}
"""Effect label → the answer expected from ``etsid gap`` (issue 22's vocabulary; several
effects "+"-joined in sorted order; ``consistent`` for a no-effect pair). A payload is
expected as ``mass``; see :data:`SAME_FROM_ACCELERATIONS` for what else counts."""

SAME_FROM_ACCELERATIONS: dict[str, str] = {"mass": "thrust_scale"}
"""Names scored as one: issue 22 has mass and thrust scale indistinguishable from
accelerations alone (the vocabulary reports a payload as a thrust-to-weight change), so a
payload named ``thrust_scale`` and a thrust scale named ``mass`` both count as right."""


def same_answer(expected: str, named: str) -> bool:
    """Whether ``named`` ("+"-joined names or a verdict) is the ``expected`` answer."""
    def canon(answer: str) -> list[str]:
        return sorted(SAME_FROM_ACCELERATIONS.get(a, a) for a in answer.split("+"))
    return canon(expected) == canon(named)

OUT_OF_VOCABULARY: dict[str, str] = {
    "gyro_scale": "gyro scale-factor error (every gyro axis reads 10-15 % high, the rate "
                  "loop flies on it)",
    "imu_tilt": "IMU mounted rolled by 3-5 deg (gyro, accelerometer and attitude in a "
                "rotated frame)",
    "motor_tilt": "every rotor axis tilted 4-7 deg (PyFlyt: twisted about its arm, a yaw "
                  "torque; octocopter: outward along its arm, side forces)",
}
"""Changes outside the vocabulary: the right answer is ``unexplained`` or the nearest
physical name with a caveat, never a confident wrong name."""


IN_VOCABULARY_FOR: dict[tuple[str, str], str] = {("pyflyt", "motor_tilt"): "rotor_twist"}
"""(simulator, label) → the vocabulary name of a change that is out of the vocabulary on
the other simulators: PyFlyt twists every rotor about its arm, which ``rotor_twist``
describes (session 15); the octocopter tilts them outward along the arm, which nothing
does."""


def out_of_vocabulary(label: str, sim: str | None = None) -> bool:
    """Whether ``label`` flown by simulator ``sim`` is outside the vocabulary."""
    return label in OUT_OF_VOCABULARY and (sim, label) not in IN_VOCABULARY_FOR


def expected_name(label: str, sim: str | None = None) -> str:
    """The answer expected for ``label`` flown by ``sim`` ("unexplained" for a change
    outside the vocabulary)."""
    if (sim, label) in IN_VOCABULARY_FOR:
        return IN_VOCABULARY_FOR[(sim, label)]
    return "unexplained" if label in OUT_OF_VOCABULARY else EXPECTED[label]


@dataclass
class Record:
    """True state of one flight, one row per logged sample, in the simulator's frames.

    World frame x, y, z with z up (taken as ENU), body frame FLU; SI units.
    """

    t: np.ndarray
    """Time, s, from the first sample."""
    pos: np.ndarray
    """(N, 3) position, m (z = height of the body origin above the ground plane)."""
    vel: np.ndarray
    """(N, 3) world velocity, m/s."""
    rot: np.ndarray
    """(N, 3, 3) world-from-body rotation matrices."""
    rates: np.ndarray
    """(N, 3) body angular rate, rad/s."""
    spec_force: np.ndarray
    """(N, 3) specific force (non-gravitational force / mass), body, m/s²."""
    motors: np.ndarray
    """(N, n) motor outputs as the flight controller sends them, 0..1."""
    vbat: np.ndarray | None = None
    """(N,) pack voltage, V, or None when the flight has no battery model."""
    ground_height: float = 0.0
    """Height of the body origin when the vehicle rests on the ground, m."""
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    """True internals for sanity checks (thrust per rotor …), never written to the logs."""


@dataclass
class Sensors:
    """Sensor model applied to a :class:`Record` (body FLU, the IMU's own axes).

    ``gyro_bias`` and ``accel_bias`` are in FRD (as etsid reports them); noise is white
    Gaussian per sample at the log rate.
    """

    gyro_std: float = 0.01
    """Gyro noise, rad/s."""
    accel_std: float = 0.15
    """Accelerometer noise, m/s²."""
    gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Constant gyro bias, FRD, rad/s."""
    accel_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Constant accelerometer bias, FRD, m/s²."""
    gyro_scale: float = 1.0
    """Gyro scale factor (1 = exact)."""
    imu_roll: float = 0.0
    """IMU mounting error about body x, rad."""
    filter_gain: float = 1.0
    """Complementary attitude filter: pull towards the aided reference, 1/s."""
    reference_std: float = 0.01
    """Noise of the aided attitude reference the filter corrects towards, rad."""
    alt_std: float = 0.005
    """Rangefinder noise, m."""
    vel_std: float = 0.03
    """Velocity noise, m/s."""
    vbat_std: float = 0.01
    """Voltage noise, V."""

    def mount(self) -> np.ndarray:
        """IMU-from-body rotation (FLU)."""
        c, s = np.cos(self.imu_roll), np.sin(self.imu_roll)
        return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])

    def gyro(self, rates_flu: np.ndarray) -> np.ndarray:
        """Noise-free gyro reading (FLU, rad/s) of true body rates ``(…, 3)``; what a rate
        loop flying on this gyro sees."""
        bias = FLU_TO_FRD @ np.asarray(self.gyro_bias)
        return self.gyro_scale * (np.asarray(rates_flu) @ self.mount().T) + bias

    def accel(self, force_flu: np.ndarray) -> np.ndarray:
        """Noise-free accelerometer reading (FLU, m/s²) of the true specific force."""
        return np.asarray(force_flu) @ self.mount().T + FLU_TO_FRD @ np.asarray(self.accel_bias)


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _expm(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    a = float(np.linalg.norm(w))
    if a < 1e-12:
        return np.eye(3) + _skew(w)
    k = _skew(w / a)
    return np.eye(3) + np.sin(a) * k + (1.0 - np.cos(a)) * (k @ k)


def _logm(r: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix (small and moderate angles)."""
    c = np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)
    a = float(np.arccos(c))
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return v * (0.5 if a < 1e-9 else a / (2.0 * np.sin(a)))


def attitude_filter(rec: Record, gyro_meas: np.ndarray, sensors: Sensors,
                    rng: np.random.Generator) -> np.ndarray:
    """Complementary filter: integrate the measured gyro (IMU axes) and pull the estimate
    towards an aided reference (the true attitude plus noise, as a GNSS/vision-aided
    estimator has) at ``filter_gain`` 1/s. A gyro bias b leaves an attitude error of about
    b / gain, as a real estimator that absorbs part of it. Returns (N, 3, 3) estimated
    world-from-IMU matrices."""
    n = rec.t.size
    mount_t = sensors.mount().T
    truth = rec.rot @ mount_t  # world-from-IMU
    est = np.empty_like(truth)
    r = truth[0].copy()
    dt = np.diff(rec.t, prepend=rec.t[0])
    noise = rng.normal(0.0, sensors.reference_std, (n, 3))
    for i in range(n):
        err = _logm(r.T @ truth[i]) + noise[i]
        r = r @ _expm((gyro_meas[i] + sensors.filter_gain * err) * dt[i])
        est[i] = r
    return est


def to_table(rec: Record, sensors: Sensors, rng: np.random.Generator,
             source: str) -> pd.DataFrame:
    """FlightTable (NED world, FRD body, SI) of ``rec`` as ``sensors`` measure it."""
    n = rec.t.size
    gyro = sensors.gyro(rec.rates) + rng.normal(0.0, sensors.gyro_std, (n, 3))
    acc = sensors.accel(rec.spec_force) + rng.normal(0.0, sensors.accel_std, (n, 3))
    est = attitude_filter(rec, sensors.gyro(rec.rates), sensors, rng)
    roll, pitch, yaw = matrix_to_euler(ENU_TO_NED @ est @ FLU_TO_FRD)
    vel = rec.vel @ ENU_TO_NED.T + rng.normal(0.0, sensors.vel_std, (n, 3))
    alt = rec.pos[:, 2] - rec.ground_height + rng.normal(0.0, sensors.alt_std, n)
    cols: dict[str, np.ndarray] = {
        "p": gyro[:, 0], "q": -gyro[:, 1], "r": -gyro[:, 2],
        "roll": roll, "pitch": pitch, "yaw": yaw,
        "ax": acc[:, 0], "ay": -acc[:, 1], "az": -acc[:, 2],
        "alt": np.maximum(alt, 0.0), "vx": vel[:, 0], "vy": vel[:, 1], "vz": vel[:, 2],
    }
    if rec.vbat is not None:
        cols["vbat"] = rec.vbat + rng.normal(0.0, sensors.vbat_std, n)
    for i in range(rec.motors.shape[1]):
        cols[f"m{i + 1}"] = np.clip(rec.motors[:, i], 0.0, 1.0)
    table = pd.DataFrame({k: np.asarray(v, dtype=np.float64) for k, v in cols.items()},
                         index=pd.Index(np.asarray(rec.t, dtype=np.float64), name="t"))
    table.attrs.update({"source": source, "format": "sim", "rate_hz": float(
        (n - 1) / (rec.t[-1] - rec.t[0]))})
    return table


LEG_TURNS = (0, 1, 2, 1)
"""Forward-flight legs turn by these quarter turns from the first heading and back: the
headings span half a circle without wrapping (both simulators' attitude loops take the
plain difference of yaw angles, so a setpoint past ±π makes the vehicle spin)."""


def bounded_walk(rng: np.random.Generator, n: int, step: float, limit: float) -> np.ndarray:
    """``n`` yaw setpoints, rad: a random walk of ±``step`` (or no change) kept within
    ±``limit`` of zero (never near ±π, see :data:`LEG_TURNS`)."""
    out = np.zeros(n)
    for i in range(1, n):
        move = rng.choice([0.0, 0.0, step, -step])
        out[i] = out[i - 1] + (move if abs(out[i - 1] + move) <= limit else -move)
    return out


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy scalars and arrays turned into plain Python for JSON."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.floating | np.integer):
        return obj.item()
    return obj
