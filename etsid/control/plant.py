"""The plant the vertical-loop controllers fly: a small protocol and its observation.

A :class:`Plant` advances the vehicle by one control period with a collective thrust
command and reports what the autopilot measures (rangefinder altitude, vertical speed,
attitude) together with the noise-free altitude used only for scoring. The attitude
loops stay the plant's own; only the collective is commanded from outside.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class Observation:
    """What the vertical-loop controller sees after a control period.

    Attributes
    ----------
    t : float
        Time since the start of the flight, s.
    alt : float
        Measured height above ground (rangefinder, sample-and-hold), m.
    vz : float
        Measured NED vertical velocity (positive down), m/s.
    roll, pitch : float
        Measured attitude, rad.
    true_alt : float
        Noise-free CG height above ground, m (scoring only; controllers never read it).
    mass : float
        Current vehicle mass, kg (truth, for the log).
    """

    t: float
    alt: float
    vz: float
    roll: float
    pitch: float
    true_alt: float
    mass: float


class Plant(Protocol):
    """A vehicle whose vertical loop is closed from outside.

    Attributes
    ----------
    dt : float
        Control period, s (the plant may integrate with a finer step inside).
    hover_command : float
        Collective command (0..1) that hovers the vehicle as built, out of ground effect:
        the one piece of prior knowledge both controllers start from.
    """

    dt: float
    hover_command: float

    def reset(self, altitude: float) -> Observation:
        """Start a new flight in trimmed hover with the CG at ``altitude`` (m)."""
        ...

    def step(self, u_thrust: float) -> Observation:
        """Hold the collective ``u_thrust`` (0..1) for one control period; observe."""
        ...

    def set_mass(self, mass: float) -> None:
        """Change the vehicle mass (kg) from now on (a payload picked up or dropped)."""
        ...
