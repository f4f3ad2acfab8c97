"""The vertical-loop tasks: altitude references, start height and mid-flight events.

Every scenario is a reference r(t) with its first two derivatives (m, m/s, m/s²), a start
height, a default duration, and optionally a payload added at a given time. Sines start
with a smooth amplitude ramp (so the vehicle, starting in hover, is not asked for a
velocity step at t = 0). The numbers are documented in docs/control.md.

>>> from etsid.control.scenarios import SCENARIOS
>>> sorted(SCENARIOS)
['altitude-steps', 'hover-ige', 'ige-sine', 'mass-change', 'sine-altitude']
>>> r, rd, rdd = SCENARIOS["sine-altitude"].reference(0.0)
>>> float(r), float(rd), float(rdd)
(2.0, 0.0, 0.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from etsid.errors import ControlError


def _smoothstep(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic ramp 0→1 on [0, 1] (zero slope and curvature at both ends) and derivatives."""
    x = np.clip(x, 0.0, 1.0)
    s = x**3 * (10.0 - 15.0 * x + 6.0 * x**2)
    ds = 30.0 * x**2 * (1.0 - x) ** 2
    dds = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x)
    return s, ds, dds


@dataclass(frozen=True)
class Scenario:
    """One vertical-loop task.

    Attributes
    ----------
    name, description : str
        Identifier and one-line description.
    duration : float
        Default flight time, s.
    start : float
        CG height at t = 0 (trimmed hover), m.
    centre, amplitude, period : float
        Sine reference r = centre + ramp(t)·amplitude·sin(2πt/period) (m, m, s); amplitude
        0 for a constant or step reference.
    ramp : float
        Duration of the amplitude ramp-in, s.
    steps : tuple of (float, float)
        (time s, new height m) for step references; the height before the first step is
        ``centre``.
    mass_change : tuple of (float, float) or None
        (time s, added mass kg): a payload picked up mid-flight.
    """

    name: str
    description: str
    duration: float
    start: float
    centre: float
    amplitude: float = 0.0
    period: float = 10.0
    ramp: float = 2.5
    steps: tuple[tuple[float, float], ...] = field(default_factory=tuple)
    mass_change: tuple[float, float] | None = None

    def reference(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reference height, climb rate and vertical acceleration at time(s) ``t``.

        Returns
        -------
        r, rd, rdd : numpy.ndarray
            m, m/s, m/s² (up positive), shaped like ``t``. Steps have zero derivatives.
        """
        t = np.asarray(t, dtype=np.float64)
        r = np.full_like(t, self.centre)
        rd = np.zeros_like(t)
        rdd = np.zeros_like(t)
        for when, height in self.steps:
            r = np.where(t >= when, height, r)
        if self.amplitude > 0.0:
            w = 2.0 * math.pi / self.period
            s, ds, dds = _smoothstep(t / self.ramp)
            ds, dds = ds / self.ramp, dds / self.ramp**2
            a = self.amplitude
            sn, cs = np.sin(w * t), np.cos(w * t)
            r = r + a * s * sn
            rd = rd + a * (ds * sn + s * w * cs)
            rdd = rdd + a * (dds * sn + 2.0 * ds * w * cs - s * w * w * sn)
        return r, rd, rdd

    def at(self, t: float) -> tuple[float, float, float]:
        """:meth:`reference` at one time ``t`` (s), as floats, without numpy (fast path)."""
        r, rd, rdd = self.centre, 0.0, 0.0
        for when, height in self.steps:
            if t >= when:
                r = height
        if self.amplitude > 0.0:
            w = 2.0 * math.pi / self.period
            x = min(max(t / self.ramp, 0.0), 1.0)
            s = x**3 * (10.0 - 15.0 * x + 6.0 * x**2)
            ds = 30.0 * x**2 * (1.0 - x) ** 2 / self.ramp
            dds = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / self.ramp**2
            a = self.amplitude
            sn, cs = math.sin(w * t), math.cos(w * t)
            r += a * s * sn
            rd += a * (ds * sn + s * w * cs)
            rdd += a * (dds * sn + 2.0 * ds * w * cs - s * w * w * sn)
        return r, rd, rdd

    def step_times(self) -> list[float]:
        """Times of the reference steps, s."""
        return [float(w) for w, _ in self.steps]


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("sine-altitude", "sine 2.0 ± 1.0 m, period 10 s (chapter Fig. 1.12 task), "
                 "above ground effect (ground-effect thrust gain ≤ 2 % at 1 m)",
                 duration=60.0, start=2.0, centre=2.0, amplitude=1.0, period=10.0),
        Scenario("altitude-steps", "height steps 1.5 → 2.5 → 1.5 → 3.0 → 2.0 → 1.0 → 2.0 m every "
                 "10 s", duration=62.0, start=1.5, centre=1.5,
                 steps=((2.0, 2.5), (12.0, 1.5), (22.0, 3.0), (32.0, 2.0), (42.0, 1.0),
                        (52.0, 2.0))),
        Scenario("hover-ige", "low hover in ground effect: 0.32 ± 0.05 m, period 8 s "
                 "(thrust per command 13–19 % above free air)", duration=40.0, start=0.32,
                 centre=0.32, amplitude=0.05, period=8.0),
        Scenario("mass-change", "the sine-altitude task with a 1.0 kg payload (+24 %) added "
                 "at 30 s",
                 duration=60.0, start=2.0, centre=2.0, amplitude=1.0, period=10.0,
                 mass_change=(30.0, 1.0)),
        Scenario("ige-sine", "sine 0.75 ± 0.45 m, period 10 s: dips to 0.30 m, deep into "
                 "ground effect (thrust per command up to 16 % higher)", duration=60.0,
                 start=0.75, centre=0.75, amplitude=0.45, period=10.0),
    )
}
"""Scenario name → :class:`Scenario` (``sine-altitude`` is the task of ``etsid simulate
sine-altitude``; the names are shared where the task is)."""

ALIASES = {"sine": "sine-altitude", "step": "altitude-steps"}
"""Former names, still accepted (``step`` was too close to simulate's stick ``steps``)."""


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name`` (or a former name of :data:`ALIASES`);
    :class:`~etsid.errors.ControlError` if there is none."""
    try:
        return SCENARIOS[ALIASES.get(name, name)]
    except KeyError:
        raise ControlError(f"unknown control scenario {name!r}; choose one of "
                           f"{', '.join(sorted(SCENARIOS))}") from None
