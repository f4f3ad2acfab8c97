"""Which signals drive the rate model: pilot sticks, torque commands or rate setpoints.

``--inputs`` chooses the family:

``sticks``
    The pilot's sticks (PX4 ``manual_control_setpoint`` / ``input_rc``, MAVLink
    ``RC_CHANNELS``/``MANUAL_CONTROL``, ROS ``/mavros/rc/in`` …) as ``u_roll u_pitch u_yaw``
    (+ ``u_thrust``).
``torque``
    The rate controller's outputs: PX4 ``actuator_controls_0.control[0..3]`` or
    ``vehicle_torque_setpoint`` / ``vehicle_thrust_setpoint``, ArduPilot DataFlash
    ``RATE.ROut/POut/YOut`` (+ ``RATE.AOut``), as ``u_roll u_pitch u_yaw`` (+ ``u_thrust``).
``setpoints``
    Rate setpoints ``sp_p sp_q sp_r`` (PX4 ``vehicle_rates_setpoint``, MAVLink
    ``ATTITUDE_TARGET`` body rates, DataFlash ``RATE.RDes…``).
``attitude``
    Attitude setpoints ``sp_roll sp_pitch sp_yaw`` (PX4 ``vehicle_attitude_setpoint``,
    DataFlash ``ATT.DesRoll…``, MAVLink/MAVROS ``ATTITUDE_TARGET`` quaternions) with the
    thrust setpoint as ``u_thrust``: the commands to the attitude loops.
``motors``
    Motor outputs ``m1 … mN`` (PX4 ``actuator_motors`` / ``actuator_outputs``, DataFlash
    ``RCOU``, MAVLink ``SERVO_OUTPUT_RAW``, MAVROS ``rc/out``), at least four. With a known
    motor layout the model's regressors are the commands they carry
    (:mod:`etsid.ident.motors`), else the raw outputs.
``auto`` (default), in this order:
    1. sticks when they carry excitation — on each of roll, pitch and yaw the stick signal
       has a standard deviation of at least :data:`STICK_STD_MIN` (normalised units) and a
       native rate of at least :data:`STICK_RATE_MIN` Hz;
    2. the first of torque commands, rate setpoints, attitude setpoints whose native rate
       is at least :data:`INPUT_RATE_MIN` Hz;
    3. the fastest of them;
    4. sticks anyway (with a note);
    5. motor outputs, when nothing else exists;
    6. else a one-line refusal.

The choice is made on the reader's candidate signals (:class:`etsid.ingest.base.Signal`),
ranked within each family by ingest's own order (:func:`etsid.ingest.mapping.signal_rank`),
and the chosen signals are handed to ingest's single mapping pass as ``preset`` columns
(:func:`etsid.ingest.table_from_raw`); user ``--map`` options win.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError
from etsid.ident.choices import MODES as MODES
from etsid.ident.choices import STICK_RATE_MIN as STICK_RATE_MIN
from etsid.ident.choices import STICK_STD_MIN as STICK_STD_MIN
from etsid.table import is_table_path

if TYPE_CHECKING:  # ingest is imported only when a log is read (ident → ingest stays thin)
    from etsid.ingest import ReadOptions
    from etsid.ingest.base import Signal

INPUT_RATE_MIN = 20.0
"""Least native rate, Hz, of a controller family (torque commands, rate or attitude
setpoints) for ``auto`` to take it in its turn: a 10 Hz command held over five 50 Hz
identification samples describes the rate loop poorly. When no family passes, ``auto``
takes the fastest one and says so."""

AXES = ("u_roll", "u_pitch", "u_yaw")
LOOP = (*AXES, "u_thrust")
SETPOINTS = ("sp_p", "sp_q", "sp_r")
ATTITUDE = ("sp_roll", "sp_pitch", "sp_yaw")
MOTORS = tuple(f"m{i}" for i in range(1, 9))
MIN_MOTORS = 4
"""Fewest motor outputs (m1 … m4) for the motor family."""

TORQUE_TOPICS = frozenset({
    "actuator_controls_0", "actuator_controls", "vehicle_torque_setpoint",
    "vehicle_thrust_setpoint", "RATE", "CTUN", "/mavros/target_actuator_control",
    "/fmu/out/vehicle_torque_setpoint", "/fmu/out/vehicle_thrust_setpoint",
    "/fmu/out/actuator_controls_0",
})
"""Topics / messages whose ``u_*`` signals are controller torque or thrust commands."""


def kind_of(source: str | None) -> str:
    """``torque`` when ``source`` (``TOPIC.FIELD``) is a controller command, ``sticks`` for
    any other ``u_*`` source, ``unknown`` without a source.

    >>> kind_of("actuator_controls_0.control[0]"), kind_of("manual_control_setpoint.y")
    ('torque', 'sticks')
    """
    if not source:
        return "unknown"
    topic = source.partition(".")[0]  # topic names hold no dot (etsid.ingest.base)
    if topic in TORQUE_TOPICS or "torque" in topic or "actuator_control" in topic:
        return "torque"
    if any(key in topic for key in ("rates_setpoint", "attitude_setpoint", "setpoint_attitude",
                                    "setpoint_raw", "ATTITUDE_TARGET")):
        return "setpoint"
    return "sticks"


def excitation(signals: dict[str, Signal]) -> dict[str, dict[str, float]]:
    """Per stick axis: ``std`` (normalised units) and native ``rate_hz`` of the signal."""
    out: dict[str, dict[str, float]] = {}
    for column in AXES:
        sig = signals.get(column)
        if sig is None:
            continue
        values = np.asarray(sig.values, dtype=float)
        values = values[np.isfinite(values)]
        out[column] = {"std": float(np.std(values)) if values.size else 0.0,
                       "rate_hz": float(sig.rate_hz)}
    return out


def excited(stats: dict[str, dict[str, float]]) -> bool:
    """The ``auto`` test: every roll/pitch/yaw stick has std ≥ :data:`STICK_STD_MIN`
    and rate ≥ :data:`STICK_RATE_MIN`."""
    return all(column in stats and stats[column]["std"] >= STICK_STD_MIN
               and stats[column]["rate_hz"] >= STICK_RATE_MIN for column in AXES)


@dataclass
class InputChoice:
    """The chosen input family, its signals and why.

    Attributes
    ----------
    mode
        What was asked (one of :data:`MODES`).
    kind
        What is used: ``sticks``, ``torque``, ``setpoints``, ``attitude`` or ``motors``.
    columns
        Model input columns (``u_roll …`` or ``sp_p …``).
    sources
        Column → ``TOPIC.FIELD`` of the signal behind it.
    reason
        One line: why this family.
    sticks
        The stick excitation test's numbers per axis (std, rate_hz).
    signals
        Column → the chosen :class:`~etsid.ingest.base.Signal` (handed to ingest as
        ``preset``; not part of :meth:`to_dict`).
    """

    mode: str
    kind: str
    columns: list[str]
    sources: dict[str, str] = field(default_factory=dict)
    reason: str = ""
    sticks: dict[str, dict[str, float]] = field(default_factory=dict)
    signals: dict[str, Signal] = field(default_factory=dict, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (stored in ``table.attrs["input_selection"]`` and config.json)."""
        return {f.name: copy.deepcopy(getattr(self, f.name)) for f in fields(self)
                if f.name != "signals"}


def _best(signals: list[Signal], columns: tuple[str, ...]) -> dict[str, Signal]:
    """The best signal per column of ``columns`` by ingest's own order."""
    from etsid.ingest.mapping import signal_rank

    best: dict[str, Signal] = {}
    for sig in signals:
        if sig.column in columns and sig.t.size and (
                sig.column not in best or signal_rank(sig) < signal_rank(best[sig.column])):
            best[sig.column] = sig
    return best


def _describe(stats: dict[str, dict[str, float]]) -> str:
    return ", ".join(f"{c} std {v['std']:.3g} at {v['rate_hz']:.3g} Hz"
                     for c, v in stats.items()) or "no sticks"


def choose_inputs(signals: list[Signal], mode: str = "auto",
                  path: str | Path = "log") -> InputChoice:
    """Choose the input family among a log's candidate signals (module docstring).

    Parameters
    ----------
    signals
        :attr:`etsid.ingest.base.RawLog.signals`.
    mode
        One of :data:`MODES`.
    path
        For messages.

    Raises
    ------
    IdentError
        Unknown mode, or the requested family is not in the log.
    """
    if mode not in MODES:
        raise IdentError(f"--inputs {mode!r}: choose one of {', '.join(MODES)}")
    path = Path(path)
    loop = [s for s in signals if s.column in LOOP]
    sticks = _best([s for s in loop if kind_of(s.source) == "sticks"], LOOP)
    torque = _best([s for s in loop if kind_of(s.source) == "torque"], LOOP)
    setpoints = _best(signals, SETPOINTS)
    attitude = _best(signals, ATTITUDE)
    motors = _best(signals, MOTORS)
    n_motors = next((i for i, c in enumerate(MOTORS) if c not in motors), len(MOTORS))
    thrust_sp = _best([s for s in loop if kind_of(s.source) == "setpoint"], ("u_thrust",))
    if attitude:
        attitude.update(thrust_sp or {k: v for k, v in _best(loop, ("u_thrust",)).items()})
    stats = excitation(sticks)
    has = {"sticks": all(c in sticks for c in AXES), "torque": all(c in torque for c in AXES),
           "setpoints": all(c in setpoints for c in SETPOINTS),
           "attitude": all(c in attitude for c in ATTITUDE),
           "motors": n_motors >= MIN_MOTORS}
    picked = {"sticks": sticks, "torque": torque, "setpoints": setpoints,
              "attitude": attitude, "motors": motors}
    order = {"sticks": LOOP, "torque": LOOP, "setpoints": SETPOINTS,
             "attitude": (*ATTITUDE, "u_thrust"), "motors": MOTORS[:n_motors]}

    def rate(kind: str) -> float:
        return min(picked[kind][c].rate_hz for c in order[kind][:3 if kind != "motors"
                                                               else n_motors])

    def make(kind: str, reason: str) -> InputChoice:
        chosen = picked[kind]
        columns = [c for c in order[kind] if c in chosen]
        return InputChoice(mode, kind, columns, {c: chosen[c].source for c in columns},
                           reason, stats, {c: chosen[c] for c in columns})

    if mode != "auto":
        if not has[mode]:
            found = ", ".join(k for k, v in has.items() if v) or "none"
            what = (f"at least {MIN_MOTORS} motor outputs (m1…m{MIN_MOTORS})"
                    if mode == "motors" else f"{mode} for all three axes")
            raise IdentError(f"{path}: --inputs {mode}: the log has no {what} "
                             f"(families found: {found})")
        return make(mode, f"--inputs {mode}")
    if has["sticks"] and excited(stats):
        return make("sticks", f"sticks carry excitation ({_describe(stats)})")
    why = (f"sticks without excitation ({_describe(stats)}; need std ≥ {STICK_STD_MIN} "
           f"and rate ≥ {STICK_RATE_MIN:g} Hz on each axis)" if has["sticks"] else "no sticks")
    names = {"torque": "torque commands", "setpoints": "rate setpoints",
             "attitude": "attitude setpoints"}
    slow = []
    for kind in ("torque", "setpoints", "attitude"):
        if has[kind]:
            if rate(kind) >= INPUT_RATE_MIN:
                skipped = f"; slower: {', '.join(slow)}" if slow else ""
                return make(kind, f"{why}: {names[kind]} at {rate(kind):.3g} Hz{skipped}")
            slow.append(f"{names[kind]} {rate(kind):.3g} Hz")
    if slow:
        kind = max((k for k in ("torque", "setpoints", "attitude") if has[k]), key=rate)
        return make(kind, f"{why}; every controller command is below {INPUT_RATE_MIN:g} Hz "
                          f"({', '.join(slow)}): the fastest, {names[kind]}")
    if has["sticks"]:
        return make("sticks", f"{why}, no torque commands or setpoints: sticks anyway")
    if has["motors"]:
        return make("motors", f"{why}, no torque commands or setpoints: {n_motors} motor "
                              f"outputs at {rate('motors'):.3g} Hz")
    raise IdentError(f"{path}: no inputs for the rate model: no sticks, torque commands, "
                     f"rate or attitude setpoints on all three axes, nor {MIN_MOTORS} motor "
                     "outputs (use --map or --regressors)")


def load_for_ident(path: str | Path, options: ReadOptions | None = None, inputs: str = "auto",
                   rate_hz: float | None = None) -> pd.DataFrame:
    """A log or saved table as a FlightTable whose ``u_*`` columns are the chosen inputs.

    For a log, :func:`choose_inputs` runs on the reader's signals; the chosen signals go to
    ingest's one mapping pass and alignment as preset columns (the user's own ``--map``
    wins). The choice is stored in ``attrs["input_selection"]``. A saved table is returned
    as is (:func:`etsid.ident.defaults.default_model` applies ``inputs`` to its columns).

    Raises
    ------
    IdentError
        Unknown mode or missing family.
    IngestError
        The log cannot be read.
    """
    from etsid.ingest import ReadOptions, read_log, read_raw, table_from_raw

    options = options or ReadOptions()
    if is_table_path(path):
        return read_log(path, options, rate_hz=rate_hz)
    if inputs not in MODES:
        raise IdentError(f"--inputs {inputs!r}: choose one of {', '.join(MODES)}")
    raw = read_raw(path, options)
    user = {o.column for o in options.overrides}
    try:
        choice = choose_inputs(raw.signals, inputs, raw.path)
    except IdentError:
        if user & set(LOOP) or not raw.signals:
            choice = None  # the user mapped the inputs, or ingest reports the problem
        else:
            raise
    preset = {c: sig for c, sig in (choice.signals if choice else {}).items()
              if c not in user}
    table = table_from_raw(raw, options.overrides, rate_hz=rate_hz, preset=preset)
    if choice is not None:
        mapping = table.attrs.get("mapping") or {}
        for column in choice.columns:
            if column in user and column in mapping:
                choice.sources[column] = str(mapping[column])
                choice.reason += f"; {column} from --map"
        table.attrs["input_selection"] = choice.to_dict()
    return table
