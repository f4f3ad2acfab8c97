"""What a log says about the aircraft: vehicle type, autopilot, firmware and hardware.

Readers put these facts in ``RawLog.extra`` (keys :data:`FACTS`) when the log names them,
and :func:`etsid.ingest.align.build_table` copies them to the table's ``attrs``. Nothing
is guessed: a fact the log does not state is absent.

* PX4 ULog: ``sys_name`` (autopilot), ``ver_sw_release`` + ``ver_sw`` (firmware),
  ``ver_hw`` (hardware), parameter ``MAV_TYPE`` (vehicle);
* MAVLink tlog: ``HEARTBEAT.type`` / ``.autopilot`` of the chosen system, the firmware
  banner in ``STATUSTEXT`` (``ArduPlane V3.10.0-dev (f2b4e06a)``), else
  ``AUTOPILOT_VERSION.flight_sw_version``;
* ArduPilot DataFlash: the firmware banner in ``MSG`` (or ``VER.FWS``), the vehicle from
  the firmware's name (ArduPlane, ArduCopter, …), the board from the ``MSG`` that follows.

>>> px4_version(17302271)
'v1.8.2'
>>> px4_version(17498624)
'v1.11.2-dev'
>>> mav_type_name(14), autopilot_name(3)
('octorotor', 'ArduPilot')
>>> banner_facts("ArduCopter V4.3.1 (abc123de)")
{'autopilot': 'ArduPilot', 'firmware': 'ArduCopter V4.3.1 (abc123de)', 'vehicle': 'multirotor'}
"""

from __future__ import annotations

import re

FACTS = ("vehicle", "autopilot", "firmware", "hardware")
"""Keys of ``RawLog.extra`` and table ``attrs`` that name the aircraft."""

_AUTOPILOTS = {3: "ArduPilot", 12: "PX4"}
"""MAV_AUTOPILOT values with a name of their own (the others: the enum name, lower case)."""

_ARDUPILOT_VEHICLES = {
    "arduplane": "fixed wing", "arducopter": "multirotor", "ardurover": "ground rover",
    "rover": "ground rover", "ardusub": "submarine", "antennatracker": "antenna tracker",
    "ardublimp": "airship", "arduheli": "helicopter",
}
"""ArduPilot firmware name → vehicle (the firmware is built for one kind of vehicle)."""

BANNER = re.compile(r"^\s*(Ardu\w+|Rover|AntennaTracker|Blimp|PX4\w*)\s+V?\d+\.\d+\S*"
                    r"(\s+\([0-9a-fA-F]+\))?")
"""A firmware banner line, e.g. ``ArduPlane V3.10.0-dev (f2b4e06a)``."""

_PX4_TYPES = ((255, ""), (192, "-rc"), (128, "-beta"), (64, "-alpha"), (0, "-dev"))


def _enum_name(enum: str, value: int) -> str | None:
    from etsid.ingest.mavlink.dtypes import dialect

    entry = dialect().enums.get(enum, {}).get(int(value))
    if entry is None or entry.name.endswith("ENUM_END"):
        return None
    return entry.name.removeprefix(f"{enum}_").lower().replace("_", " ")


def mav_type_name(value: int) -> str | None:
    """Vehicle name of a MAVLink ``MAV_TYPE`` (``2`` → ``quadrotor``); None if unknown or
    generic."""
    if int(value) == 0:
        return None
    name = _enum_name("MAV_TYPE", value)
    if name and name.startswith("vtol"):  # VTOL_RESERVEDn in older dialects: a VTOL
        return "VTOL" if "reserved" in name else "VTOL" + name[4:]
    return name


def autopilot_name(value: int) -> str | None:
    """Autopilot name of a MAVLink ``MAV_AUTOPILOT`` (``3`` → ``ArduPilot``); None for
    generic, invalid or unknown."""
    if int(value) in _AUTOPILOTS:
        return _AUTOPILOTS[int(value)]
    if int(value) in (0, 8):  # GENERIC, INVALID (not a flight controller)
        return None
    return _enum_name("MAV_AUTOPILOT", value)


def px4_version(release: int) -> str | None:
    """PX4's ``ver_sw_release`` word (0xMMmmpptt) as ``vMM.mm.pp`` plus ``-dev``/``-alpha``/
    ``-beta``/``-rc`` unless it is a release; None for 0."""
    release = int(release)
    if release <= 0:
        return None
    major, minor, patch, kind = (release >> 24) & 0xFF, (release >> 16) & 0xFF, \
        (release >> 8) & 0xFF, release & 0xFF
    suffix = next(s for floor, s in _PX4_TYPES if kind >= floor)
    return f"v{major}.{minor}.{patch}{suffix}"


def ardupilot_version(word: int) -> str | None:
    """``AUTOPILOT_VERSION.flight_sw_version`` (major, minor, patch, type bytes) as
    ``vMM.mm.pp`` (+ ``-dev``/``-alpha``/``-beta``/``-rc`` from FIRMWARE_VERSION_TYPE)."""
    word = int(word)
    if word <= 0:
        return None
    kind = word & 0xFF
    suffix = {0: "-dev", 64: "-alpha", 128: "-beta", 192: "-rc"}.get(kind, "")
    return f"v{(word >> 24) & 0xFF}.{(word >> 16) & 0xFF}.{(word >> 8) & 0xFF}{suffix}"


def banner_facts(text: str) -> dict[str, str]:
    """Firmware, autopilot and (for ArduPilot) vehicle from a firmware banner line; empty
    when ``text`` is no banner."""
    match = BANNER.match(text)
    if not match:
        return {}
    name = match.group(1)
    facts = {"firmware": match.group(0).strip()}
    if name.upper().startswith("PX4"):
        facts["autopilot"] = "PX4"
    else:
        facts["autopilot"] = "ArduPilot"
        vehicle = _ARDUPILOT_VEHICLES.get(name.lower())
        if vehicle:
            facts["vehicle"] = vehicle
    return dict(sorted(facts.items()))


def first_banner(lines: list[str]) -> tuple[dict[str, str], int | None]:
    """Facts of the first banner among ``lines`` and its index (None: no banner)."""
    for i, line in enumerate(lines):
        facts = banner_facts(line)
        if facts:
            return facts, i
    return {}, None


def decode_text(value: bytes | str) -> str:
    """A fixed-length char field as text (NUL padding and undecodable bytes dropped)."""
    if isinstance(value, bytes):
        value = value.split(b"\0", 1)[0].decode("utf-8", "replace")
    return value.replace("\ufffd", "").strip()
