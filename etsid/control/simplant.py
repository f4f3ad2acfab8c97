"""The simulated hexacopter as a :class:`~etsid.control.plant.Plant` (placeholder).

Waits for the simulator's stepping API (issue 12: advance the vehicle from a full state
with external loop commands, altitude hold off, mass change mid-flight).
"""

from __future__ import annotations

from pathlib import Path

from etsid.errors import ControlError


class SimPlant:
    """Placeholder until ``etsid.sim`` can be stepped from outside."""

    def __init__(self, vehicle: str | Path | None = None, seed: int = 0,
                 dt: float = 0.02) -> None:
        raise ControlError("the simulator cannot be stepped from outside yet "
                           "(etsid.sim stepping API missing)")
