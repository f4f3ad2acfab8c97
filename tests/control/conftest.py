"""Fixtures of the control tests."""

from __future__ import annotations

import math

import numpy as np
import pytest

from etsid.control.plant import Observation


class ToyPlant:
    """TEMPORARY 1-D vertical model (until the simulator's stepping API lands).

    thrust = k Ω² · ge(h), Ω first-order lag (50 ms) behind idle + span·u; measured height
    with 5 mm noise held at 50 Hz, vertical speed with 0.03 m/s noise.
    """

    def __init__(self, dt: float = 0.02, seed: int = 0, mass: float = 4.2) -> None:
        self.dt = dt
        self.mass0 = mass
        self.hover_command = 0.5545
        self.idle, self.span, self.tau = 80.0, 825.0, 0.05
        om_h = self.idle + self.span * self.hover_command
        self.k = mass * 9.80665 / om_h**2
        self.rng = np.random.default_rng(seed)

    def ge(self, h: float) -> float:
        return 1.0 + 0.2 * (0.25 / max(h, 0.1)) ** 2

    def _obs(self) -> Observation:
        return Observation(t=self.t, alt=self.h + 0.005 * self.rng.standard_normal(),
                           vz=-self.w + 0.03 * self.rng.standard_normal(), roll=0.0,
                           pitch=0.0, true_alt=self.h, mass=self.mass)

    def reset(self, altitude: float) -> Observation:
        self.t, self.h, self.w, self.mass = 0.0, altitude, 0.0, self.mass0
        self.om = math.sqrt(self.mass * 9.80665 / (self.k * self.ge(altitude)))
        return self._obs()

    def step(self, u: float) -> Observation:
        n = 20
        h = self.dt / n
        target = self.idle + self.span * u
        for _ in range(n):
            self.om += h * (target - self.om) / self.tau
            acc = self.k * self.om**2 * self.ge(self.h) / self.mass - 9.80665
            self.w += h * acc
            self.h += h * self.w
            if self.h < 0.18:
                self.h, self.w = 0.18, max(self.w, 0.0)
        self.t += self.dt
        return self._obs()

    def set_mass(self, mass: float) -> None:
        self.mass = mass


@pytest.fixture
def toy_plant() -> ToyPlant:
    return ToyPlant()
