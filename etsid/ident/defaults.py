"""The default MIMO rate model of a multirotor log, and where its inputs come from.

Outputs are the body rates ``p q r`` (rad/s). Regressors (the chapter's model with small
lags, documented in docs/identify.md):

- each rate at k−1 … k−``OUTPUT_LAGS`` (autoregression; several lags let the model average
  gyro noise instead of copying it),
- each loop command at k−1 … k−``INPUT_LAGS``.

Inputs, first family present wins:

1. ``u_roll u_pitch u_yaw`` (+ ``u_thrust``): loop commands — pilot sticks (RC) or the
   rate controller's torque commands (PX4 ``actuator_controls_0`` /
   ``vehicle_torque_setpoint``), whatever ingest mapped;
2. ``sp_p sp_q sp_r``: rate setpoints (PX4 ``vehicle_rates_setpoint``, MAVLink
   ``ATTITUDE_TARGET``);
3. motor outputs ``m1`` … ``m8``.

>>> import pandas as pd
>>> t = pd.DataFrame({c: [0.0, 0.1] for c in ["p", "q", "r", "sp_p", "sp_q", "sp_r"]})
>>> default_model(t).inputs
['sp_p', 'sp_q', 'sp_r']
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from etsid.errors import IdentError
from etsid.ident.regressors import RegressorSpec
from etsid.table import RATE_COLUMNS

OUTPUT_LAGS = 4
"""Autoregressive lags of each rate, samples."""

INPUT_LAGS = 2
"""Lags of each loop command, samples."""

FAMILIES: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("loop commands", ("u_roll", "u_pitch", "u_yaw"), ("u_thrust",)),
    ("rate setpoints", ("sp_p", "sp_q", "sp_r"), ()),
    ("motor outputs", ("m1", "m2", "m3", "m4"), ("m5", "m6", "m7", "m8")),
)


@dataclass
class DefaultModel:
    """What :func:`default_model` chose and why."""

    spec: RegressorSpec
    inputs: list[str]
    family: str
    sources: dict[str, str]

    @property
    def note(self) -> str:
        """One line for people: which inputs were used and where they came from."""
        src = ", ".join(f"{c} <- {s}" for c, s in self.sources.items())
        return f"inputs: {self.family} ({', '.join(self.inputs)})" + (f" from {src}" if src
                                                                         else "")


def _has(table: pd.DataFrame, name: str) -> bool:
    return name in table.columns and bool(table[name].notna().any())


def default_model(table: pd.DataFrame, output_lags: int = OUTPUT_LAGS,
                  input_lags: int = INPUT_LAGS) -> DefaultModel:
    """Pick the default MIMO rate model for ``table``.

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
    found = [(name, list(needed) + [c for c in optional if _has(table, c)])
             for name, needed, optional in FAMILIES if all(_has(table, c) for c in needed)]
    if not found:
        raise IdentError("the default rate model needs inputs u_roll u_pitch u_yaw, or "
                         f"sp_p sp_q sp_r, or motor outputs m1..m4; the table has: {have} "
                         "(use --regressors to choose)")
    family, inputs = found[0]
    terms = [f"{y}[k-1..k-{output_lags}]" if output_lags > 1 else f"{y}[k-1]"
             for y in RATE_COLUMNS]
    terms += [f"{u}[k-1..k-{input_lags}]" if input_lags > 1 else f"{u}[k-1]" for u in inputs]
    spec = RegressorSpec.parse(",".join(terms), RATE_COLUMNS)
    mapping = dict(table.attrs.get("mapping") or {})
    sources = {c: str(mapping[c]) for c in inputs if c in mapping}
    return DefaultModel(spec, inputs, family, sources)
