"""The PID feedback law shared by both controllers, and the PID baseline controller.

Command units are the normalised collective (0..1). Feedback on the height error
e = r − h and on the climb-rate error ṙ − w (w = −v_z, measured): D acts on the rate
error, so a moving reference is followed without a derivative kick on steps.
Anti-windup by conditional integration: the integrator stops while the command is
saturated in the direction the error pushes, and its contribution is bounded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from etsid.control.plant import Observation
from etsid.control.scenarios import Scenario

U_MIN = 0.05
"""Lowest collective the controllers command (motors keep spinning), 0..1."""
U_MAX = 0.95
"""Highest collective the controllers command (headroom for the attitude loops), 0..1."""
MIN_TILT = 0.7
"""Floor of cos(roll)·cos(pitch) in the tilt compensation (as the simulator's own hold)."""


@dataclass(frozen=True)
class Gains:
    """PID gains in command units.

    Attributes
    ----------
    kp : float
        Collective per metre of height error, 1/m.
    kd : float
        Collective per m/s of climb-rate error, s/m.
    ki : float
        Collective per metre-second of integrated height error, 1/(m s).
    i_limit : float
        Bound on the integrator's contribution, collective units.
    leak : float
        Integrator leak rate, 1/s (0: a pure integrator). The eTS controller leaks its
        integrator so that steady offsets end up in the learnt feed-forward, not in both.
    """

    kp: float
    kd: float
    ki: float
    i_limit: float = 0.2
    leak: float = 0.0


PID_GAINS = Gains(kp=1.35, kd=0.40, ki=0.48)
"""Baseline gains, tuned on the nominal Tarot 680 (docs/control.md)."""


@dataclass
class Command:
    """One control decision: the command sent and its parts (collective units, 0..1)."""

    u: float
    u_ff: float
    u_fb: float


def tilt_factor(obs: Observation) -> float:
    """cos(roll)·cos(pitch), floored at :data:`MIN_TILT`: vertical share of the thrust."""
    return max(math.cos(obs.roll) * math.cos(obs.pitch), MIN_TILT)


class Feedback:
    """PID on height and climb-rate errors with conditional-integration anti-windup."""

    def __init__(self, gains: Gains, dt: float) -> None:
        self.gains = gains
        self.dt = dt
        self.integral = 0.0

    def reset(self) -> None:
        """Clear the integrator."""
        self.integral = 0.0

    def __call__(self, r: float, rd: float, obs: Observation) -> float:
        """Feedback collective (before tilt compensation) for reference ``r``, ``rd``."""
        g = self.gains
        e = r - obs.alt
        return g.kp * e + g.kd * (rd + obs.vz) + self.integral

    def integrate(self, r: float, obs: Observation, saturated: int) -> None:
        """Advance the integrator by one period unless saturation (+1 high, −1 low) forbids it."""
        g = self.gains
        e = r - obs.alt
        self.integral *= 1.0 - g.leak * self.dt
        if (saturated > 0 and e > 0.0) or (saturated < 0 and e < 0.0):
            return
        self.integral = min(max(self.integral + g.ki * e * self.dt, -g.i_limit), g.i_limit)


def saturate(u: float) -> tuple[float, int]:
    """Clip ``u`` to [U_MIN, U_MAX]; also say which side clipped (+1, −1, 0)."""
    if u > U_MAX:
        return U_MAX, 1
    if u < U_MIN:
        return U_MIN, -1
    return u, 0


class PIDController:
    """Baseline: hover-thrust feed-forward + PID feedback, tilt-compensated.

    Parameters
    ----------
    dt : float
        Control period, s.
    hover_command : float
        Feed-forward collective: the nominal vehicle's hover command out of ground effect.
    gains : Gains
        Feedback gains (default :data:`PID_GAINS`).
    """

    name = "pid"

    def __init__(self, dt: float, hover_command: float, gains: Gains = PID_GAINS) -> None:
        self.dt = dt
        self.hover_command = hover_command
        self.feedback = Feedback(gains, dt)

    def reset(self) -> None:
        """Forget the integrator."""
        self.feedback.reset()

    def update(self, t: float, obs: Observation, scenario: Scenario) -> Command:
        """The collective for the next control period, from the observation at ``t``."""
        r, rd, _ = scenario.at(t)
        u_fb = self.feedback(r, rd, obs)
        u, sat = saturate((self.hover_command + u_fb) / tilt_factor(obs))
        self.feedback.integrate(r, obs, sat)
        return Command(u=u, u_ff=self.hover_command, u_fb=u_fb)
