"""A regime benchmark from a second generator that etsid does not contain.

Written for issue 24 independently of ``etsid.sim`` (no import from it, none of its code or
laws): another airframe (a 1.2 kg quad X with 10-inch rotors, not the Tarot hexacopter),
another ground-effect law, another controller and another sensor model.

- **Ground effect**: Hayden's fit of rotor power in ground effect at constant thrust,
  P_IGE/P_OGE = 1 / (0.9926 + 0.03794 (2R/h)²) (Hayden 1976, J. American Helicopter Soc.
  21(4)), turned into a thrust gain at constant power, T_IGE/T_OGE = (P_OGE/P_IGE)^(2/3),
  applied per rotor at its own height above ground (a tilted frame has one side lower).
- **Controller**: a single-loop attitude PID (torque = Kp·angle error + Ki·∫error −
  Kd·rate), not a cascade; yaw a rate P loop; altitude hold from a 20 Hz rangefinder with
  a complementary vertical-speed estimate; motors as first-order lags (40 ms).
- **Sensors**: gyro at 200 Hz with a 60 Hz first-order anti-alias filter, white noise
  0.015 rad/s and a random-walk bias; attitude with 3 mrad noise; sticks logged at 50 Hz as
  1 µs PWM steps (held in between); altitude from the rangefinder held at 20 Hz.
- **Flight**: 180 s, alternating dwells low (0.15–0.4 m) and high (0.8–3 m), 0.5 m/s climbs
  and descents, random multisine sticks on roll, pitch and yaw throughout.

Airframes (``--airframe``): ``quad10``, the 1.2 kg quad X with 10-inch rotors above (issue
24's); ``hexa15``, a Tarot-680-class hexacopter (2.8 kg, 680 mm wheelbase, 15-inch rotors),
the airframe class of the chapter and of the issue's independent generator. Hayden's law
depends on h/R: at the lowest dwell a 15-inch rotor gains 8.5 % thrust, a 10-inch one 4 %
(at 0.4 m, 1.3 % and 0.3 %). The controller's torque gains scale with the inertia, so both
attitude loops have the same bandwidth.

Settings frozen before the first run: ``IdentConfig()`` as of commit d5b31b4 (structure
auto, rule merging on), free-run fit % on identify's validation part. The first result is
recorded in docs/identify.md ("A second generator").

    python benchmarks/ets_gen2.py [--seeds 1,2,3] [--no-regime] [--airframe hexa15]
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

G = 9.81
PHYS_HZ = 1000
LOG_HZ = 200
STICK_HZ = 50
RANGE_HZ = 20


@dataclass(frozen=True)
class Airframe:
    """A multirotor of this generator: rotors evenly spaced on a circle (an X layout,
    spins alternating), with the controller's torque gains scaled by the inertia so that
    every airframe's attitude loop has the same bandwidth."""

    name: str
    n_rotors: int
    mass: float                 # kg
    inertia: tuple[float, float, float]  # kg m²
    arm: float                  # m, centre to rotor
    rotor_r: float              # m
    rotor_above_cg: float       # m
    t_max: float                # N per rotor
    yaw_per_thrust: float       # N m per N
    motor_tau: float            # s

    def rotors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x (forward), y (right) of each rotor, m, and its spin sign."""
        if self.n_rotors == 4:  # the original quad X (rotor order kept: outputs unchanged)
            a = self.arm / math.sqrt(2.0)
            return (np.array([a, -a, a, -a]), np.array([a, -a, -a, a]),
                    np.array([1.0, 1.0, -1.0, -1.0]))
        ang = np.pi / self.n_rotors + 2.0 * np.pi * np.arange(self.n_rotors) / self.n_rotors
        spin = np.where(np.arange(self.n_rotors) % 2 == 0, 1.0, -1.0)
        return self.arm * np.cos(ang), self.arm * np.sin(ang), spin


#: a 1.2 kg quad X with 10-inch rotors (the generator of issue 24)
QUAD10 = Airframe("quad10", 4, 1.2, (0.012, 0.012, 0.022), 0.225, 0.127, 0.04, 8.0, 0.016,
                  0.04)
#: a Tarot-680-class hexacopter, the chapter's airframe class: 680 mm wheelbase, 15-inch
#: rotors, 2.8 kg (Santoso et al. fly a Tarot 680 below 40 cm)
HEXA15 = Airframe("hexa15", 6, 2.8, (0.065, 0.065, 0.12), 0.34, 0.19, 0.05, 14.0, 0.02, 0.06)
AIRFRAMES = {a.name: a for a in (QUAD10, HEXA15)}


def ground_gain(h: np.ndarray, rotor_r: float = QUAD10.rotor_r) -> np.ndarray:
    """Thrust gain of a rotor of radius ``rotor_r`` (m) at height ``h`` (m) above ground
    (Hayden, at constant power)."""
    h = np.maximum(h, 0.3 * rotor_r)
    return (0.9926 + 0.03794 * (2.0 * rotor_r / h) ** 2) ** (2.0 / 3.0)


def mixer_inverse(frame: Airframe) -> np.ndarray:
    """Thrusts = M⁺ @ [total, roll, pitch, yaw] (least-norm for more than four rotors)."""
    x, y, spin = frame.rotors()
    mix = np.vstack([np.ones(frame.n_rotors), -y, x, spin * frame.yaw_per_thrust])
    return np.linalg.inv(mix) if frame.n_rotors == 4 else np.linalg.pinv(mix)


def _multisine(rng: np.random.Generator, t: np.ndarray, amp: float) -> np.ndarray:
    freqs = rng.uniform(0.1, 3.0, size=12)
    phases = rng.uniform(0, 2 * np.pi, size=12)
    weights = 1.0 / np.sqrt(freqs)
    s = (weights[:, None] * np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None])).sum(0)
    return np.clip(amp * s / np.std(s), -1.0, 1.0)


def _altitude_plan(rng: np.random.Generator, duration: float, regimes: bool
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints (t, h) of the altitude setpoint: dwells joined by 0.5 m/s ramps."""
    t, h = [0.0], [0.3 if regimes else 1.8]
    low = True
    while t[-1] < duration:
        target = (rng.uniform(0.15, 0.4) if low else rng.uniform(0.8, 3.0)) if regimes \
            else rng.uniform(1.2, 2.6)
        ramp = abs(target - h[-1]) / 0.5
        t += [t[-1] + ramp, t[-1] + ramp + rng.uniform(12.0, 20.0)]
        h += [target, target]
        low = not low
    return np.array(t), np.array(h)


def fly(seed: int, duration: float = 180.0, regimes: bool = True,
        frame: Airframe = QUAD10) -> pd.DataFrame:
    """Fly the scenario (module docstring) with ``frame`` and return a FlightTable at
    200 Hz."""
    rotor_x, rotor_y, spin = frame.rotors()
    mix_inv = mixer_inverse(frame)
    inertia = np.array(frame.inertia)
    nr, mass, t_max = frame.n_rotors, frame.mass, frame.t_max
    k_xy = inertia[0] / QUAD10.inertia[0]  # torque gains per unit inertia of the quad's
    k_z = inertia[2] / QUAD10.inertia[2]
    rng = np.random.default_rng(seed)
    n_phys = int(duration * PHYS_HZ)
    dt = 1.0 / PHYS_HZ
    t_phys = np.arange(n_phys) * dt
    t_stick = np.arange(int(duration * STICK_HZ)) / STICK_HZ
    sticks = np.vstack([_multisine(rng, t_stick, 0.3), _multisine(rng, t_stick, 0.3),
                        _multisine(rng, t_stick, 0.35)])
    sticks = np.round(sticks * 500.0) / 500.0  # 1 µs steps of a 1000–2000 µs channel
    plan_t, plan_h = _altitude_plan(rng, duration, regimes)
    h_sp_all = np.interp(t_phys, plan_t, plan_h)
    h0 = plan_h[0]
    ang = np.zeros(3)
    rate = np.zeros(3)
    h, vz = h0, 0.0
    thrust = np.full(nr, mass * G / nr / float(ground_gain(np.array([h0 + frame.rotor_above_cg]),
                                                           frame.rotor_r)[0]))
    integ = np.zeros(2)
    bias = rng.normal(0.0, 0.01, 3)
    gyro_f = np.zeros(3)
    h_meas, vz_est, h_est = h0, 0.0, h0
    alpha_gyro = 1.0 - math.exp(-2 * math.pi * 60.0 * dt)
    every = PHYS_HZ // LOG_HZ
    rows = []
    u_thrust = 0.0
    for k in range(n_phys):
        tk = t_phys[k]
        js = min(int(tk * STICK_HZ), len(t_stick) - 1)
        u_roll, u_pitch, u_yaw = sticks[:, js]
        if k % (PHYS_HZ // RANGE_HZ) == 0:
            h_meas = h + rng.normal(0.0, 0.01)
        # controller: attitude PID on the stick's angle, yaw rate P, altitude hold
        sp = np.array([0.45 * u_roll, 0.45 * u_pitch])
        err = sp - ang[:2]
        integ += err * dt
        tau_xy = k_xy * (0.6 * err + 0.25 * integ - 0.1 * rate[:2])
        tau_z = k_z * (0.06 * (2.0 * u_yaw - rate[2]))
        e = h_meas - h_est  # complementary filter: poles at −10 rad/s (double)
        h_est += dt * (vz_est + 20.0 * e)
        vz_est += dt * 100.0 * e
        acc_cmd = 3.0 * (h_sp_all[k] - h_est) - 2.5 * vz_est
        total = mass * (G + acc_cmd) / max(math.cos(ang[0]) * math.cos(ang[1]), 0.5)
        cmd = np.clip(mix_inv @ np.array([total, *tau_xy, tau_z]), 0.0, t_max)
        u_thrust = float(cmd.sum() / (nr * t_max))
        # plant
        thrust += (cmd - thrust) * (dt / frame.motor_tau)
        down = -rotor_x * math.sin(ang[1]) + rotor_y * math.sin(ang[0]) * math.cos(ang[1])
        eff = thrust * ground_gain(h + frame.rotor_above_cg - down, frame.rotor_r)
        moment = np.array([-(rotor_y * eff).sum(), (rotor_x * eff).sum(),
                           (spin * frame.yaw_per_thrust * thrust).sum()])
        rate = rate + dt * (moment - np.cross(rate, inertia * rate)) / inertia
        phi, theta = ang[0], ang[1]
        ang = ang + dt * np.array([
            rate[0] + math.tan(theta) * (math.sin(phi) * rate[1] + math.cos(phi) * rate[2]),
            math.cos(phi) * rate[1] - math.sin(phi) * rate[2],
            (math.sin(phi) * rate[1] + math.cos(phi) * rate[2]) / math.cos(theta)])
        acc = eff.sum() * math.cos(phi) * math.cos(theta) / mass - G
        vz += acc * dt
        h = max(h + vz * dt, 0.05)
        # sensors
        bias += rng.normal(0.0, 0.0005 * math.sqrt(dt), 3)
        gyro_f += alpha_gyro * (rate + bias - gyro_f)
        if k % every == 0:
            gyro = gyro_f + rng.normal(0.0, 0.015, 3)
            att = ang + rng.normal(0.0, 0.003, 3)
            rows.append((tk, *gyro, att[0], att[1], math.atan2(math.sin(att[2]),
                                                               math.cos(att[2])),
                         u_roll, u_pitch, u_yaw, u_thrust, h_meas))
    cols = ["t", "p", "q", "r", "roll", "pitch", "yaw", "u_roll", "u_pitch", "u_yaw",
            "u_thrust", "alt"]
    table = pd.DataFrame(rows, columns=cols).set_index("t")
    table.attrs.update({"source": "benchmarks/ets_gen2.py", "rotor_radius_m": frame.rotor_r,
                        "seed": seed, "airframe": frame.name})
    return table


def band_lines(regimes: dict) -> list[str]:
    """Per altitude band: validation seconds and free-run fit % eTS / ARX (Δ) of p, q, r;
    ``n.i.`` where the band is not informative (too short or too still)."""
    out = []
    for band in regimes.get("per_regime") or []:
        parts = []
        for y in "pqr":
            o = (band.get("outputs") or {}).get(y) or {}
            e = (o.get("free_run") or {}).get("fit")
            a = (o.get("arx_free_run") or {}).get("fit")
            if not o.get("informative") or e is None or a is None:
                parts.append(f"{y} n.i.")
            else:
                parts.append(f"{y} {e:.1f} / {a:.1f} ({e - a:+.1f})")
        out.append(f"band {band['name']}: {band.get('n_validation', 0)} val rows; "
                   + "; ".join(parts))
    return out


def main() -> None:
    from etsid.ident import IdentConfig, identify

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--duration", type=float, default=180.0)
    ap.add_argument("--no-regime", action="store_true",
                    help="dwells between 1.2 and 2.6 m only (no ground effect)")
    ap.add_argument("--airframe", choices=sorted(AIRFRAMES), default="quad10",
                    help="quad10: the 10-inch quad of issue 24; hexa15: a Tarot-680-class "
                         "hexacopter with 15-inch rotors")
    args = ap.parse_args()
    print("| seed | structure | rules peak / frozen (merges) | eTS free-run fit p / q / r |"
          " ARX | Δ p / q / r | eTS / ARX val 1-step p / q / r |")
    print("|---|---|---|---|---|---|---|")
    deltas = []
    for seed in (int(s) for s in args.seeds.split(",")):
        table = fly(seed, args.duration, regimes=not args.no_regime,
                    frame=AIRFRAMES[args.airframe])
        run = identify(table, IdentConfig())
        out = run.metrics["outputs"]
        ets = [out[y]["validation"]["free_run"]["fit"] for y in "pqr"]
        arx = [out[y]["arx"]["validation"]["free_run"]["fit"] for y in "pqr"]
        one = [out[y]["validation"]["one_step"]["rmse"]
               / out[y]["arx"]["validation"]["one_step"]["rmse"] for y in "pqr"]
        d = [a - b for a, b in zip(ets, arx, strict=True)]
        deltas.append(d)
        rules = run.metrics["rules"]
        print(f"| {seed} | {run.metrics.get('structure', {}).get('chosen')} | "
              f"{rules['peak']} / {rules['frozen']} ({len(rules.get('merges', []))}) | "
              + " / ".join(f"{v:.1f}" for v in ets) + " | "
              + " / ".join(f"{v:.1f}" for v in arx) + " | "
              + " / ".join(f"{v:+.1f}" for v in d) + " | "
              + " / ".join(f"{v:.3f}" for v in one) + " |", flush=True)
        print("  learnt:", run.metrics["regimes"].get("sentence"), flush=True)
        for line in band_lines(run.metrics["regimes"]):
            print("  " + line, flush=True)
    mean = np.mean(deltas, axis=0)
    print("mean Δ free-run fit eTS − ARX p / q / r: " + " / ".join(f"{v:+.2f}" for v in mean))


if __name__ == "__main__":
    main()
