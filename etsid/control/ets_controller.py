"""The eTS vertical-loop controller: an online-learned inverse model plus a small feedback.

Learning (every control period, from zero rules): the inverse model maps what the vehicle
*did* to the collective that made it do so,

    u(k) = f(h, w, a),

with h the height, w the climb rate and a the climb acceleration over a short window, all
from the measurements (filtered with the same first-order filter as the command, so the
pair stays consistent) — a linear change of coordinates of the chapter's regressor
[h(k+1), h(k), h(k−1)] (docs/control.md says why). Control: the model is queried with the
reference trajectory, u_ff = f(r, ṙ, r̈) a little ahead (motor lag), and a PID with small
gains adds u_fb, which alone keeps the first seconds safe. Until the model has learnt
``warmup`` seconds of data the feed-forward is the nominal hover command (the PID's prior);
it then blends into the learnt one over ``blend`` seconds.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from etsid.control.pid import PID_GAINS, Command, Feedback, Gains, saturate, tilt_factor
from etsid.control.plant import Observation
from etsid.control.scenarios import Scenario
from etsid.ets import ETS

INPUT_NAMES = ("h", "w", "a")
"""eTS inputs: height (m), climb rate (m/s), climb acceleration (m/s²)."""
OUTPUT_NAME = "u_thrust"


@dataclass(frozen=True)
class ETSSettings:
    """Settings of the eTS controller (defaults used for every result in docs/control.md).

    Attributes
    ----------
    radius : tuple of float
        eTS zone of influence per input (h, w, a) as a fraction of its range.
    x_range : tuple of (float, float)
        Fixed normalisation ranges of h (m), w (m/s), a (m/s²): the flight envelope.
    forgetting : float
        RLS forgetting factor per learned sample (firing-weighted; 1 = none).
    omega : float
        Initial RLS covariance of a new rule.
    max_rules : int
        Cap on the rule base.
    window : float
        Acceleration window, s: a = Δw̄ / window.
    lag : float
        Motor lag the learning pairs and the feed-forward preview account for, s.
    filter_tau : float
        Time constant of the first-order filter on h, w and the applied command, s.
    warmup, blend : float
        Seconds of learnt data before the learnt feed-forward is used, and of its blend-in.
    query : {"state", "reference"}
        Where the inverse is evaluated: at the measured height and climb rate with the
        reference acceleration ("state": the operating point the data come from), or all
        three from the reference ("reference": pure feed-forward).
    gains : Gains
        The stabilising feedback: by default the PID baseline's own gains, so that the
        learnt feed-forward is the only difference between the two controllers.
    """

    radius: tuple[float, float, float] = (0.1, 0.5, 0.5)
    x_range: tuple[tuple[float, float], ...] = ((0.0, 4.0), (-2.0, 2.0), (-3.0, 3.0))
    forgetting: float = 0.98
    omega: float = 1000.0
    max_rules: int = 30
    window: float = 0.2
    lag: float = 0.05
    filter_tau: float = 0.1
    warmup: float = 1.0
    blend: float = 1.0
    query: str = "reference"
    gains: Gains = PID_GAINS


class ETSController:
    """Inverse-model eTS controller learning from zero rules (see the module docstring).

    Parameters
    ----------
    dt : float
        Control period, s.
    hover_command : float
        Nominal hover collective (used only before the model has learnt ``warmup`` s).
    settings : ETSSettings
        Learning and feedback settings.
    """

    name = "ets"

    def __init__(self, dt: float, hover_command: float,
                 settings: ETSSettings | None = None) -> None:
        self.dt = dt
        self.hover_command = hover_command
        self.settings = settings or ETSSettings()
        self.reset()

    def reset(self) -> None:
        """Start again from an empty rule base."""
        s = self.settings
        self.model = ETS(radius=list(s.radius), omega=s.omega, variant="ets+",
                         max_rules=s.max_rules, forgetting=s.forgetting,
                         # the ETS defaults before issue 11's study (tuned with them)
                         utility_threshold=0.05, adaptive_spread=False,
                         x_range=np.asarray(s.x_range, dtype=np.float64),
                         y_range=np.array([[0.0, 1.0]]), history_every=10**9,
                         input_names=list(INPUT_NAMES), output_names=[OUTPUT_NAME])
        self.feedback = Feedback(s.gains, self.dt)
        self.d = max(1, round(s.window / self.dt))
        self.ell = max(0, round(s.lag / self.dt))
        self.alpha = self.dt / (s.filter_tau + self.dt)
        size = self.d + self.ell + 2
        self.h_buf: deque[float] = deque(maxlen=size)
        self.w_buf: deque[float] = deque(maxlen=size)
        self.u_buf: deque[float] = deque(maxlen=size)
        self.hf = math.nan
        self.wf = math.nan
        self.uf = self.hover_command
        self.learned = 0
        self.learn_times: list[float] = []
        self.u_last = self.hover_command

    # ------------------------------------------------------------------ learning
    def _filter(self, obs: Observation) -> None:
        w = -obs.vz
        if math.isnan(self.hf):
            self.hf, self.wf = obs.alt, w
        a = self.alpha
        self.hf += a * (obs.alt - self.hf)
        self.wf += a * (w - self.wf)
        self.h_buf.append(self.hf)
        self.w_buf.append(self.wf)

    def _learn(self, t: float) -> None:
        """Learn the pair (h, w, a over the last window) → mean command that caused it."""
        d, ell = self.d, self.ell
        if len(self.u_buf) < d + ell or len(self.w_buf) < d + 1:
            return
        w1, w0 = self.w_buf[-1], self.w_buf[-1 - d]
        x = ((self.h_buf[-1] + self.h_buf[-1 - d]) / 2.0, (w1 + w0) / 2.0,
             (w1 - w0) / (d * self.dt))
        # u_buf[-1] is the filtered command applied over the last period
        us = list(self.u_buf)[len(self.u_buf) - d - ell: len(self.u_buf) - ell]
        self.model.learn_one(np.asarray(x), float(np.mean(us)))
        self.learned += 1
        self.learn_times.append(t)

    # ------------------------------------------------------------------ control
    def feed_forward(self, t: float, scenario: Scenario) -> float:
        """The learnt inverse queried with the reference a little ahead of ``t``."""
        s = self.settings
        tq = t + 0.5 * self.dt + s.lag
        r, rd, rdd = scenario.at(tq)
        learnt_for = self.learned * self.dt
        if self.model.n_rules == 0 or learnt_for < s.warmup:
            return self.hover_command
        if s.query == "state":
            r, rd = self.hf, self.wf
        u_model = float(self.model.predict_one(np.array([r, rd, rdd]))[0])
        if not math.isfinite(u_model):
            return self.hover_command
        u_model = min(max(u_model, 0.0), 1.0)
        weight = min(1.0, (learnt_for - s.warmup) / s.blend) if s.blend > 0 else 1.0
        return (1.0 - weight) * self.hover_command + weight * u_model

    def update(self, t: float, obs: Observation, scenario: Scenario) -> Command:
        """Learn from the last period, then choose the collective for the next one."""
        self._filter(obs)
        self._learn(t)
        r, rd, _ = scenario.at(t)
        u_ff = self.feed_forward(t, scenario)
        u_fb = self.feedback(r, rd, obs)
        tilt = tilt_factor(obs)
        u, sat = saturate((u_ff + u_fb) / tilt)
        self.feedback.integrate(r, obs, sat)
        # the filter on the applied command, in level-flight units (as learnt)
        self.uf += self.alpha * (u * tilt - self.uf)
        self.u_buf.append(self.uf)
        return Command(u=u, u_ff=u_ff, u_fb=u_fb)
