"""PX4's airframe numbers: the ``SYS_AUTOSTART`` family of a log and the rotor layout it
implies, for logs without control-allocation geometry (PX4 before 1.13 has no
``CA_ROTOR*`` parameters).

PX4 numbers its airframe scripts in blocks of a thousand, one block per frame family
(``ROMFS/px4fmu_common/init.d``: 4000–4999 quad X, 5000–5999 quad +, 6000–6999 hexa X,
7000–7999 hexa +, 8000–8999 octo X, 9000–9999 octo +, 10000–10999 wide-arm / H quads,
11000–11999 coaxial hexa, 12000–12999 coaxial octo, 13000–13999 VTOL). The families whose
motor order is PX4's standard one for the count (quad X, hexa X, coaxial octo X) are
confirmed by it; the others are named, not laid out.

>>> airframe_family(12001)
('octo coax', True)
>>> airframe_family(13014)
('VTOL', False)
>>> airframe_family(0) is None
True
"""

from __future__ import annotations

FAMILIES: dict[int, tuple[str, bool]] = {
    1: ("simulation", False), 2: ("plane", False), 3: ("flying wing", False),
    4: ("quad X", True), 5: ("quad +", False), 6: ("hexa X", True), 7: ("hexa +", False),
    8: ("octo X", False), 9: ("octo +", False), 10: ("quad wide / H", False),
    11: ("hexa coax", False), 12: ("octo coax", True), 13: ("VTOL", False),
}
"""Thousands block → (family, whether its motor order is PX4's standard layout for its
rotor count: Quad X, Hexa X, Octo coax X)."""

NOT_MULTIROTOR = ("plane", "flying wing", "VTOL")
"""Families whose outputs drive control surfaces or tilt rotors too."""


def airframe_family(autostart: object) -> tuple[str, bool] | None:
    """(family name, standard layout?) of a ``SYS_AUTOSTART`` value; None for 0, a value
    outside the blocks above, or one that is not a number."""
    try:
        value = int(autostart)  # type: ignore[call-overload]
    except (TypeError, ValueError):
        return None
    return FAMILIES.get(value // 1000) if value >= 1000 else None
