"""ArduPilot's motor layouts: ``FRAME_CLASS`` / ``FRAME_TYPE`` → rotor angles and spins.

ArduCopter (≥ 3.5) states its frame in two parameters; its mixer (``AP_MotorsMatrix``) then
puts motor i (output i by default) at a fixed angle, with a fixed spin. The table below
holds the frames whose rotors sit on a circle (the classes quad, hexa, octa, octa-quad with
the types plus, X and H); the others (V, V-tail, Y6, dodeca, ...) are not read and a fit
falls back to the standard layout for the motor count, as it says. A log has no arm length:
the layout is angles and spins on a unit circle, marked ``arm_known = False``.

The DataFlash reader puts the parameters in the table's ``attrs["log"]`` (``frame_class``,
``frame_type``); :func:`etsid.fit.layout.rotor_layout` reads them.

>>> layout = frame_layout({"FRAME_CLASS": 2.0, "FRAME_TYPE": 1.0})
>>> [round(a) for a in layout["angles_deg"]], layout["spin"][:2]
([90, 270, 330, 150, 30, 210], [-1.0, 1.0])
>>> frame_layout({"FRAME_CLASS": 1.0, "FRAME_TYPE": 4.0}) is None
True
"""

from __future__ import annotations

import math
from typing import Any

CCW, CW = 1.0, -1.0
"""Spin seen from above: +1 counter-clockwise (etsid's convention, the simulator's)."""

CLASS_NAMES = {1: "quad", 2: "hexa", 3: "octa", 4: "octa-quad"}
TYPE_NAMES = {0: "plus", 1: "X", 3: "H"}

_FRAMES: dict[tuple[int, int], tuple[tuple[float, float], ...]] = {
    # (class, type): (angle clockwise from the nose in degrees, spin) of motors 1, 2, ...
    (1, 0): ((90, CCW), (-90, CCW), (0, CW), (180, CW)),
    (1, 1): ((45, CCW), (-135, CCW), (-45, CW), (135, CW)),
    (1, 3): ((45, CW), (-135, CW), (-45, CCW), (135, CCW)),
    (2, 0): ((0, CW), (180, CCW), (-120, CW), (60, CCW), (-60, CCW), (120, CW)),
    (2, 1): ((90, CW), (-90, CCW), (-30, CW), (150, CCW), (30, CCW), (-150, CW)),
    (3, 0): ((0, CW), (180, CW), (45, CCW), (135, CCW), (-45, CCW), (-135, CCW), (-90, CW),
             (90, CW)),
    (3, 1): ((22.5, CW), (-157.5, CW), (67.5, CCW), (157.5, CCW), (-22.5, CCW),
             (-112.5, CCW), (-67.5, CW), (112.5, CW)),
    (4, 0): ((0, CCW), (-90, CW), (180, CCW), (90, CW), (-90, CCW), (0, CW), (90, CCW),
             (180, CW)),
    (4, 1): ((45, CCW), (-45, CW), (-135, CCW), (135, CW), (-45, CCW), (45, CW), (135, CCW),
             (-135, CW)),
    (4, 3): ((45, CW), (-45, CCW), (-135, CW), (135, CCW), (-45, CW), (45, CCW), (135, CW),
             (-135, CCW)),
}
"""Motor angles and spins of ArduPilot's matrix frames on a circle (ArduCopter's
``AP_MotorsMatrix::setup_motors``, 4.x)."""


def frame_layout(params: dict[str, Any]) -> dict[str, Any] | None:
    """Motor layout of ``FRAME_CLASS`` / ``FRAME_TYPE`` (None when the parameters are absent
    or name a frame outside the table): ``angles_deg`` (clockwise from the nose),
    ``x``/``y`` on a unit circle (FRD), ``spin`` (+1 counter-clockwise), ``arm_known``
    False and ``source`` naming the frame."""
    try:
        cls, typ = int(params["FRAME_CLASS"]), int(params["FRAME_TYPE"])
    except (KeyError, TypeError, ValueError):
        return None
    rows = _FRAMES.get((cls, typ))
    if rows is None:
        return None
    angles = [a % 360.0 for a, _ in rows]
    return {"angles_deg": angles,
            "x": [math.cos(math.radians(a)) for a in angles],
            "y": [math.sin(math.radians(a)) for a in angles],
            "spin": [s for _, s in rows], "arm_known": False,
            "source": f"the log's FRAME_CLASS {cls} / FRAME_TYPE {typ} (ArduPilot "
                      f"{CLASS_NAMES[cls]} {TYPE_NAMES[typ]})"}
