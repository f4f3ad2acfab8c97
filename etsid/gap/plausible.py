"""What of each flight is fit to be evidence: upsets kept out, estimates checked.

Two checks run on both prepared flights before any model is fitted, and each says what it
did in a note:

* **Upsets and aerobatics** (:func:`upset_mask`): samples tilted beyond
  :data:`MAX_TILT_DEG` (a flip, a vehicle on its back), with :data:`UPSET_PAD_S` either
  side, leave the airborne evidence. The nominal model is a hover-and-cruise model; an
  upset's error would otherwise set the floors (a flip's gyro error of 0.6 rad/s makes the
  pair blind to any gyro bias) or count as a mismatch.
* **Velocity estimates** (:func:`velocity_problem`): the NED velocity is an estimator's
  output, not a measurement. A multirotor flying at speed feels rotor drag, so its
  horizontal specific force follows the body velocity with a negative slope; an estimate
  that drifts to 18 m/s while the accelerometer shows no drag at all is not the vehicle's
  motion. The altitude gives the second check: the climb the velocity integrates to must
  agree with the height's own change. A flight whose velocity fails either check has it
  dropped (in both flights, so both compare the same channels).
"""

from __future__ import annotations

import numpy as np

from etsid.gap.signals import Flight, down_in_body, true_runs

MAX_TILT_DEG = 60.0
"""Tilt beyond which a sample is an upset or aerobatics: the autopilots' own lean limits in
their stabilised and position modes are 35–45° by default (PX4 MPC_MAN_TILT_MAX 35°,
MPC_TILT_MAX_AIR 45°; ArduCopter ANGLE_MAX 45°), so 60° is only reached in acro, a flip or
a loss of control."""
UPSET_PAD_S = 1.0
"""Seconds either side of an upset also left out (entry and recovery)."""
DRAG_CHECK_SPEED = 3.0
"""m/s: horizontal speed from which rotor drag must show in the specific force (at the
least drag coefficient below, 0.1 m/s² or more, above the accelerometer's noise)."""
MIN_DRAG = 0.03
"""1/s: least slope of horizontal specific force on body velocity a multirotor shows. The
rotor momentum drag of multirotors is 0.1–0.3 /s (PX4's EKF2_MCOEF default 0.15; the
coaxial octocopter's logs read 0.11); a slope more than three standard errors below a
fifth of the smallest is no drag at all."""
CLIMB_WINDOW_S = 10.0
"""Window over which the integrated vertical velocity is compared with the height change."""
MAX_CLIMB_DISAGREE = 1.5
"""m: largest median disagreement per window between the height change and the integrated
vertical velocity (a rangefinder or barometer wanders by a few decimetres; an estimate
that disagrees by metres in ten seconds is not the vehicle's climb)."""


def upset_mask(flight: Flight) -> np.ndarray:
    """Samples tilted beyond :data:`MAX_TILT_DEG`, padded by :data:`UPSET_PAD_S`."""
    if "roll" not in flight.have or not np.all(np.isfinite(flight.att[:, :2])):
        return np.zeros(flight.n, dtype=bool)
    cos_tilt = np.cos(flight.att[:, 0]) * np.cos(flight.att[:, 1])
    upset = cos_tilt < np.cos(np.radians(MAX_TILT_DEG))
    if not np.any(upset):
        return upset
    pad = round(UPSET_PAD_S * flight.fs)
    out = np.zeros_like(upset)
    for a, b in true_runs(upset):
        out[max(0, a - pad):min(flight.n, b + pad)] = True
    return out


def exclude_upsets(flight: Flight) -> str | None:
    """Take the upsets out of ``flight.airborne``; the note saying how much, or None."""
    upset = upset_mask(flight) & flight.airborne
    if not np.any(upset):
        return None
    flight.airborne = flight.airborne & ~upset
    runs = true_runs(upset)
    return (f"{np.sum(upset) / flight.fs:.1f} s of {flight.name} tilted beyond "
            f"{MAX_TILT_DEG:.0f}° (aerobatics or an upset, {len(runs)} stretch"
            f"{'es' if len(runs) > 1 else ''} from {flight.t[runs[0][0]]:.1f} s) kept out of "
            "the floors and the evidence")


def _drag_slope(flight: Flight) -> tuple[float, float] | None:
    """(slope, standard error) of the horizontal specific force on the body velocity (both
    axes, one slope, an intercept each), negated: the drag coefficient, 1/s."""
    a = flight.airborne
    if not ("ax" in flight.have and "ay" in flight.have) or a.sum() < 50:
        return None
    v = flight.v_body[a, :2]
    f = flight.acc[a, :2]
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(f))):
        return None
    v = v - v.mean(axis=0)
    f = f - f.mean(axis=0)
    sxx = float(np.sum(v**2))
    if sxx <= 0:
        return None
    slope = float(np.sum(v * f) / sxx)
    resid = f - slope * v
    # one effective sample per second: the drift is slow, its samples are not independent
    n_eff = max(a.sum() / flight.fs, 3.0)
    se = float(np.sqrt(np.mean(resid**2) / (sxx / a.sum() * n_eff)))
    return -slope, se


def down_velocity(flight: Flight) -> np.ndarray:
    """Earth-frame down velocity (m/s): the body velocity turned back through the attitude,
    v_down = −sin θ v_x + sin φ cos θ v_y + cos φ cos θ v_z (body z alone where the attitude
    is missing). Body z is not "down" in forward flight: pitched 0.15 rad at 3 m/s it reads
    0.45 m/s of climb that is not there."""
    vb = flight.v_body
    d = down_in_body(flight.att)
    down = vb[:, 0] * d[:, 0] + vb[:, 1] * d[:, 1] + vb[:, 2] * d[:, 2]
    return np.where(np.isfinite(down), down, vb[:, 2])


def _climb_disagreement(flight: Flight) -> float | None:
    """Median over :data:`CLIMB_WINDOW_S` windows of |height change − ∫ climb rate| (m)."""
    if not np.any(np.isfinite(flight.alt)):
        return None
    vz = down_velocity(flight)  # climb = −v_down
    n = int(CLIMB_WINDOW_S * flight.fs)
    out = []
    for a, b in true_runs(flight.airborne):
        for i in range(a, b - n, n):
            alt = flight.alt[i:i + n]
            if not np.all(np.isfinite(alt)):
                continue
            climb = -float(np.sum(vz[i:i + n])) / flight.fs
            out.append(abs((alt[-1] - alt[0]) - climb))
    return float(np.median(out)) if out else None


def velocity_problem(flight: Flight) -> str | None:
    """Why ``flight``'s velocity estimate is not the vehicle's motion, or None."""
    if "vel" not in flight.have:
        return None
    speed = np.hypot(flight.v_body[flight.airborne, 0], flight.v_body[flight.airborne, 1])
    if speed.size and float(np.max(speed)) >= DRAG_CHECK_SPEED:
        drag = _drag_slope(flight)
        if drag is not None and drag[0] + 3.0 * drag[1] < MIN_DRAG:
            return (f"{flight.name}'s velocity estimate reaches {np.max(speed):.1f} m/s but its "
                    f"horizontal specific force shows no drag against it (slope "
                    f"{drag[0]:.3f} ± {drag[1]:.3f} /s, a multirotor ≥ {MIN_DRAG:g} /s): the "
                    "estimate drifts")
    climb = _climb_disagreement(flight)
    if climb is not None and climb > MAX_CLIMB_DISAGREE:
        return (f"{flight.name}'s vertical velocity integrates to a climb {climb:.1f} m away "
                f"from its height change per {CLIMB_WINDOW_S:.0f} s (median): the estimate "
                "drifts")
    return None


def _drop_velocity(flight: Flight) -> None:
    flight.have.discard("vel")
    flight.v_body = np.zeros_like(flight.v_body)


def condition(sim: Flight, real: Flight) -> list[str]:
    """Apply both checks to the pair (upsets out of each; a failed velocity dropped from
    both); the notes saying what was done."""
    notes = [n for n in (exclude_upsets(sim), exclude_upsets(real)) if n]
    problems = [p for p in (velocity_problem(sim), velocity_problem(real)) if p]
    if problems:
        for f in (sim, real):
            _drop_velocity(f)
        notes.append("; ".join(problems) + ": velocity not used in either log (the "
                     "accelerometer-vs-velocity and horizontal-force channels, and the "
                     "effects that need them, are not judged)")
    return notes
