"""What a fit returns: each parameter with its unit, standard error and verdict."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

VERDICTS = ("identified", "not-determined", "unidentifiable", "declared")
"""``identified``: the 95 % interval is within the parameter's tolerance of its value;
``not-determined``: estimable in principle but this flight does not pin it down (fixed to
the default); ``unidentifiable``: no log of this kind can separate it (fixed to a declared
default); ``declared``: read from the log's parameters, not estimated."""

TOLERANCE: dict[str, float] = {
    "hover_command": 0.05, "thrust_to_weight": 0.05, "thrust_slope": 0.05,
    "idle_ratio": 0.20, "motor_time_constant": 0.20, "roll_effectiveness": 0.20,
    "pitch_effectiveness": 0.20, "yaw_effectiveness": 0.20, "inertia_ratio_yx": 0.20,
    "roll_accel_per_command": 0.20, "pitch_accel_per_command": 0.20,
    "yaw_accel_per_command": 0.20,
    "drag_x": 0.20, "drag_y": 0.20, "drag_quad_x": 0.20, "drag_quad_y": 0.20,
}
"""Relative half-width of the 95 % interval below which a parameter counts as identified
(issue 40's accuracy classes: 5 % for thrust per weight and hover command, 20 % for the
rest)."""

ABS_TOLERANCE: dict[str, float] = {"time_delay": 0.010, "hover_command_per_volt": 0.005}
"""Parameters whose value may be zero: identified when the 95 % half-width is below this
(s; 1/V)."""


@dataclass
class Param:
    """One fitted (or fixed) parameter."""

    name: str
    value: float
    se: float
    unit: str
    verdict: str
    meaning: str
    note: str = ""

    @property
    def interval(self) -> tuple[float, float]:
        """95 % interval (value ± 1.96 se); (value, value) for a fixed parameter."""
        if not math.isfinite(self.se):
            return (self.value, self.value)
        return (self.value - 1.96 * self.se, self.value + 1.96 * self.se)


def judge(name: str, value: float, se: float) -> str:
    """``identified`` or ``not-determined`` from the 95 % half-width (:data:`TOLERANCE`)."""
    if not (math.isfinite(value) and math.isfinite(se)):
        return "not-determined"
    if name in ABS_TOLERANCE:
        return "identified" if 1.96 * se <= ABS_TOLERANCE[name] else "not-determined"
    tol = TOLERANCE.get(name, 0.20)
    return "identified" if value != 0 and 1.96 * se <= tol * abs(value) else "not-determined"


@dataclass
class FitResult:
    """Everything ``etsid fit`` found for one airframe."""

    params: dict[str, Param]
    vehicle: dict[str, Any]                      # the vehicle file's content
    sources: list[str]                           # the logs pooled
    layout: dict[str, Any]                       # rotor geometry and where it came from
    counts: dict[str, int] = field(default_factory=dict)   # samples used / left out, why
    notes: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict (``"schema": "etsid.fit/1"``)."""
        return {"schema": "etsid.fit/1", "sources": self.sources, "layout": self.layout,
                "counts": self.counts, "notes": self.notes,
                "params": {k: {kk: (None if isinstance(vv, float) and not math.isfinite(vv)
                                    else vv) for kk, vv in asdict(p).items()}
                           for k, p in self.params.items()}}

    def summary(self) -> str:
        """Human table: name, value ± se, unit, verdict."""
        lines = [f"{'parameter':26s} {'value':>12s} {'± se':>10s}  {'unit':10s} verdict"]
        for p in self.params.values():
            se = f"{p.se:.3g}" if math.isfinite(p.se) else "—"
            lines.append(f"{p.name:26s} {p.value:12.4g} {se:>10s}  {p.unit:10s} {p.verdict}"
                         + (f" ({p.note})" if p.note else ""))
        return "\n".join(lines + [f"note: {n}" for n in self.notes])
