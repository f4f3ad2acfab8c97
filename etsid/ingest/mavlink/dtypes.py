"""numpy views of MAVLink payloads, built from pymavlink's own message definitions.

pymavlink's generated dialect classes carry each message's wire layout as a ``struct``
format (fields sorted by size, extensions last) and the field names in the same order.
:func:`message_dtype` turns that into a packed little-endian numpy structured dtype, so
a block of payloads (zero-padded to full length, as MAVLink 2 truncates trailing zero
bytes) can be decoded in one ``view``.
"""

from __future__ import annotations

import re
from functools import cache
from types import ModuleType

import numpy as np

_STRUCT_TO_NUMPY = {
    "b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4",
    "q": "<i8", "Q": "<u8", "f": "<f4", "d": "<f8", "c": "S1",
}


@cache
def dialect() -> ModuleType:
    """pymavlink's ArduPilot dialect (a superset of ``common``), MAVLink 2 flavour."""
    from pymavlink.dialects.v20 import ardupilotmega

    return ardupilotmega


def message_class(name_or_id: str | int) -> type:
    """pymavlink message class by name (``ATTITUDE``) or numeric id."""
    mod = dialect()
    if isinstance(name_or_id, int):
        return mod.mavlink_map[name_or_id]
    return getattr(mod, f"MAVLink_{name_or_id.lower()}_message")


@cache
def message_ids() -> dict[str, int]:
    """Message name → id for every message of the dialect."""
    return {cls.msgname: mid for mid, cls in dialect().mavlink_map.items()}


@cache
def crc_extra_table() -> np.ndarray:
    """``CRC_EXTRA`` per message id (int16 array; −1 where the dialect has no message)."""
    table = np.full(max(dialect().mavlink_map) + 1, -1, dtype=np.int16)
    for mid, cls in dialect().mavlink_map.items():
        table[mid] = cls.crc_extra
    return table


@cache
def message_dtype(msgid: int) -> np.dtype:
    """Packed little-endian structured dtype of a message's full payload (with extensions).

    >>> message_dtype(30).names
    ('time_boot_ms', 'roll', 'pitch', 'yaw', 'rollspeed', 'pitchspeed', 'yawspeed')
    >>> message_dtype(30).itemsize
    28
    """
    cls = message_class(msgid)
    fmt = cls.unpacker.format
    fmt = fmt.decode() if isinstance(fmt, (bytes, bytearray)) else fmt
    tokens = re.findall(r"(\d*)([a-zA-Z])", fmt.lstrip("<>=!@"))
    names = list(cls.ordered_fieldnames)
    if len(tokens) != len(names):
        raise ValueError(f"{cls.msgname}: format {fmt!r} does not match its field list")
    fields = []
    for name, (count, char) in zip(names, tokens, strict=True):
        n = int(count) if count else 1
        if char == "s":
            fields.append((name, f"S{n}"))
        elif n > 1:
            fields.append((name, _STRUCT_TO_NUMPY[char], (n,)))
        else:
            fields.append((name, _STRUCT_TO_NUMPY[char]))
    return np.dtype(fields)
