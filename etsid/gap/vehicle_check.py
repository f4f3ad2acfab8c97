"""Could one vehicle explain both logs? Said first, before any physics is named.

A fault or a missing effect changes a vehicle by a bounded amount: a thrust scale of
±20 %, a heavier inertia of 30–60 %, a sagging pack. Two *different* airframes differ by
more, and on several ratios at once. The checks compare what each log says about its own
vehicle, each measured on that log alone:

* the rotor count and the kind of inputs (structural; :func:`structural`);
* the hover thrust command, as ``mean((m + k)²)`` (thrust-to-weight);
* the pack voltage (cell count);
* the control effectiveness per axis: angular acceleration per unit differential thrust
  command, from the nominal model fitted on each log (``(T·arm)/I`` of each airframe);
* the rate-response bandwidth: each log's own fitted motor time constant (reported, not
  judged: a slow motor is a fault the vocabulary names).

A ratio outside :data:`PLAUSIBLE` is evidence of a different airframe.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from etsid.gap.nominal import NominalModel, fit_nominal
from etsid.gap.signals import Flight

PLAUSIBLE = {
    "hover thrust": (1 / 1.6, 1.6),
    "hover thrust at equal voltage": (1 / 1.6, 1.6),
    "pack voltage": (1 / 1.4, 1.3),
    "roll effectiveness": (0.2, 5.0),
    "pitch effectiveness": (0.2, 5.0),
}
"""REAL/SIM ratios one airframe with a fault can reach. Hover thrust: a 20 % thrust loss
(1.25×) plus a payload, not a vehicle that needs 1.6× the thrust command; where both logs
have the pack voltage it is judged at equal voltage (``(m + k)² (V/V_sim)²``: an ESC's duty
drives the motor at duty × V, so a pack at 0.76× needs 1.73× the command² for the same
thrust, which is a sag, not another airframe); pack voltage: a LiPo cell reads 4.2 V
full and drops to 3.0 V loaded when empty (PX4's empty cell at 3.5 V less its 0.3 V load
drop, a worn pack lower), so a recording whose pack sags or runs down reaches 0.71× a
simulation's full one; above, a pack 1.3× SIM's is not a sag but one cell in four more
(4S/3S = 1.33), another pack; effectiveness: a 60 %
heavier inertia with a 20 % weaker thrust is 0.5×, and each log's own fit of it moves
with its motor lag (a lag three times SIM's gave 0.37× on a dev pair of one airframe), so
only a factor of five says another airframe. Yaw effectiveness is reported, not judged:
the reaction torque and the rotor spin-up torque share their regressors, and a changed
rotor inertia or a delay moves the split between them by several times on one airframe."""
AXES = (("roll effectiveness", "p"), ("pitch effectiveness", "q"), ("yaw effectiveness", "r"))


@dataclass
class VehicleCheck:
    """What the two logs say about their vehicles."""

    ratios: dict[str, float] = field(default_factory=dict)
    evidence: list[str] = field(default_factory=list)
    bandwidth: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """gap.json ``vehicle_check``."""
        return {"ratios": self.ratios, "plausible": {k: list(v) for k, v in PLAUSIBLE.items()
                                                     if k in self.ratios},
                "evidence": self.evidence, "motor_time_constant_s": self.bandwidth}


def structural(sim: Flight, real: Flight) -> str | None:
    """A difference no fault makes: the number of rotors (or of commands)."""
    if sim.inputs == real.inputs and sim.motors.shape[1] != real.motors.shape[1]:
        return (f"{real.name} has {real.motors.shape[1]} motor outputs, {sim.name} "
                f"{sim.motors.shape[1]}: another rotor count is another airframe")
    return None


def _hover(flight: Flight, k: float) -> float:
    if flight.inputs == "motors":
        power = np.mean((np.clip(flight.motors, 0, 1) + k) ** 2, axis=1)
    else:
        power = (np.clip(flight.motors[:, 0], 0, 1) + k) ** 2
    return float(np.median(power[flight.airborne]))


def _effectiveness(model: NominalModel, channel: str, n_inputs: int) -> float:
    """RMS of the channel's coefficients on the differential thrust (p, q) or reaction
    torque (r) of each input: the first ``n_inputs`` regressors of the channel."""
    coef = model.coef.get(channel)
    if coef is None:
        return float("nan")
    return float(np.sqrt(np.mean(coef[:n_inputs] ** 2)))


def check_vehicles(sim: Flight, real: Flight, nominal: NominalModel) -> VehicleCheck:
    """Ratios REAL/SIM of what defines an airframe, and the evidence among them."""
    out = VehicleCheck()
    k = nominal.k
    out.ratios["hover thrust"] = _hover(real, k) / max(_hover(sim, k), 1e-9)
    if "vbat" in sim.have and "vbat" in real.have:
        v_sim = float(np.nanmedian(sim.vbat[sim.airborne]))
        v_real = float(np.nanmedian(real.vbat[real.airborne]))
        out.ratios["pack voltage"] = v_real / max(v_sim, 1e-9)
        out.ratios["hover thrust at equal voltage"] = (out.ratios["hover thrust"]
                                                       * out.ratios["pack voltage"] ** 2)
    own = fit_nominal(real, law=(k, nominal.v_ref))
    n = sim.motors.shape[1] if sim.inputs == "motors" else 3
    for name, c in AXES:
        a, b = _effectiveness(own, c, n), _effectiveness(nominal, c, n)
        if np.isfinite(a) and np.isfinite(b) and b > 0:
            out.ratios[name] = a / b
    out.bandwidth = {"sim": nominal.tau, "real": own.tau}
    for name, ratio in out.ratios.items():
        if name not in PLAUSIBLE or (name == "hover thrust"
                                     and "hover thrust at equal voltage" in out.ratios):
            continue
        lo, hi = PLAUSIBLE[name]
        if not lo < ratio < hi:
            out.evidence.append(f"{name} {ratio:.2f}× {sim.name}'s (one airframe with a fault "
                                f"stays within {lo:.2f}–{hi:.2f}×)")
    return out
