"""``run_gap``: the one entry point of the gap analysis (SIM log + REAL log → gap.json).

Steps: prepare both flights the same way; fit the nominal model on SIM and measure its own
held-out error there (the noise floor ``σ_c``); predict REAL and call a channel mismatched
when its error exceeds :data:`Z_MISMATCH` times SIM's (in mean square); locate where the
residual concentrates; fit the candidate library on the first :data:`FIT_SHARE` of REAL's
airborne time and keep what improves the later part (:mod:`etsid.gap.select`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import GapError
from etsid.gap.candidates import Context
from etsid.gap.fitting import Scorer
from etsid.gap.locate import ground_band, locate_channel, scheduling_variables, segments
from etsid.gap.nominal import (
    GYRO_CHANNELS,
    LABELS,
    UNITS,
    NominalModel,
    fit_nominal,
    measured,
)
from etsid.gap.result import SCHEMA_NAME, write_gap_json
from etsid.gap.select import MIN_SHARE, Scored, Selection, fit_unexplained, select
from etsid.gap.signals import MIN_AIRBORNE_S, Flight, describe, prepare
from etsid.gap.summary import effect_entry, summary_sentence

Z_MISMATCH = 4.0
"""A channel is mismatched when REAL's mean squared error is this many times SIM's
(RMSE twice SIM's own held-out error)."""
Z_SMALL = 2.5
MIN_SHARE_SMALL = 0.5
"""Small but structured mismatch: with no channel above :data:`Z_MISMATCH`, channels (not
the gyro ones) above ``Z_SMALL`` are explained only by an effect that removes
``MIN_SHARE_SMALL`` of their held-out excess (both chosen on the dev seeds, whose 20
no-effect pairs stay below z = 2 in every such channel)."""
CALM_QUANTILE = 1.0 / 3.0
"""The calm (busy) part of REAL: samples whose motor command rate is in the lowest
(highest) third."""
SIM_FIT_SHARE = 0.7
FIT_SHARE = 0.6
GYRO_FLOOR = 0.009
"""rad/s: the flight-to-flight difference of a calibrated MEMS gyro's bias (≈0.3 °/s =
0.005 rad/s per flight, two flights compared: 0.007 rad/s) is not evidence of missing
physics; 0.009 keeps the dev seeds' no-effect pairs below the threshold."""
SPEED_MARGIN = 0.5
CLIMB_MARGIN = 0.15
"""m/s: REAL is compared only within SIM's speed and climb-rate range plus these."""
MAX_HOVER_RATIO = 2.2
MAX_VOLTAGE_RATIO = 1.3
"""Mean airborne pack voltages further apart than this are different packs (cell counts:
4S/3S is 1.33), hence different vehicles; battery sag in the dev pairs stays below 1.2."""


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


def _split(mask: np.ndarray, share: float) -> tuple[np.ndarray, np.ndarray]:
    idx = np.flatnonzero(mask)
    cut = idx[int(share * idx.size)] if idx.size else 0
    before = mask & (np.arange(mask.size) < cut)
    return before, mask & ~before


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


def _insufficient(sim: Flight, real: Flight, reason: str) -> GapResult:
    data = {"schema": SCHEMA_NAME, "verdict": "insufficient", "reason": reason,
            "summary": f"Insufficient data: {reason}.", "sim": describe(sim),
            "real": describe(real), "mismatch": None, "effects": [], "rmse_before": {},
            "rmse_after": {}, "noise": {}, "units": dict(UNITS), "notes": []}
    return GapResult(data, sim, real)


def analyse(sim_table: pd.DataFrame, real_table: pd.DataFrame, sim_name: str = "SIM",
            real_name: str = "REAL", vehicle: Any = None) -> GapResult:
    """Compare a simulated and a recorded flight (FlightTables) and explain the gap.

    Parameters
    ----------
    sim_table, real_table : pandas.DataFrame
        FlightTables of the simulation and of the recording.
    sim_name, real_name : str
        Names used in messages.
    vehicle : str, Path or Vehicle, optional
        Vehicle description; sharpens the rotor-speed law and the ground-effect geometry.

    Returns
    -------
    GapResult
        gap.json content plus the prepared flights and series for the report.

    Raises
    ------
    GapError
        A log lacks the channels the analysis needs, or the two logs are plainly of
        different vehicles.
    """
    sim = prepare(sim_table, sim_name)
    real = prepare(real_table, real_name)
    if sim.inputs != real.inputs or sim.motors.shape[1] != real.motors.shape[1]:
        raise GapError(f"{real_name}: not the same vehicle type as {sim_name} "
                       f"({real.motors.shape[1]} {real.inputs} vs {sim.motors.shape[1]} "
                       f"{sim.inputs})")
    for f in (sim, real):
        if f.airborne_s < MIN_AIRBORNE_S:
            return _insufficient(sim, real, f"{f.name} has {f.airborne_s:.1f} s of airborne "
                                            f"data; at least {MIN_AIRBORNE_S:.0f} s needed")
    info = _vehicle_info(vehicle, sim.motors.shape[1]) if vehicle is not None else {}
    notes: list[str] = []

    # --- nominal model and SIM's own error --------------------------------------------
    s_fit, s_hold = _split(sim.airborne, SIM_FIT_SHARE)
    probe = fit_nominal(sim, s_fit, k=info.get("k"))
    ys = measured(sim)
    sigma = {c: r for c, r in _rmse({c: ys[c] - v for c, v in probe.predict(sim).items()},
                                    s_hold).items()}
    for c in GYRO_CHANNELS:
        if c in sigma:
            sigma[c] = max(sigma[c], GYRO_FLOOR)
    nominal = fit_nominal(sim, k=info.get("k"))
    yr = measured(real)
    shared = tuple(c for c in nominal.channels if c in yr)
    nominal.channels = shared
    lacking = [c for c in ("p", "q", "r", "az") if c not in shared]
    if lacking:
        raise GapError(f"{real_name}: lacks {', '.join(lacking)} for a verdict")
    missing = sorted(set(("ax", "ay", "gyro_p")) - set(shared))
    if missing:
        notes.append("not compared (a log lacks velocity, attitude or horizontal specific "
                     f"force): {', '.join(missing)}")

    # --- envelope: only where SIM's data support the nominal model --------------------
    sim_speed = np.hypot(sim.v_body[:, 0], sim.v_body[:, 1])[sim.airborne]
    real_speed = np.hypot(real.v_body[:, 0], real.v_body[:, 1])
    limit = float(np.quantile(sim_speed, 0.99)) * 1.2 + SPEED_MARGIN
    climb = float(np.quantile(np.abs(sim.v_body[sim.airborne, 2]), 0.99)) * 1.2 + CLIMB_MARGIN
    outside = real.airborne & ((real_speed > limit) | (np.abs(real.v_body[:, 2]) > climb))
    if np.any(outside):
        notes.append(f"{np.sum(outside) / real.fs:.1f} s of {real_name} faster than "
                     f"{limit:.1f} m/s horizontally or {climb:.2f} m/s vertically (beyond "
                     f"what {sim_name} flew) not used as evidence")
        real.airborne = real.airborne & ~outside
        if real.airborne_s < MIN_AIRBORNE_S:
            return _insufficient(sim, real, f"{real_name} flies mostly outside the speed "
                                            f"range of {sim_name}")

    # --- obviously different vehicles ---------------------------------------------------
    k = nominal.k
    hover_sim = float(np.median(np.mean((np.clip(sim.motors, 0, 1) + k) ** 2, axis=1)
                                [sim.airborne]))
    hover_real = float(np.median(np.mean((np.clip(real.motors, 0, 1) + k) ** 2, axis=1)
                                 [real.airborne]))
    ratio = hover_real / max(hover_sim, 1e-9)
    if not 1.0 / MAX_HOVER_RATIO < ratio < MAX_HOVER_RATIO:
        raise GapError(f"{real_name}: hover thrust command {ratio:.2f}× that of {sim_name}; "
                       "these look like different vehicles, not one vehicle with missing "
                       "physics")
    if "vbat" in sim.have and "vbat" in real.have:
        v_sim = float(np.nanmedian(sim.vbat[sim.airborne]))
        v_real = float(np.nanmedian(real.vbat[real.airborne]))
        v_ratio = v_real / max(v_sim, 1e-9)
        if not 1.0 / MAX_VOLTAGE_RATIO < v_ratio < MAX_VOLTAGE_RATIO:
            raise GapError(f"{real_name}: battery voltage {v_real:.1f} V against {v_sim:.1f} V "
                           f"in {sim_name} (different packs); these look like different "
                           "vehicles, not one vehicle with missing physics")
    # --- mismatch verdict on all airborne REAL -----------------------------------------
    ctx = Context(real, nominal,
                  float(np.nanmean(sim.vbat[sim.airborne])) if "vbat" in sim.have else None,
                  info.get("dirs") if info.get("dirs") is not None else _rotor_dirs(nominal,
                                                                                    real),
                  info.get("arm"))
    scorer = Scorer(ctx, yr, sigma)
    z_all = scorer.zscores(None, real.airborne)
    mis = [c for c, z in sorted(z_all.items(), key=lambda kv: -kv[1]) if z > Z_MISMATCH]
    small = not mis
    if small:
        mis = [c for c, z in sorted(z_all.items(), key=lambda kv: -kv[1])
               if z > Z_SMALL and c not in GYRO_CHANNELS]
    r_fit, r_hold = _split(real.airborne, FIT_SHARE)
    res0 = scorer.residuals()
    rmse_before = _rmse(res0, r_hold)
    base = {"schema": SCHEMA_NAME, "sim": describe(sim), "real": describe(real),
            "noise": sigma, "units": {c: UNITS[c] for c in shared},
            "nominal": {"k": k, "tau": nominal.tau, "delay": nominal.delay,
                        "channels": list(shared), "z_all": z_all},
            "rmse_before": rmse_before}
    series = {"res_before": res0, "fit": r_fit, "hold": r_hold, "z_all": z_all,
              "scorer": scorer}
    if not mis:
        data = {**base, "verdict": "consistent", "mismatch": None, "effects": [],
                "rmse_after": rmse_before, "notes": notes,
                "reason": f"every channel of {real_name} is within {np.sqrt(Z_MISMATCH):.0f}× "
                          f"the nominal model's error on {sim_name} itself"}
        data["summary"] = summary_sentence(data)
        return GapResult(data, sim, real, nominal, series)

    # --- explain -------------------------------------------------------------------------
    rate = scheduling_variables(real)["command_rate"]
    calm = r_hold & (rate <= np.quantile(rate[real.airborne], CALM_QUANTILE))
    busy = r_hold & (rate >= np.quantile(rate[real.airborne], 1.0 - CALM_QUANTILE))
    sel = select(scorer, r_fit, r_hold, tuple(mis),
                 min_share=MIN_SHARE_SMALL if small else MIN_SHARE, z_left=Z_MISMATCH,
                 activity=(calm, busy))
    if small and sel.chosen:
        notes.append(f"small but structured mismatch: {', '.join(mis)} between "
                     f"{np.sqrt(Z_SMALL):.1f}× and {np.sqrt(Z_MISMATCH):.0f}× {sim_name}'s "
                     "error, and a named effect predicts it on held-out data")
    mods = sel.chosen.fit.mods if sel.chosen else None
    effects = []
    radius = info.get("radius")
    ground_theta = None
    if sel.chosen:
        for cand, theta, err in sel.chosen.fit.split():
            single = next((s for s in sel.ranked if s.fit.candidates == (cand,)), None)
            effects.append(effect_entry(cand, theta, err, single, sel, scorer, r_hold,
                                        res0))
            if cand.name == "ground_effect":
                ground_theta = theta
                if radius is None:
                    radius = float(theta[0])
    res1 = scorer.residuals(mods)
    z_after = scorer.zscores(mods, r_hold)
    unexplained = None
    left = [c for c in mis if z_after.get(c, 0.0) > Z_MISMATCH]
    if left:
        var = scheduling_variables(real)
        worst = left[0]
        reg = locate_channel(worst, res1[worst], sigma[worst], real, radius)
        names = [reg.variable] if reg.variable != "none" else ["thrust", "command_rate"]
        unexplained = fit_unexplained(scorer, mods, worst, {n: var[n] for n in names}, r_fit,
                                      r_hold)
        if unexplained is not None:
            res1[worst] = res1[worst] - unexplained.correction
            effects.append({
                "name": "unexplained", "channels": [worst],
                "parameters": {"model": {"value": f"eTS, {unexplained.model.n_rules} rules",
                                         "unit": ""},
                               "inputs": {"value": names, "unit": ""}},
                "confidence": float(np.clip(1 - unexplained.z_after / unexplained.z_before,
                                            0, 1)),
                "evidence": f"{LABELS[worst]} keeps structure no named effect explains; an "
                            f"eTS model on {', '.join(names)} predicts it on held-out data",
                "rmse_before": {worst: float(np.sqrt(np.mean(res0[worst][r_hold] ** 2)))},
                "rmse_after": {worst: float(np.sqrt(np.mean(res1[worst][r_hold] ** 2)))}})
    rmse_after = _rmse(res1, r_hold)
    series.update(res_after=res1, selection=sel, mods=mods)
    if not effects:
        data = {**base, "verdict": "consistent", "mismatch": None, "effects": [],
                "rmse_after": rmse_before, "candidates": _ranking(sel),
                "notes": [*notes, f"{', '.join(mis)} exceed{'s' if len(mis) == 1 else ''} "
                          f"{sim_name}'s error, but no effect and no residual model "
                          "improves held-out data: unstructured (noise or manoeuvre), "
                          "not missing physics"],
                "reason": "the differences are not structured: nothing fitted on the first "
                          f"part of {real_name} predicts its later part better"}
        data["summary"] = summary_sentence(data)
        return GapResult(data, sim, real, nominal, series)
    main = mis[0]
    effective = info.get("radius") is None
    reg = locate_channel(main, res0[main], sigma[main], real, radius, effective)
    basis = "residual bins"
    if ground_theta is not None:
        # what the tool believes: the band where the fitted law's excess is ≥ half its peak
        reg = ground_band(main, res0[main], real, float(ground_theta[0]),
                          float(ground_theta[1]), reg.eta2, radius, effective)
        basis = "fitted law"
    segs = segments(res0[main], sigma[main], real)
    regime = {"channel": main, "variable": reg.variable,
              "range": None if reg.variable == "none" else [reg.lo, reg.hi],
              "unit": "" if reg.variable == "none" else
              {"alt": "m", "speed": "m/s", "thrust": "1", "command_rate": "1/s", "vbat": "V",
               "time": "s"}[reg.variable],
              "z_over_r": [reg.lo / radius, reg.hi / radius]
              if reg.variable == "alt" and radius else None,
              "radius": None if not (reg.variable == "alt" and radius) else
              {"value": radius, "unit": "m",
               "source": "fitted effective" if effective else "vehicle"},
              "basis": basis, "description": reg.description}
    data = {**base, "verdict": "mismatch",
            "reason": f"{', '.join(LABELS[c] for c in mis)} differ beyond {sim_name}'s own error",
            "mismatch": {"channels": mis,
                         "segments": [{"t_start": a, "t_end": b} for a, b in segs],
                         "regime": regime},
            "effects": effects, "rmse_after": rmse_after, "candidates": _ranking(sel),
            "notes": notes}
    data["summary"] = summary_sentence(data)
    return GapResult(data, sim, real, nominal, series)


def _ranking(sel: Selection) -> list[dict[str, Any]]:
    def row(s: Scored) -> dict[str, Any]:
        return {"name": s.fit.name, "share": round(s.share, 4), "score": round(s.score, 4)}
    return [row(s) for s in sel.ranked]


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
            vehicle: str | Path | None = None, options: Any = None) -> GapResult:
    """Read two logs (or saved tables), analyse them, write ``out_dir/gap.json``.

    ``options`` is an :class:`etsid.ingest.ReadOptions` for both logs (default: none).

    ``gap.json`` is validated against ``gap.schema.json`` before it is written; the series
    behind the figures go to ``out_dir/gap_series.parquet`` (``etsid report`` draws them).
    """
    from etsid.ingest import read_log

    sim_table = read_log(sim_path, options)
    real_table = read_log(real_path, options)
    result = analyse(sim_table, real_table, Path(sim_path).name, Path(real_path).name, vehicle)
    if out_dir is not None:
        write_gap_json(result.data, out_dir)
        frame = series_frame(result)
        if not frame.empty:
            frame.to_parquet(Path(out_dir) / SERIES_FILE)
    return result
