"""``run_gap``: the one entry point of the gap analysis (SIM log + REAL log → gap.json).

:func:`analyse` runs the stages in order, each a function named for what it decides:
:func:`prepare_pair` (same inputs, same grid), :func:`airborne_problem` (enough flight in
both?), :func:`nominal_and_floors` (the model fitted on SIM and each channel's floor),
:func:`restrict_to_envelope` (only what SIM flew), :func:`different_airframe` (one vehicle
for both?), then :func:`etsid.gap.likelihood.explain_by_likelihood`: the held-out
likelihood criterion on REAL's blocked folds names the effects, says what is left and
where (gap.json). The verdict rules live in :mod:`etsid.gap.verdict`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.blas import one_blas_thread
from etsid.errors import GapError
from etsid.gap.candidates import Context
from etsid.gap.fitting import Scorer
from etsid.gap.floors import channel_floors, own_error
from etsid.gap.likelihood import explain_by_likelihood
from etsid.gap.locate import scheduling_variables
from etsid.gap.loop import BandResponse, band_response
from etsid.gap.nominal import (
    ENVELOPE_FACTOR,
    MIN_VOLTAGE_COVER,
    UNITS,
    NominalModel,
    fit_nominal,
    measured,
    voltage_covered,
)
from etsid.gap.pem import prediction_error_scorer
from etsid.gap.plausible import condition
from etsid.gap.result import SCHEMA_NAME, write_gap_json
from etsid.gap.signals import (
    MIN_AIRBORNE_S,
    SETPOINT_KINDS,
    Flight,
    describe,
    excerpt,
    input_kinds,
    prepare,
)
from etsid.gap.validation import time_split
from etsid.gap.vehicle_check import check_vehicles, structural

SIM_FIT_SHARE = 0.7
FIT_SHARE = 0.6
CLIMB_MARGIN = 0.15
"""m/s: REAL is compared only within SIM's climb-rate range (× ENVELOPE_FACTOR) plus this;
the horizontal speed's limit is the nominal model's (:attr:`NominalModel.speed_limit`)."""


@dataclass
class GapResult:
    """Everything the gap analysis found (``data`` is gap.json)."""

    data: dict[str, Any]
    sim: Flight | None = None
    real: Flight | None = None
    nominal: NominalModel | None = None
    series: dict[str, Any] = field(default_factory=dict)

    @property
    def summary(self) -> str:
        """The one-paragraph summary printed on stdout."""
        return str(self.data["summary"])


@dataclass
class Floors:
    """The nominal model fitted on SIM and each channel's floor (:mod:`etsid.gap.floors`)."""

    nominal: NominalModel
    sigma: dict[str, float]
    source: dict[str, str]
    loop: BandResponse | None = None
    """SIM's band-by-band response (:mod:`etsid.gap.loop`)."""
    voltage_cover: float | None = None
    """Share of REAL's airborne pack voltage within SIM's span (:func:`voltage_covered`)."""
    own: dict[str, float] | None = None
    """Channel → SIM's own held-out error alone (:func:`etsid.gap.floors.own_error`)."""


def _rmse(res: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, float]:
    return {c: float(np.sqrt(np.mean(v[mask] ** 2))) for c, v in res.items()}


def _rotor_dirs(nominal: NominalModel, flight: Flight) -> np.ndarray | None:
    if flight.inputs != "motors":
        return None
    n = flight.motors.shape[1]
    gp, gq = nominal.coef["p"][:n], nominal.coef["q"][:n]
    gp, gq = gp - gp.mean(), gq - gq.mean()
    d = np.column_stack([gq / (np.sqrt(np.mean(gq**2)) + 1e-12),
                         -gp / (np.sqrt(np.mean(gp**2)) + 1e-12)])
    return d / (np.linalg.norm(d, axis=1, keepdims=True) + 1e-12)


def _vehicle_info(vehicle: Any, n_inputs: int) -> dict[str, Any]:
    from etsid.sim import load_vehicle

    v = load_vehicle(vehicle)
    m = v["motor"]
    info = {"k": m["omega_idle"] / (m["omega_max"] - m["omega_idle"]),
            "arm": float(v["frame"]["arm_length"]), "radius": float(v["rotor"]["radius"]),
            "dirs": None}
    if v.n_rotors == n_inputs:
        pos = v.rotor_positions[:, :2]
        info["dirs"] = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    return info


def _early(sim: Flight, real: Flight, verdict: str, reason: str, summary: str,
           extra: dict[str, Any] | None = None) -> GapResult:
    """A result decided before any model is compared (insufficient, different-vehicle)."""
    data = {"schema": SCHEMA_NAME, "verdict": verdict, "reason": reason, "summary": summary,
            "sim": describe(sim), "real": describe(real), "mismatch": None, "effects": [],
            "rmse_before": {}, "rmse_after": {}, "noise": {}, "units": dict(UNITS),
            "notes": [], **(extra or {})}
    return GapResult(data, sim, real)


def _insufficient(sim: Flight, real: Flight, reason: str) -> GapResult:
    return _early(sim, real, "insufficient", reason, f"Insufficient data: {reason}.")


def _different(sim: Flight, real: Flight, evidence: list[str],
               check: dict[str, Any] | None = None, twin: str | None = None) -> GapResult:
    reason = "; ".join(evidence) + (f"; {twin}" if twin else "")
    summary = (f"Different vehicle: {reason}. One airframe with a fault does not explain both "
               "logs, so no missing physics is named; compare a simulation of this airframe "
               "(its rotor count, mass, inertia and propulsion) with the recording.")
    extra = {"vehicle_check": check or {"evidence": evidence}}
    return _early(sim, real, "different-vehicle", reason, summary, extra)


def prepare_pair(sim_table: pd.DataFrame, real_table: pd.DataFrame, sim_name: str,
                 real_name: str) -> tuple[Flight, Flight]:
    """Both flights on the analysis grid with the same kind of inputs: motor outputs where
    both logs have them, else the loop commands where both have those."""
    common = [k for k in input_kinds(sim_table) if k in input_kinds(real_table)]
    kind = common[0] if common else None
    sim = prepare(sim_table, sim_name, kind)
    real = prepare(real_table, real_name, kind)
    if sim.inputs != real.inputs:
        raise GapError(f"{real_name}: its inputs ({real.inputs}) cannot be compared with "
                       f"{sim_name}'s ({sim.inputs}): one log needs motor outputs m1..mN or "
                       "the loop commands u_thrust/u_roll/u_pitch/u_yaw the other has")
    return sim, real


def airborne_problem(sim: Flight, real: Flight) -> str | None:
    """Why the flights cannot support a verdict (too little airborne time), in words that
    say what happened: a simulation that barely flies while the recording does is a twin
    that crashed or never took off."""
    if sim.airborne_s < MIN_AIRBORNE_S <= real.airborne_s:
        flying = np.flatnonzero(sim.airborne)
        when = (f"it is airborne only {sim.airborne_s:.1f} s (last at {sim.t[flying[-1]]:.1f} s)"
                if flying.size else "it never leaves the ground")
        alt = sim.alt[np.isfinite(sim.alt)]
        top = f", highest {np.max(alt):.2f} m" if alt.size else ""
        return (f"{sim.name} does not fly the recording: {when}{top}, while {real.name} is "
                f"airborne {real.airborne_s:.1f} s (a replayed twin that crashed or never took "
                "off: check its vehicle and the replay's divergence report)")
    for f in (sim, real):
        if f.airborne_s < MIN_AIRBORNE_S:
            return (f"{f.name} has {f.airborne_s:.1f} s of airborne data; at least "
                    f"{MIN_AIRBORNE_S:.0f} s needed")
    return None


def twin_divergence(sim_table: pd.DataFrame, sim_name: str) -> str | None:
    """What the replay said of a twin that left its recording (``replay_divergence`` in the
    table's provenance), in words, or None."""
    div = sim_table.attrs.get("replay_divergence")
    if not isinstance(div, dict) or "t" not in div:
        return None
    return (f"{sim_name} is a replayed twin that leaves its recording at {div['t']:.1f} s "
            f"({div.get('what', '')})")


def nominal_and_floors(sim: Flight, real: Flight, k: float | None) -> Floors:
    """The nominal model on SIM, and each channel's floor: SIM's own held-out error or
    REAL's sensor noise, whichever is larger (:func:`etsid.gap.floors.channel_floors`)."""
    s_fit, s_hold = time_split(sim.airborne, SIM_FIT_SHARE)
    cover = voltage_covered(sim, real)
    nominal = fit_nominal(sim, k=k, voltage=cover is not None and cover >= MIN_VOLTAGE_COVER)
    probe = fit_nominal(sim, s_fit, law=(nominal.k, nominal.v_ref))
    own = own_error(sim, nominal, probe, s_hold,
                    [sim.airborne, *time_split(sim.airborne, FIT_SHARE)])
    sigma, source = channel_floors(own, real)
    return Floors(nominal, sigma, source, band_response(sim, nominal, measured(sim)), cover,
                  own)


def restrict_to_envelope(sim: Flight, real: Flight, nominal: NominalModel) -> str | None:
    """Drop REAL samples faster than SIM ever flew (``nominal.speed_limit``, and a climb rate
    with its own margin) from the evidence; the note saying how much, or None."""
    real_speed = np.hypot(real.v_body[:, 0], real.v_body[:, 1])
    limit = nominal.speed_limit
    climb = float(np.quantile(np.abs(sim.v_body[sim.airborne, 2]), 0.99)) * ENVELOPE_FACTOR \
        + CLIMB_MARGIN
    outside = real.airborne & ((real_speed > limit) | (np.abs(real.v_body[:, 2]) > climb))
    if not np.any(outside):
        return None
    real.airborne = real.airborne & ~outside
    return (f"{np.sum(outside) / real.fs:.1f} s of {real.name} faster than {limit:.1f} m/s "
            f"horizontally or {climb:.2f} m/s vertically (beyond what {sim.name} flew) not "
            "used as evidence")


def different_airframe(sim: Flight, real: Flight, nominal: NominalModel
                       ) -> tuple[list[str], dict[str, Any]]:
    """Evidence that the logs are of different airframes (:mod:`etsid.gap.vehicle_check`)."""
    check = check_vehicles(sim, real, nominal)
    return check.evidence, check.as_dict()

def analyse(sim_table: pd.DataFrame, real_table: pd.DataFrame, sim_name: str = "SIM",
            real_name: str = "REAL", vehicle: Any = None,
            progress: Callable[[str], None] | None = None) -> GapResult:
    """Compare a simulated and a recorded flight (FlightTables) and explain the gap.

    Parameters
    ----------
    sim_table, real_table : pandas.DataFrame
        FlightTables of the simulation and of the recording.
    sim_name, real_name : str
        Names used in messages.
    vehicle : str, Path or Vehicle, optional
        Vehicle description; sharpens the rotor-speed law and the ground-effect geometry.
    progress : callable, optional
        Called with one line as each stage starts (``etsid gap`` prints them on a terminal).

    Returns
    -------
    GapResult
        gap.json content plus the prepared flights and series for the report. The verdict
        is ``consistent``, ``mismatch``, ``insufficient`` or ``different-vehicle``.

    Raises
    ------
    GapError
        A log lacks the channels the analysis needs.
    """
    with one_blas_thread():
        return _analyse(sim_table, real_table, sim_name, real_name, vehicle, progress)


def _analyse(sim_table: pd.DataFrame, real_table: pd.DataFrame, sim_name: str,
             real_name: str, vehicle: Any, progress: Callable[[str], None] | None
             ) -> GapResult:
    """:func:`analyse` with BLAS on one thread (:mod:`etsid.blas`: the analysis' least
    squares and QR factorisations are skinny, and threads mostly wait for each other)."""
    say = progress or (lambda line: None)
    say(f"gap: preparing {sim_name} and {real_name} (same inputs, same grid)")
    sim, real = prepare_pair(sim_table, real_table, sim_name, real_name)
    sim, n_sim = excerpt(sim)  # bounded cost and memory for long logs
    real, n_real = excerpt(real)
    excerpts = [n for n in (n_sim, n_real) if n]
    conditioned = condition(sim, real)
    if sim.command_source:
        cols = ", ".join(SETPOINT_KINDS[sim.command_source])
        conditioned.insert(0, f"command: the {sim.command_source} ({cols}) of both logs, which "
                              "have neither motor outputs nor stick commands")
    rotor_count = structural(sim, real)
    if rotor_count:
        return _different(sim, real, [rotor_count])
    twin = twin_divergence(sim_table, sim_name)
    problem = airborne_problem(sim, real)
    if problem:
        return _insufficient(sim, real, problem + (f"; {twin}" if twin else ""))
    info = _vehicle_info(vehicle, sim.motors.shape[1]) if vehicle is not None else {}
    notes: list[str] = []
    say(f"gap: fitting the nominal model on {sim_name}; noise floors from both logs")
    floors = nominal_and_floors(sim, real, info.get("k"))
    nominal, sigma = floors.nominal, floors.sigma
    info["loop"] = floors.loop
    notes.extend(conditioned)
    yr = measured(real)
    shared = tuple(c for c in nominal.channels if c in yr)
    nominal.channels = shared
    lacking = [c for c in ("p", "q", "r", "az") if c not in shared]
    if lacking:
        raise GapError(f"{real_name}: lacks {', '.join(lacking)} for a verdict")
    missing = sorted(set(("ax", "ay", "gyro_p", "kin_z")) - set(shared))
    if missing:
        notes.append("not compared (a log lacks velocity, attitude or horizontal specific "
                     f"force): {', '.join(missing)}")
    raised = sorted(c for c in shared if floors.source.get(c) == "real noise")
    if raised:
        notes.append(f"floor set by {real_name}'s own sensor noise (larger than "
                     f"{sim_name}'s model error) on {', '.join(raised)}")
    if twin:
        notes.append(f"{twin}: differences after that are the twin's, not physics alone")
    if floors.voltage_cover is not None and floors.voltage_cover < MIN_VOLTAGE_COVER:
        notes.append(f"{real_name} flies {100 * (1 - floors.voltage_cover):.0f} % of its time at "
                     f"pack voltages {sim_name} never reached: rotor speed is taken from the "
                     "command alone, and a voltage effect is judged as a candidate")
    envelope = restrict_to_envelope(sim, real, floors.nominal)
    if envelope:
        notes.append(envelope)
        if real.airborne_s < MIN_AIRBORNE_S:
            return _insufficient(sim, real, f"{real_name} flies mostly outside the speed "
                                            f"range of {sim_name}" + (f"; {twin}" if twin
                                                                      else ""))
    say("gap: checking that one airframe can explain both logs")
    evidence, check = different_airframe(sim, real, nominal)
    if evidence:
        return _different(sim, real, evidence, check, twin)

    ctx = Context(real, nominal,
                  float(np.nanmean(sim.vbat[sim.airborne])) if "vbat" in sim.have else None,
                  info.get("dirs") if info.get("dirs") is not None else _rotor_dirs(nominal,
                                                                                    real),
                  info.get("arm"))
    scorer = Scorer(ctx, yr, sigma)
    notes.extend(excerpts)
    if floors.loop is not None and floors.loop.noise_driven:
        # SIM's loop answers noise its log does not hold: the direct fit is biased
        scorer = prediction_error_scorer(sim, scorer)  # roll and pitch: prediction errors
    base = {"schema": SCHEMA_NAME, "sim": describe(sim), "real": describe(real),
            "noise": sigma, "noise_source": {c: floors.source[c] for c in shared},
            "units": {c: UNITS[c] for c in shared}, "vehicle_check": check,
            "nominal": {"k": nominal.k, "tau": nominal.tau, "delay": nominal.delay,
                        "drag_law": nominal.drag_law, "speed_law": nominal.speed_law,
                        "channels": list(shared)}}
    data, series = explain_by_likelihood(sim, real, nominal, sigma, scorer, base, notes,
                                         info, say, own=floors.own)
    return GapResult(data, sim, real, nominal, series)


SERIES_FILE = "gap_series.parquet"


def series_frame(result: GapResult) -> pd.DataFrame:
    """REAL's channels on its analysis grid: measured, nominal and augmented prediction,
    the scheduling variables and the fit/held-out masks (for the report's figures)."""
    real, s = result.real, result.series
    if real is None or "res_before" not in s:
        return pd.DataFrame()
    cols: dict[str, np.ndarray] = {}
    meas = measured(real)
    after = s.get("res_after", s["res_before"])
    for c, r0 in s["res_before"].items():
        cols[f"{c}"] = meas[c]
        cols[f"{c}_nominal"] = meas[c] - r0
        cols[f"{c}_augmented"] = meas[c] - after[c]
    for name, v in scheduling_variables(real).items():
        cols[f"var_{name}"] = v
    cols["airborne"] = real.airborne
    cols["fit"] = s["fit"]
    cols["held_out"] = s["hold"]
    return pd.DataFrame(cols, index=pd.Index(real.t, name="t"))


def run_gap(sim_path: str | Path, real_path: str | Path, out_dir: str | Path | None = None,
            vehicle: str | Path | None = None, options: Any = None,
            progress: Callable[[str], None] | None = None) -> GapResult:
    """Read two logs (or saved tables), analyse them, write ``out_dir/gap.json``.

    ``options`` is an :class:`etsid.ingest.ReadOptions` for both logs (default: none).

    ``gap.json`` is validated against ``gap.schema.json`` before it is written; the series
    behind the figures go to ``out_dir/gap_series.parquet`` (``etsid report`` draws them).
    """
    from etsid.ingest import read_log

    sim_table = read_log(sim_path, options)
    real_table = read_log(real_path, options)
    result = analyse(sim_table, real_table, Path(sim_path).name, Path(real_path).name, vehicle,
                     progress)
    if out_dir is not None:
        write_gap_json(result.data, out_dir)
        frame = series_frame(result)
        if not frame.empty:
            frame.to_parquet(Path(out_dir) / SERIES_FILE)
    return result
