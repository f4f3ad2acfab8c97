"""One mechanism for every simulation setting: dotted ``vehicle.*`` / ``scenario.*`` keys.

``etsid simulate --set vehicle.thrust_scale=1.1 --set scenario.duration=60`` and
``simulate(..., settings={"vehicle.thrust_scale": 1.1, "scenario.duration": 60})`` go
through :func:`split_settings`: ``vehicle.KEY`` is any key of
:meth:`etsid.sim.vehicle.Vehicle.with_settings` (an effect name, ``mass``,
``battery_sag`` or ``SECTION.FIELD``), ``scenario.KEY`` any setting of the scenario
(:data:`etsid.sim.SCENARIOS`). Values are checked where they are used, with one-line
:class:`~etsid.errors.SimError` messages naming the key.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from etsid.errors import SimError
from etsid.sim.vehicle import resolve_vehicle_key

PREFIXES = ("vehicle", "scenario")


def split_settings(settings: Mapping[str, Any] | None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split dotted settings into vehicle and scenario settings (prefix removed).

    Parameters
    ----------
    settings : mapping or None
        ``{"vehicle.thrust_scale": 1.1, "scenario.duration": 60.0, ...}``.

    Returns
    -------
    vehicle, scenario : dict
        Keys without their prefix.

    Raises
    ------
    SimError
        A key without a known prefix, or a vehicle key that names no field or effect.

    Examples
    --------
    >>> split_settings({"vehicle.time_delay": 0.02, "scenario.altitude": 1.0})
    ({'time_delay': 0.02}, {'altitude': 1.0})
    """
    vehicle: dict[str, Any] = {}
    scenario: dict[str, Any] = {}
    for key, value in (settings or {}).items():
        prefix, _, rest = str(key).partition(".")
        if prefix not in PREFIXES or not rest:
            raise SimError(f"setting {key!r}: a key starts with 'vehicle.' or 'scenario.' "
                           "(e.g. vehicle.thrust_scale, scenario.duration)")
        if prefix == "vehicle":
            resolve_vehicle_key(rest)  # unknown keys fail here, before any simulation
            vehicle[rest] = value
        else:
            scenario[rest] = value
    return vehicle, scenario
