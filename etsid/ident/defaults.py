"""The default MIMO rate model of a multirotor log, and where its inputs come from.

Outputs are the body rates ``p q r`` (rad/s). Regressors (the chapter's model with small
lags, documented in docs/identify.md):

- each rate at k−1 … k−``OUTPUT_LAGS`` (autoregression; several lags let the model average
  gyro noise instead of copying it),
- each loop command at k−1 … k−``INPUT_LAGS``,
- ``roll[k-1]`` and ``pitch[k-1]`` when the inputs are sticks or attitude setpoints and the
  log has the attitude (:data:`ATTITUDE_TERMS`): the attitude loop closes around those
  inputs, so the rate response depends on the angle reached; in free run the angles are
  integrated from the simulated rates (:mod:`etsid.ident.simulate`),

at the identification rate (:data:`etsid.ident.resample.DEFAULT_RATE_HZ`, 50 Hz): with 4
output and 6 input lags the model sees 80 ms of rate and 120 ms of command history (lag
study in docs/identify.md).

Inputs (``inputs="auto"``), first family present wins:

1. ``u_roll u_pitch u_yaw`` (+ ``u_thrust``): loop commands — pilot sticks (RC) or the
   rate controller's torque commands (PX4 ``actuator_controls_0`` /
   ``vehicle_torque_setpoint``), whatever ingest mapped;
2. ``sp_p sp_q sp_r``: rate setpoints (PX4 ``vehicle_rates_setpoint``, MAVLink
   ``ATTITUDE_TARGET``);
3. attitude setpoints ``sp_roll sp_pitch sp_yaw`` (+ ``u_thrust``);
4. motor outputs: the commands they carry ``mot_roll mot_pitch mot_yaw mot_thrust`` when
   the motor layout is known (:mod:`etsid.ident.motors`), else ``m1`` … ``m8``.

``inputs`` names a family (:data:`etsid.ident.inputs.MODES`); ``auto`` follows the choice
made when the log was read, else the order above.

>>> import pandas as pd
>>> t = pd.DataFrame({c: [0.0, 0.1] for c in ["p", "q", "r", "sp_p", "sp_q", "sp_r"]})
>>> default_model(t).inputs
['sp_p', 'sp_q', 'sp_r']
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from etsid.errors import IdentError
from etsid.ident.bare import bare
from etsid.ident.choices import ATTITUDE_MODES as ATTITUDE_MODES
from etsid.ident.choices import INPUT_LAGS as INPUT_LAGS
from etsid.ident.choices import OUTPUT_LAGS as OUTPUT_LAGS
from etsid.ident.choices import SCHEDULE as SCHEDULE
from etsid.ident.inputs import AXES, MODES, excited, kind_of
from etsid.ident.motors import MOTOR_COMMANDS, motor_columns
from etsid.ident.regressors import RegressorSpec
from etsid.table import RATE_COLUMNS

ATTITUDE_TERMS = "roll[k-1],pitch[k-1]"
"""Attitude states of the rate model when the attitude loop closes around its inputs
(``attitude="auto"``); chosen by the attitude study of docs/identify.md."""

FAMILIES: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("loop commands", ("u_roll", "u_pitch", "u_yaw"), ("u_thrust",)),
    ("rate setpoints", ("sp_p", "sp_q", "sp_r"), ()),
    ("attitude setpoints", ("sp_roll", "sp_pitch", "sp_yaw"), ("u_thrust",)),
    ("motor commands", MOTOR_COMMANDS, ()),
    ("motor outputs", ("m1", "m2", "m3", "m4"), ("m5", "m6", "m7", "m8")),
)


@dataclass
class DefaultModel:
    """What :func:`default_model` chose and why."""

    spec: RegressorSpec
    inputs: list[str]
    family: str
    sources: dict[str, str]
    kind: str = "unknown"
    reason: str = ""
    attitude: bool = False

    @property
    def note(self) -> str:
        """One line for people: which inputs were used and where they came from."""
        src = ", ".join(f"{c} <- {s}" for c, s in self.sources.items())
        kind = f" [{self.kind}]" if self.kind != "unknown" else ""
        why = f"; {self.reason}" if self.reason else ""
        return (f"inputs: {self.family} ({', '.join(self.inputs)}){kind}"
                + (f" from {src}" if src else "") + why)


def _has(table: pd.DataFrame, name: str) -> bool:
    return name in table.columns and bool(bare(table)[name].notna().any())


def _u_kind(table: pd.DataFrame) -> str:
    """``sticks``/``torque`` for the table's u_* columns (from the input selection made on
    reading, else the mapping), ``unknown`` without provenance."""
    selection = table.attrs.get("input_selection")
    if isinstance(selection, dict) and selection.get("kind") in ("sticks", "torque"):
        return str(selection["kind"])
    mapping = table.attrs.get("mapping") or {}
    return kind_of(mapping.get("u_roll")) if isinstance(mapping, dict) else "unknown"


def _family(table: pd.DataFrame, inputs: str,
            found: dict[str, list[str]]) -> tuple[str, str]:
    """Family name and the reason for it, following ``inputs`` (see module docstring)."""
    loop, kind = "loop commands", _u_kind(table)
    if inputs in ("sticks", "torque"):
        if loop not in found:
            raise IdentError(f"--inputs {inputs}: the table has no u_roll u_pitch u_yaw")
        if kind not in (inputs, "unknown"):
            raise IdentError(f"--inputs {inputs}: the table's u_* columns are {kind} "
                             f"({(table.attrs.get('mapping') or {}).get('u_roll')}); read "
                             "the log itself, or --map u_roll=TOPIC.FIELD …")
        return loop, f"--inputs {inputs}"
    if inputs == "setpoints":
        if "rate setpoints" not in found:
            raise IdentError("--inputs setpoints: the table has no sp_p sp_q sp_r")
        return "rate setpoints", "--inputs setpoints"
    if inputs == "attitude":
        if "attitude setpoints" not in found:
            raise IdentError("--inputs attitude: the table has no sp_roll sp_pitch sp_yaw")
        return "attitude setpoints", "--inputs attitude"
    motors = next((f for f in ("motor commands", "motor outputs") if f in found), None)
    if inputs == "motors":
        if motors is None:
            raise IdentError("--inputs motors: the table has no motor outputs m1..m4")
        return motors, "--inputs motors" + _layout_note(motors)
    if inputs != "auto":
        raise IdentError(f"--inputs {inputs!r}: choose one of {', '.join(MODES)}")
    selection = table.attrs.get("input_selection")
    if isinstance(selection, dict) and selection.get("kind"):
        want = {"setpoints": "rate setpoints", "attitude": "attitude setpoints",
                "motors": motors}.get(selection["kind"], loop)
        if want in found:
            return want, str(selection.get("reason", "")) + (
                _layout_note(want) if selection["kind"] == "motors" else "")
    if loop in found:
        if kind == "torque":
            return loop, "torque commands"
        stats = {c: {"std": float(np.nanstd(table[c].to_numpy(dtype=float))),
                     "rate_hz": float("inf")} for c in AXES}
        if excited(stats):
            return loop, ""
        flat = ", ".join(f"{c} std {v['std']:.3g}" for c, v in stats.items())
        for other in ("rate setpoints", "attitude setpoints", "motor commands",
                      "motor outputs"):
            if other in found:
                return other, f"loop commands without excitation ({flat}): {other}"
        return loop, f"loop commands without excitation ({flat}), nothing else: used anyway"
    return next(iter(found)), ""


def _layout_note(family: str | None) -> str:
    return ("; layout known: the commands the motor outputs carry (mixer inverse)"
            if family == "motor commands" else
            "; no motor layout: the raw motor outputs" if family == "motor outputs" else "")


def _closes_attitude(table: pd.DataFrame, family: str, kind: str) -> bool:
    """Does the attitude loop close around the inputs (sticks of a stabilised mode, or
    attitude setpoints) and does the table have the angles?"""
    around = family == "attitude setpoints" or (family == "loop commands"
                                                and kind in ("sticks", "unknown"))
    return around and _has(table, "roll") and _has(table, "pitch")


def default_model(table: pd.DataFrame, output_lags: int = OUTPUT_LAGS,
                  input_lags: int = INPUT_LAGS, inputs: str = "auto",
                  attitude: str = "auto") -> DefaultModel:
    """Pick the default MIMO rate model for ``table``.

    Parameters
    ----------
    table
        FlightTable (its ``attrs["input_selection"]``, set when a log is read with
        :func:`etsid.ident.inputs.load_for_ident`, and ``attrs["mapping"]`` tell where the
        ``u_*`` columns came from).
    output_lags, input_lags
        Lags, samples.
    inputs
        One of :data:`etsid.ident.inputs.MODES`.
    attitude
        ``auto`` or ``on``: add :data:`ATTITUDE_TERMS` when the attitude loop closes around
        the inputs and the table has ``roll pitch``; ``none``: never.

    Raises
    ------
    IdentError
        No body rates, or none of the input families, with the columns the table has.
    """
    if output_lags < 1 or input_lags < 1:
        raise IdentError("default model lags must be ≥ 1")
    missing = [c for c in RATE_COLUMNS if not _has(table, c)]
    have = ", ".join(c for c in table.columns if c != "segment") or "none"
    if missing:
        raise IdentError(f"the default rate model needs p, q, r: no data in "
                         f"{', '.join(missing)}; the table has: {have} "
                         "(use --output and --regressors for other columns)")
    found = {name: list(needed) + [c for c in optional if _has(table, c)]
             for name, needed, optional in FAMILIES if all(_has(table, c) for c in needed)}
    if not found:
        raise IdentError("the default rate model needs inputs u_roll u_pitch u_yaw, or "
                         f"sp_p sp_q sp_r, or motor outputs m1..m4; the table has: {have} "
                         "(use --regressors to choose)")
    family, reason = _family(table, inputs, found)
    inputs_used = found[family]
    terms = [f"{y}[k-1..k-{output_lags}]" if output_lags > 1 else f"{y}[k-1]"
             for y in RATE_COLUMNS]
    terms += [f"{u}[k-1..k-{input_lags}]" if input_lags > 1 else f"{u}[k-1]"
              for u in inputs_used]
    kind = {"rate setpoints": "setpoints", "attitude setpoints": "attitude",
            "motor commands": "motors", "motor outputs": "motors"}.get(family) or _u_kind(table)
    if attitude not in ATTITUDE_MODES:
        raise IdentError(f"--attitude-states {attitude!r}: choose one of "
                         f"{', '.join(ATTITUDE_MODES)}")
    with_attitude = attitude != "none" and _closes_attitude(table, family, kind)
    if with_attitude:
        terms.append(ATTITUDE_TERMS)
    spec = RegressorSpec.parse(",".join(terms), RATE_COLUMNS)
    mapping = dict(table.attrs.get("mapping") or {})
    sources = {c: str(mapping[c]) for c in inputs_used if c in mapping}
    if family == "motor commands":
        motors = motor_columns(table)
        sources = dict.fromkeys(inputs_used, f"mixer inverse of {motors[0]}…{motors[-1]}")
    return DefaultModel(spec, inputs_used, family, sources, kind, reason, with_attitude)
