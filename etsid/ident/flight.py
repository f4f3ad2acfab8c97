"""Which samples are in flight, and which of them carry excitation (``--segments``).

Real logs hold time on the ground before take-off and after landing; a model of the
airborne rate dynamics must neither learn nor be judged there. ``--segments``:

``auto`` (default)
    Airborne samples only. The autopilot's own land detector where the table has it
    (column ``landed``: PX4 ``vehicle_land_detected.landed``, MAVLink
    ``EXTENDED_SYS_STATE.landed_state``, MAVROS ``extended_state``, ArduPilot ``EV``
    land-complete events): airborne where ``landed`` < 0.5; rows where the detector has no
    value yet are not airborne. A detector declares *landed* some time after touch-down
    and *airborne* when the throttle rises, before lift-off: where the table has the
    detector's earlier stages (column ``ground_contact``: PX4 ``ground_contact`` /
    ``maybe_landed``) those rows are on the ground too; without them
    :data:`LAND_MARGIN_S` is cut at each take-off and landing edge (:func:`trim_edges`).
    When ``landed`` is only an *armed state* (MAVLink
    ``HEARTBEAT.base_mode``, MAVROS ``state.armed``, DataFlash ``ARM`` or ``EV``
    armed/disarmed events: see :func:`is_armed_state`), a disarmed vehicle is on the ground
    but an armed one may still sit on it, so airborne = armed **and** a rule
    (:func:`armed_airborne`; a log that starts already flying — armed from its first
    sample, at hover thrust, moving — has no ground level and uses the thrust rule).
    Without either, the rule of :func:`airborne_rule` on the thrust command, the altitude
    and the vertical speed. Without any of them every row counts. A land detector that
    never says *airborne* in the whole log is not trusted either (a log cut after the
    take-off, or an autopilot generation whose detector is not run in every flight mode:
    ArduCopter 3.1–3.2 in its manual-throttle modes): the rule decides, and the method
    says so.
``all``
    Every row (the table's own segments).
``T0:T1[,T0:T1…]``
    Only these time windows, s (table time).

Airborne stretches shorter than :data:`MIN_AIR_S` are dropped and ground blips shorter
than :data:`GROUND_BLIP_S` inside a flight are filled. Every kept stretch is its own
``segment``: no regressor reaches across two of them.

**Excitation** (rate model only): a sample is *excited* when, over the
:data:`EXCITE_WINDOW_S` window centred on it, the standard deviation of at least one body
rate (p, q or r) is at least :data:`EXCITE_STD` rad/s. Still hover (rates at sensor-noise
and vibration level, a few mrad/s) is not excited. The validation part is placed inside
excited, airborne data (:func:`etsid.ident.checks.split_excited`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError
from etsid.ident.bare import bare
from etsid.table import SEGMENT

LANDED = "landed"
"""FlightTable column of the autopilot's land detector (1 on the ground, 0 airborne)."""

THRUST_AIR = 0.2
"""Rule: least collective thrust command (0…1) of an airborne sample. Multirotors hover
at 0.3–0.7; on the ground, armed or not, the command sits near 0."""

ALT_AIR_M = 0.5
"""Rule without thrust: least height above the log's ground level (the 2nd percentile of
``alt``), m, of an airborne sample."""

VZ_AIR = 0.3
"""Rule without thrust: a vertical speed of at least this, m/s, also counts as airborne
(the climb of a take-off before it reaches :data:`ALT_AIR_M`)."""

GROUND_CONTACT = "ground_contact"
"""FlightTable column of the land detector's touch-down stages (1 ground contact or maybe
landed)."""

LAND_MARGIN_S = 1.0
"""Seconds cut at each take-off and landing edge of a land detector's airborne stretch when
the table has no ``ground_contact`` column. A detector declares *landed* only after its
conditions have held for a trigger time (ArduPilot ``LAND_DETECTOR_TRIGGER_SEC`` = 1 s;
PX4 passes ground contact → maybe landed → landed: 2.1 s from the first ground contact to
``landed`` on the real coaxial-octocopter log) and *airborne* as soon as the throttle
rises, while the vehicle still sits on its legs (2.8 s of ground contact at that log's
take-off). One second is the shorter, documented of these trigger times."""

MIN_AIR_S = 2.0
"""Airborne stretches shorter than this, s, are dropped (a hop, a detector blip)."""

GROUND_BLIP_S = 0.5
"""Ground stretches shorter than this, s, between two airborne ones are filled."""

EXCITE_WINDOW_S = 1.0
"""Window of the excitation test, s."""

EXCITE_STD = 0.05
"""Least standard deviation of one body rate over the window for a sample to be excited,
rad/s (≈ 3 °/s; gyro noise and vibration in still hover are 0.002–0.02 rad/s)."""

START_WINDOW_S = 1.0
"""Window at the start of an armed stretch that tells a ground level from a flight already
under way (:func:`starts_flying`), s."""

STILL_RATE_STD = 0.01
"""Standard deviation of a body rate, rad/s, below which a vehicle at hover thrust is
standing still on its legs (:func:`starts_flying`): the real SITL quadplane armed at
mid-throttle on its wheels shows 0.001–0.004 rad/s, the sample flight in its 0.25 m hover
0.017–0.021 rad/s. A flight stiller than this keeps the arming-level rule (it may then lose
low hovers, as before)."""

ON_BACK_AZ = 4.9
"""Least body-z specific force, m/s² (FRD: upright hover reads −9.8), of a vehicle lying on
its back: rotor thrust only ever pulls along −z, and in a flip or a fall the reading stays
≤ 0, so a push from the top side (+z) of half a g is a contact force: the vehicle is on the
ground upside down (:func:`upset_rows`)."""

ON_BACK_HOLD_S = 1.0
"""Seconds the on-its-back reading must hold (a bump in flight lasts far less)."""

UPSET_LOOKBACK_S = 3.0
"""Seconds before the vehicle comes to rest on its back that count as the upset (the loss of
control, the tumble and the fall; 2.5 s on the real ArduCopter flip flight), s."""

ARMED_STATE_SOURCES = ("HEARTBEAT.base_mode", "ARM.ArmState", "EV.Id (armed)", ".armed")
"""``attrs["mapping"]["landed"]`` ending in one of these: the column is an armed state
(1 disarmed, 0 armed), not a land detector."""

SEGMENT_MODES = ("auto", "all")

_WINDOW = re.compile(r"^\s*(-?[0-9.]+)\s*:\s*(-?[0-9.]+)\s*$")


@dataclass
class FlightSelection:
    """The rows kept for identification and why.

    Attributes
    ----------
    mode
        ``auto``, ``all`` or the windows as given.
    method
        ``land detector + ground contact``, ``land detector, 1 s margins``,
        ``armed state + …``, ``rule (thrust)``, ``rule (altitude, vertical speed)``,
        ``none (no detector, thrust or altitude: every row)``, ``all`` or ``windows``.
    keep
        Boolean mask over the table's rows.
    windows
        ``[t0, t1]`` of every kept stretch, s.
    total_s, airborne_s
        Seconds of the whole table and of the kept rows.
    """

    mode: str
    method: str
    keep: np.ndarray
    windows: list[list[float]] = field(default_factory=list)
    total_s: float = 0.0
    airborne_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (metrics.json ``flight``)."""
        return {"mode": self.mode, "method": self.method, "total_s": self.total_s,
                "airborne_s": self.airborne_s, "windows": self.windows}


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of every run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _duration(t: np.ndarray, a: int, b: int, dt: float) -> float:
    return float(t[b - 1] - t[a] + dt)


def clean_mask(mask: np.ndarray, t: np.ndarray, min_air_s: float = MIN_AIR_S,
               blip_s: float = GROUND_BLIP_S) -> np.ndarray:
    """``mask`` with ground blips shorter than ``blip_s`` filled and airborne stretches
    shorter than ``min_air_s`` removed (s)."""
    mask = np.asarray(mask, dtype=bool).copy()
    if mask.size < 2:
        return mask
    dt = float(np.median(np.diff(t)))
    ground = _runs(~mask)
    for a, b in ground:
        if a > 0 and b < mask.size and _duration(t, a, b, dt) < blip_s:
            mask[a:b] = True
    for a, b in _runs(mask):
        if _duration(t, a, b, dt) < min_air_s:
            mask[a:b] = False
    return mask


def trim_edges(mask: np.ndarray, t: np.ndarray, margin_s: float = LAND_MARGIN_S
               ) -> np.ndarray:
    """``mask`` without the first and last ``margin_s`` seconds of every True run that
    borders a False row (the log's own start and end are not take-offs or landings)."""
    out = np.asarray(mask, dtype=bool).copy()
    n = out.size
    for a, b in _runs(out):
        if a > 0:
            out[a:b] &= t[a:b] >= t[a] + margin_s
        if b < n:
            out[a:b] &= t[a:b] <= t[b - 1] - margin_s
    return out


def _detector_airborne(table: pd.DataFrame, landed: np.ndarray, t: np.ndarray
                       ) -> tuple[np.ndarray, str]:
    """Airborne rows by a land detector (ground blips filled) without its touch-down
    stages or margins (module docstring); short stretches are not dropped yet."""
    with np.errstate(invalid="ignore"):
        keep = clean_mask(np.nan_to_num(landed, nan=1.0) < 0.5, t, min_air_s=0.0)
    contact = _column(table, GROUND_CONTACT)
    if contact is not None:
        with np.errstate(invalid="ignore"):
            return (keep & (np.nan_to_num(contact, nan=0.0) < 0.5),
                    "land detector + ground contact")
    return trim_edges(keep, t), f"land detector, {LAND_MARGIN_S:g} s margins"


def _column(table: pd.DataFrame, name: str) -> np.ndarray | None:
    if name not in table.columns:
        return None
    column = bare(table)[name]
    return column.to_numpy(dtype=float) if column.notna().any() else None


def is_armed_state(table: pd.DataFrame) -> bool:
    """Whether the table's ``landed`` column comes from an armed state (see
    :data:`ARMED_STATE_SOURCES`) rather than a land detector."""
    source = str((table.attrs.get("mapping") or {}).get(LANDED, ""))
    return source.endswith(ARMED_STATE_SOURCES)


def armed_airborne(table: pd.DataFrame, armed: np.ndarray) -> tuple[np.ndarray, str]:
    """Airborne rows when ``landed`` is only an armed state (``armed`` = its rows < 0.5).

    In each armed stretch: where ``alt`` rises at least :data:`ALT_AIR_M` above its level
    at the start of the stretch (median over its first second; a vehicle arms on the
    ground), airborne = that height test or ``|vz|`` ≥ :data:`VZ_AIR` (an armed vehicle
    may sit on the ground at mid-throttle: a plane's or an altitude-hold throttle stick).
    A stretch without such a climb (no altitude) uses :func:`airborne_rule` (thrust first),
    and so does a stretch whose start is not a ground level (:func:`starts_flying`: the log
    begins already armed, at hover thrust and moving — its low hover is not the ground).
    Disarmed rows are never airborne.
    """
    t = np.asarray(table.index, dtype=float)
    rule, how = airborne_rule(table)
    alt, vz = _column(table, "alt"), _column(table, "vz")
    out = np.zeros(len(t), dtype=bool)
    used = set()
    for a, b in _runs(armed):
        air = rule[a:b]
        if how == "rule (thrust)" and starts_flying(table, armed, a):
            used.add("rule (thrust): log starts flying")
        elif alt is not None:
            first = alt[a:b][t[a:b] <= t[a] + 1.0]
            ref = np.nanmedian(first) if np.isfinite(first).any() else np.nan
            with np.errstate(invalid="ignore"):
                high = np.nan_to_num(alt[a:b] - ref, nan=0.0) >= ALT_AIR_M
            if high.any():
                air = high
                if vz is not None:
                    air = air | (np.abs(np.nan_to_num(vz[a:b], nan=0.0)) >= VZ_AIR)
                used.add("altitude above arming level")
            else:
                used.add(how)
        else:
            used.add(how)
        out[a:b] = air
    return out, "armed state + " + (" / ".join(sorted(used)) or how)


def starts_flying(table: pd.DataFrame, armed: np.ndarray, start: int) -> bool:
    """Whether the armed stretch beginning at row ``start`` begins in flight, so that its
    first second is no ground level.

    True when all of these hold over the stretch's first second (:data:`START_WINDOW_S`):

    * the arming is not in the log: no disarmed row precedes the stretch (rows before the
      first armed-state message, NaN, do not count);
    * the collective thrust command is at least :data:`THRUST_AIR` (median) — hover
      thrust, not an idling spool-up;
    * the vehicle moves: the standard deviation of at least one body rate (p, q, r) is at
      least :data:`STILL_RATE_STD` (a vehicle standing on its legs is still);
    * no ground contact: the ``ground_contact`` column, where the table has one, is 0.

    A vehicle that arms on the ground, or sits armed at mid-throttle and still, keeps the
    arming-level rule of :func:`armed_airborne`.
    """
    landed = _column(table, LANDED)
    if landed is not None and np.any(landed[:start] >= 0.5):
        return False
    t = np.asarray(table.index, dtype=float)
    first = slice(start, start + int(np.searchsorted(t[start:], t[start] + START_WINDOW_S,
                                                     side="right")))
    if not armed[first].all():
        return False
    thrust = _column(table, "u_thrust")
    if thrust is None or not np.isfinite(thrust[first]).any() \
            or np.nanmedian(thrust[first]) < THRUST_AIR:
        return False
    rates = [_column(table, c) for c in ("p", "q", "r")]
    moving = any(r is not None and np.isfinite(r[first]).sum() > 2
                 and np.nanstd(r[first]) >= STILL_RATE_STD for r in rates)
    contact = _column(table, GROUND_CONTACT)
    touching = contact is not None and bool(np.any(np.nan_to_num(contact[first]) >= 0.5))
    return moving and not touching


def airborne_rule(table: pd.DataFrame) -> tuple[np.ndarray, str]:
    """Airborne rows without a land detector.

    With a thrust command ``u_thrust``: airborne where it is ≥ :data:`THRUST_AIR`. Without
    one: where ``alt`` is ≥ :data:`ALT_AIR_M` above the ground level (2nd percentile of
    ``alt``) or ``|vz|`` ≥ :data:`VZ_AIR`. With neither: every row.
    """
    n = len(table)
    thrust = _column(table, "u_thrust")
    if thrust is not None:
        with np.errstate(invalid="ignore"):
            return np.nan_to_num(thrust, nan=0.0) >= THRUST_AIR, "rule (thrust)"
    alt = _column(table, "alt")
    vz = _column(table, "vz")
    if alt is None and vz is None:
        return np.ones(n, dtype=bool), "none (no detector, thrust or altitude: every row)"
    air = np.zeros(n, dtype=bool)
    if alt is not None:
        ground = np.nanpercentile(alt, 2)
        air |= np.nan_to_num(alt - ground, nan=0.0) >= ALT_AIR_M
    if vz is not None:
        air |= np.abs(np.nan_to_num(vz, nan=0.0)) >= VZ_AIR
    return air, "rule (altitude, vertical speed)"


def upset_rows(table: pd.DataFrame) -> tuple[np.ndarray, float | None]:
    """Rows of an upset: from :data:`UPSET_LOOKBACK_S` before the first time the vehicle
    rests on its back (``az`` ≥ :data:`ON_BACK_AZ` for :data:`ON_BACK_HOLD_S`) to the end of
    that stretch; the time it came to rest (None: no upset, or no ``az``)."""
    t = np.asarray(table.index, dtype=float)
    out = np.zeros(len(t), dtype=bool)
    az = _column(table, "az")
    if az is None or len(t) < 2:
        return out, None
    dt = float(np.median(np.diff(t)))
    with np.errstate(invalid="ignore"):
        back = np.nan_to_num(az, nan=0.0) >= ON_BACK_AZ
    for a, b in _runs(back):
        if _duration(t, a, b, dt) >= ON_BACK_HOLD_S:
            out[(t >= t[a] - UPSET_LOOKBACK_S) & (t <= t[b - 1])] = True
            return out, float(t[a])
    return out, None


def parse_windows(text: str) -> list[tuple[float, float]]:
    """``"T0:T1,T0:T1"`` → windows, s.

    Raises
    ------
    IdentError
        Not ``auto``/``all`` and not a list of ``T0:T1`` with T0 < T1.
    """
    out = []
    for part in text.split(","):
        match = _WINDOW.match(part)
        if match is None:
            raise IdentError(f"--segments {text!r}: write auto, all or T0:T1[,T0:T1…] "
                             "(seconds), e.g. 12.5:40,55:80")
        t0, t1 = float(match[1]), float(match[2])
        if not t1 > t0:
            raise IdentError(f"--segments {part.strip()!r}: the end must be after the start")
        out.append((t0, t1))
    return out


def select_flight(table: pd.DataFrame, mode: str = "auto") -> FlightSelection:
    """The rows to identify on (module docstring).

    Raises
    ------
    IdentError
        Bad ``mode``, or no row left.
    """
    t = np.asarray(table.index, dtype=float)
    n = len(t)
    total = float(t[-1] - t[0]) if n > 1 else 0.0
    if mode == "all":
        keep, method = np.ones(n, dtype=bool), "all"
    elif mode == "auto":
        landed = _column(table, LANDED)
        if landed is not None and not is_armed_state(table):
            raw_air, method = _detector_airborne(table, landed, t)
            if not raw_air.any():  # a detector that never says airborne (module docstring)
                source = (table.attrs.get("mapping") or {}).get(LANDED, LANDED)
                raw_air, how = airborne_rule(table)
                method = f"{how}; the land detector ({source}) never says airborne"
        elif landed is not None:
            with np.errstate(invalid="ignore"):
                raw_air, method = armed_airborne(table, np.nan_to_num(landed, nan=1.0) < 0.5)
        else:
            raw_air, method = airborne_rule(table)
        upset, rest_t = upset_rows(table)
        if rest_t is not None:
            raw_air = raw_air & ~upset
            method += f", upset cut (on its back from {rest_t:.1f} s)"
        # a detector's blips are filled before its touch-down stages are cut
        keep = clean_mask(raw_air, t, blip_s=0.0 if method.startswith("land detector")
                          else GROUND_BLIP_S)
    else:
        keep = np.zeros(n, dtype=bool)
        for t0, t1 in parse_windows(mode):
            keep |= (t >= t0) & (t <= t1)
        method = "windows"
    if not keep.any():
        what = "no sample inside the windows"
        if mode == "auto":
            dt0 = float(np.median(np.diff(t))) if n > 1 else 0.0
            longest = max((_duration(t, a, b, dt0) for a, b in _runs(raw_air)), default=0.0)
            what = (f"no airborne stretch of ≥ {MIN_AIR_S:g} s (longest {longest:.1f} s)"
                    if longest else "no airborne sample")
        raise IdentError(f"--segments {mode}: {what} ({method}, {total:.1f} s of log); "
                         "use --segments all or T0:T1 to choose the data yourself")
    dt = float(np.median(np.diff(t))) if n > 1 else 0.0
    runs = _runs(keep)
    windows = [[float(t[a]), float(t[b - 1])] for a, b in runs]
    air = float(sum(_duration(t, a, b, dt) for a, b in runs))
    return FlightSelection(mode, method, keep, windows, total, air)


def apply_selection(table: pd.DataFrame, selection: FlightSelection) -> pd.DataFrame:
    """The kept rows, each contiguous kept stretch (and each of the table's own segments
    inside it) numbered as its own ``segment``."""
    keep = selection.keep
    seg = (table[SEGMENT].to_numpy(dtype=np.int64) if SEGMENT in table.columns
           else np.zeros(len(table), dtype=np.int64))
    start = np.r_[True, (seg[1:] != seg[:-1]) | (keep[1:] & ~keep[:-1])]
    new_seg = np.cumsum(start & keep)
    out = table.loc[keep]  # (a new frame already: a boolean selection copies)
    out[SEGMENT] = new_seg[keep] - 1
    out.attrs = dict(table.attrs)
    return out


def excited_mask(table: pd.DataFrame, outputs: tuple[str, ...] = ("p", "q", "r"),
                 window_s: float = EXCITE_WINDOW_S, threshold: float = EXCITE_STD
                 ) -> np.ndarray:
    """Rows where the centred ``window_s`` standard deviation of at least one output is
    ≥ ``threshold`` (computed inside each segment)."""
    t = np.asarray(table.index, dtype=float)
    n = len(t)
    if n < 2:
        return np.zeros(n, dtype=bool)
    dt = float(np.median(np.diff(t)))
    width = max(3, round(window_s / dt) | 1)
    seg = (table[SEGMENT].to_numpy() if SEGMENT in table.columns else np.zeros(n))
    out = np.zeros(n, dtype=bool)
    frame = table[[c for c in outputs if c in table.columns]]
    for value in np.unique(seg):
        rows = seg == value
        std = frame.loc[rows].rolling(width, center=True, min_periods=3).std()
        out[rows] = (std >= threshold).any(axis=1).to_numpy()
    return out
