"""Regime-scheduled eTS against ARX on simulated flights (issue 11; docs/identify.md).

Three parts, each printing the tables recorded in docs/identify.md:

``--oracle`` (diagnosis, seeds 1–3, ige-oge 150 s or ``--duration``)
    How large is the regime effect? ARX fitted on the in-ground-effect (alt < 0.6 m) and
    out-of-ground-effect learning samples separately: input-gain ratio and the free-run
    fit of the "oracle" regime-switched ARX (the measured altitude picks the model) and of
    an LPV ARX (regressors x and x·(0.25/alt)²) against global ARX on the validation part.
    That gain is the ceiling for any scheduled model with these regressors.
``--oracle --generator gen2`` (diagnosis, issue 41; ``--airframe hexa15``, ``--seeds 41,42,43``)
    The same on the second generator's regime flights (``benchmarks/regime_bands.py``): in
    ground effect below z/R = 2 (identify's band edge; ``--split-zr``), LPV on x·(2R/alt)^k
    (``--lpv-powers``, default 2), per seed and per identify band; ``--ets`` also runs
    ``identify`` (``IdentConfig()``) and prints the scheduled eTS Δ over ARX beside it.
``--oracle --integrators`` (diagnosis, seeds 1–3)
    Would a state for the rate PID's integrator raise the ceiling? The same global and
    switched ARX with the running integrals of the sticks and the angles as extra
    regressors (integrated in free run).
``--study`` (selection, seeds 1–3, ige-oge 150 s)
    The scheduled default of ``etsid identify``: antecedent × radius × clustering scored on
    an INNER split — identify run on the learning part only (the rows before the outer
    validation part), so its own last 30 % is the inner validation; the outer validation
    part is never looked at. Criterion, fixed before the runs: the larger of
    min(mean Δfit p, mean Δfit q) over the seeds, Δ = eTS − ARX free-run fit. A third
    round changes one eTS or identify parameter at a time from the selected default.
default (benchmark, seeds never used for any choice)
    ige-oge 101.. (150 s), hover-oge 201.. and hover-ige 301.. (60 s, one regime each):
    free-run fit % on the validation part of eTS with the rules on the regressors
    (``--antecedent none``), the identify default (scheduled on ``inv_alt[k-1]``, attitude
    states) and ARX, and the last default without attitude states (radius 0.5) with its
    ARX; the frozen rule count and each rule's focal altitude.

``--sample`` (diagnosis of the bundled sample, seed 7)
    What the README's sample (ige-oge seed 7, 120 s, ROS 1 bag at gyro 100 / sticks 50 Hz)
    gains against the benchmark flights: the same flight as the 250 Hz table at 120 and
    150 s and as ROS 1 bags at other gyro / stick rates; eTS default and ARX free-run fit and
    the oracle ceiling on each (docs/identify.md, "The bundled sample").

    python benchmarks/scheduled.py [--seeds 3] [--duration 300 --ige-oge-only]
    python benchmarks/scheduled.py --oracle [--duration 300] [--integrators]
    python benchmarks/scheduled.py --oracle --generator gen2 --airframe hexa15 --seeds 41,42,43
    python benchmarks/scheduled.py --study
    python benchmarks/scheduled.py --sample
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from etsid.ident import IdentConfig, identify
from etsid.sim import simulate

GE_SPLIT_M = 0.6
"""Oracle regime boundary, m (ground-effect ratio of the Tarot < 1.03 above it)."""

STUDY_SEEDS = (1, 2, 3)


def _fits(metrics: dict[str, Any], arx: bool = False) -> list[float]:
    out = metrics["outputs"]
    return [(out[a]["arx"] if arx else out[a])["validation"]["free_run"]["fit"] for a in "pqr"]


def _focal_altitudes(run: Any) -> list[float]:
    """Focal altitude (m) of every frozen rule of a run scheduled on inv_alt or alt."""
    rules = run.rules
    names = (rules.get("antecedents") or {}).get("names") or []
    if not names:
        return []
    focal = [r["focal_point"][0] for r in rules["rules"]]
    if names[0].startswith("inv_alt"):
        return sorted(1.0 / f for f in focal)
    if names[0].startswith("alt"):
        return sorted(focal)
    return []


def benchmark(n_seeds: int, duration: float = 150.0, single: bool = True) -> None:
    print("| flight | seed | model | fit p % | fit q % | fit r % | rules (frozen) | "
          "focal altitudes m |")
    print("|---|---|---|---|---|---|---|---|")
    flights = [("ige-oge", 101 + i, duration) for i in range(n_seeds)]
    if single:
        flights += ([("hover-oge", 201 + i, 60.0) for i in range(max(1, n_seeds - 1))]
                    + [("hover-ige", 301 + i, 60.0) for i in range(max(1, n_seeds - 1))])
    gains: dict[str, list[list[float]]] = {}
    for scenario, seed, duration in flights:
        table = simulate(scenario, duration=duration, seed=seed).table
        flat = identify(table, IdentConfig(antecedent="none"))
        sched = identify(table, IdentConfig())
        rates_only = identify(table, IdentConfig(attitude="none", radius=0.5))
        arx = _fits(sched.metrics, arx=True)
        rows = [("eTS (rules on regressors)", _fits(flat.metrics), flat.metrics, []),
                ("eTS default (inv_alt)", _fits(sched.metrics), sched.metrics,
                 _focal_altitudes(sched)),
                ("ARX", arx, None, []),
                ("eTS inv_alt r 0.5, no attitude states (last default)",
                 _fits(rates_only.metrics), rates_only.metrics, _focal_altitudes(rates_only)),
                ("ARX, no attitude states", _fits(rates_only.metrics, arx=True), None, [])]
        for label, fits, m, focal in rows:
            rules = m["rules"]["frozen"] if m else "-"
            foc = ", ".join(f"{f:.2f}" for f in focal) or "-"
            print(f"| {scenario} | {seed} | {label} | "
                  + " | ".join(f"{f:.1f}" for f in fits) + f" | {rules} | {foc} |",
                  flush=True)
        gains.setdefault(scenario, []).append(
            [a - b for a, b in zip(_fits(sched.metrics), arx, strict=True)])
    print("\nmean gain of the identify default over ARX (free-run fit points p / q / r; "
          "min over seeds):")
    for scenario, g in gains.items():
        a = np.array(g)
        print(f"  {scenario}: " + " / ".join(f"{m:+.1f} ({lo:+.1f})"
                                              for m, lo in zip(a.mean(0), a.min(0),
                                                               strict=True)))


def _prepared(raw: pd.DataFrame) -> tuple[pd.DataFrame, Any, Any, int]:
    """identify's table, regressor spec, regression and learning/validation split of the
    default rate model of ``raw`` (the split depends on the excitation, not the model): the
    attitude states kept or left out as ``identify`` decides on its inner split."""
    from etsid.ident.attitude_check import check_attitude_states
    from etsid.ident.checks import split_excited
    from etsid.ident.flight import apply_selection, excited_mask, select_flight
    from etsid.ident.model_choice import choose_model
    from etsid.ident.motors import add_motor_commands
    from etsid.ident.regressors import build
    from etsid.ident.resample import decimate

    config = IdentConfig(antecedent="none")
    raw = add_motor_commands(raw)
    chosen = choose_model(raw, config)
    spec = chosen.spec
    table = decimate(apply_selection(raw, select_flight(raw, config.segments)),
                     config.rate_for(True))
    reg = build(table, spec)
    split = split_excited(excited_mask(table, spec.outputs)[reg.rows], config.validate)
    if chosen.attitude and config.attitude == "auto":
        check = check_attitude_states(reg, spec, split,
                                      excited_mask(table, spec.outputs)[reg.rows],
                                      len(table), config.validate)
        if not check.keep:
            spec = check.spec
            reg = build(table, spec)
            split = split_excited(excited_mask(table, spec.outputs)[reg.rows],
                                  config.validate)
    return table, spec, reg, split


STUDY = [("alt[k-1],u_thrust[k-1]", 0.3, "potential", "none")] + [
    (ante, radius, "evq", "none")
    for ante in ("alt[k-1]", "inv_alt[k-1]", "alt[k-1],u_thrust[k-1]",
                 "inv_alt[k-1],u_thrust[k-1]")
    for radius in (0.3, 0.5, 0.7, 1.0)] + [("inv_alt[k-1]", 0.5, "potential", "none")] + [
    ("inv_alt[k-1]", radius, "evq", "auto") for radius in (0.3, 0.5, 0.7, 1.0)]
"""(antecedent, radius, clustering, attitude states) of the selection study; the rows with
attitude states (``roll[k-1],pitch[k-1]``, integrated in free run) came in a second round,
scored on the same inner split."""


def _inner_tables() -> list[pd.DataFrame]:
    """The learning part of each study flight (the rows before the outer validation part)."""
    inner = []
    for seed in STUDY_SEEDS:
        table = simulate("ige-oge", duration=150.0, seed=seed).table
        _, _, reg, split = _prepared(table)
        inner.append(table[table.index < float(reg.t[split])])
    return inner


def _inner_scores(inner: list[pd.DataFrame], config: IdentConfig
                  ) -> tuple[np.ndarray, list[int], list[float]]:
    """Δ = eTS − ARX free-run fit (seeds × p q r) on the inner split, the frozen rule
    counts and the first seed's focal altitudes."""
    deltas, rules, focal = [], [], []
    for k, table in enumerate(inner):
        run = identify(table, config)
        deltas.append([a - b for a, b in zip(_fits(run.metrics),
                                             _fits(run.metrics, arx=True), strict=True)])
        rules.append(run.metrics["rules"]["frozen"])
        if k == 0:
            focal = _focal_altitudes(run)
    return np.array(deltas), rules, focal


def _cells(deltas: np.ndarray) -> str:
    return " | ".join(f"{m:+.2f} ({lo:+.1f})"
                      for m, lo in zip(deltas.mean(0), deltas.min(0), strict=True))


STUDY_PARAMS: list[dict[str, Any]] = [
    {"radius": 0.2}, {"radius": 0.25}, {"radius": 0.4}, {"rls": "global"},
    {"adaptive_spread": True}, {"variant": "ets"}, {"utility_threshold": 0.02},
    {"omega": 1e4}, {"omega": 1e6}, {"forgetting": 0.9999}, {"normalise": "apriori"},
    {"normalise": "running"}]
"""Third round: one eTS or identify parameter changed from the selected default."""


def study() -> None:
    print(f"scheduling study: ige-oge 150 s, seeds {list(STUDY_SEEDS)}; identify on the "
          "learning part only (inner validation = its last 30 %); Δ = eTS − ARX free-run "
          "fit, points")
    inner = _inner_tables()
    print("| antecedent | radius | clustering | attitude states | Δp mean (min) | Δq mean (min) "
          "| Δr mean (min) | rules | focal altitudes m (seed 1) |")
    print("|---|---|---|---|---|---|---|---|---|")
    best = None
    for ante, radius, clustering, attitude in STUDY:
        deltas, rules, focal = _inner_scores(inner, IdentConfig(
            antecedent=ante, radius=radius, clustering=clustering, attitude=attitude))
        score = min(deltas.mean(0)[0], deltas.mean(0)[1])
        if best is None or score > best[0]:
            best = (score, ante, radius, clustering, attitude)
        print(f"| {ante} | {radius:g} | {clustering} | {attitude} | {_cells(deltas)} | "
              f"{'/'.join(map(str, rules))} | "
              + (", ".join(f"{f:.2f}" for f in focal) or "-") + " |", flush=True)
    assert best is not None
    print(f"\nselected (max of min(mean Δp, mean Δq)): {best[1]} radius {best[2]:g} "
          f"{best[3]}, attitude states {best[4]} ({best[0]:+.2f})")
    print("\nthird round: one parameter changed from the identify default, same inner split")
    print("| change | Δp mean (min) | Δq mean (min) | Δr mean (min) | rules |")
    print("|---|---|---|---|---|")
    for change in [{}, *STUDY_PARAMS]:
        deltas, rules, _ = _inner_scores(inner, IdentConfig(**change))
        label = ", ".join(f"{k}={v}" for k, v in change.items()) or "(the default)"
        print(f"| {label} | {_cells(deltas)} | {'/'.join(map(str, rules))} |", flush=True)


def _dc_gain(theta: np.ndarray, names: list[str], u: str, o: int) -> float:
    """Steady-state gain of output ``o`` to input ``u`` of an ARX: Σ b / (1 − Σ a_own)."""
    b = sum(theta[1 + j, o] for j, nm in enumerate(names) if nm.startswith(u + "["))
    a = sum(theta[1 + j, o] for j, nm in enumerate(names) if nm.startswith("pqr"[o] + "["))
    return float(b / (1.0 - a))


MIN_REGIME_ROWS = 2
"""Least learning rows per regressor (+ constant) of each regime for the oracle switch."""


@dataclass(frozen=True)
class OracleRegimes:
    """How the oracle diagnosis splits a flight into regimes and schedules its LPV ARX."""

    split_m: float  # in ground effect below this altitude, m
    scale_m: float  # the LPV ARX's extra regressors are x·(scale_m / alt)^k, k in powers
    floor_m: float  # altitude floor of that schedule, m
    label: str
    powers: tuple[int, ...] = (2,)


ETSID_REGIMES = OracleRegimes(GE_SPLIT_M, 0.25, 0.2, f"alt < {GE_SPLIT_M} m")
"""etsid's ige-oge: the Tarot's ground-effect ratio is below 1.03 above 0.6 m."""


def rotor_regimes(radius_m: float, split_zr: float | None = None,
                  powers: tuple[int, ...] = (2,)) -> OracleRegimes:
    """Regimes of a rotor of radius ``radius_m`` (m): in ground effect below z/R =
    ``split_zr`` (default identify's band edge :data:`etsid.ident.regimes.IGE_BELOW_ZR`);
    LPV on Hayden's coordinate, x·(2R/alt)^k for each k of ``powers``."""
    from etsid.ident.regimes import IGE_BELOW_ZR

    zr = IGE_BELOW_ZR if split_zr is None else split_zr
    split = zr * radius_m
    return OracleRegimes(split, 2.0 * radius_m, 0.3 * radius_m,
                         f"z/R < {zr:g} (alt < {split:.3f} m)", powers)


def _oracle_row(seed: int, duration: float) -> None:
    print(f"| {seed} | " + _oracle(simulate("ige-oge", duration=duration, seed=seed).table)
          + " |", flush=True)


def oracle_fits(raw: pd.DataFrame, regimes: OracleRegimes = ETSID_REGIMES) -> dict[str, Any]:
    """The oracle diagnosis of one flight: ARX fitted on the learning rows in ground effect
    (alt < ``regimes.split_m``) and out of it; free-run fit % (p q r) on identify's
    validation part of the global ARX (``global``), the oracle switch (``switch``: the
    measured altitude picks the regime's ARX) and the LPV ARX (``lpv``); ``ceiling`` = the
    better of switch and LPV minus global; ``ige`` the in-ground-effect share of the
    learning / validation rows; ``ratios`` the steady-state input-gain ratios in / out;
    ``bands`` per model, identify's ``regimes.per_regime`` scores of the model (``free_run``)
    against global ARX (``arx_free_run``) when the table knows its rotor radius. Without
    :data:`MIN_REGIME_ROWS` per regressor on either side of the split there is no switch
    (its fits and ratios NaN, no ``bands["switch"]``; the ceiling is LPV's)."""
    from etsid.ident.arx import ARX
    from etsid.ident.metrics import fit_percent
    from etsid.ident.regimes import bands_for, regime_metrics, rotor_radius
    from etsid.ident.simulate import envelope, free_run

    table, spec, reg, split = _prepared(raw)
    alt = table["alt"].to_numpy()[reg.rows - 1]
    cut = regimes.split_m
    ige = alt < cut
    X, Y, n_table = reg.X, reg.Y, len(table)
    bounds = envelope(Y)
    glob = ARX.fit(X[:split], Y[:split])
    n_in = int(np.count_nonzero(ige[:split]))
    switch = min(n_in, split - n_in) >= MIN_REGIME_ROWS * (X.shape[1] + 1)
    if switch:
        a_in = ARX.fit(X[:split][ige[:split]], Y[:split][ige[:split]])
        a_out = ARX.fit(X[:split][~ige[:split]], Y[:split][~ige[:split]])

    def lpv_x(x: np.ndarray, z: np.ndarray) -> np.ndarray:
        """x and x·(scale/alt)^k for each k of ``regimes.powers`` (rows of x, alt z)."""
        h = np.atleast_1d(regimes.scale_m / np.maximum(z, regimes.floor_m))[:, None]
        x = np.atleast_2d(x)
        return np.column_stack([x, *(x * h ** k for k in regimes.powers)])

    lpv = ARX.fit(lpv_x(X, alt)[:split], Y[:split])
    reg.S = alt[:, None]
    models = {"global": lambda x, s: glob.predict_one(x),
              "lpv": lambda x, s: lpv.predict_one(lpv_x(x, s[0])[0])}
    if switch:
        models["switch"] = lambda x, s: (a_in if s[0] < cut else a_out).predict_one(x)
    sims, fits = {}, {"switch": [float("nan")] * 3}
    for key, model in models.items():
        sims[key] = np.full(Y.shape, np.nan)
        sims[key][split:] = free_run(model, reg, spec, split, n_table, bounds)
        fits[key] = [fit_percent(Y[split:, o], sims[key][split:, o]) for o in range(3)]
    names = [str(t) for t in spec.terms]
    radius = rotor_radius(table.attrs)
    bands = {} if radius is None else {
        key: regime_metrics(table["alt"].to_numpy()[reg.rows], bands_for(radius), Y,
                            list(spec.outputs),
                            {"y_val": sims[key], "y_sim": sims[key],
                             "y_arx_val": sims["global"], "y_arx_sim": sims["global"]},
                            split, reg.t)
        for key in models if key != "global"}
    return {"ige": (float(ige[:split].mean()), float(ige[split:].mean())),
            "ratios": [_dc_gain(a_in.theta, names, u, o) / _dc_gain(a_out.theta, names, u, o)
                       if switch else float("nan")
                       for o, u in enumerate(("u_roll", "u_pitch", "u_yaw"))],
            **fits, "bands": bands,
            "ceiling": [np.nanmax([fits["switch"][o], fits["lpv"][o]]) - fits["global"][o]
                        for o in range(3)]}


def _triple(v: list[float], sign: str = "") -> str:
    return " / ".join("n.a." if np.isnan(x) else f"{x:{sign}.1f}" for x in v)


def _oracle(raw: pd.DataFrame) -> str:
    """The oracle diagnosis of one flight as table cells (IGE shares, gain ratios, global
    / switched / LPV ARX fits, ceiling)."""
    f = oracle_fits(raw)
    return (f"{f['ige'][0]:.2f} / {f['ige'][1]:.2f} | "
            f"{', '.join(f'{r:.2f}' for r in f['ratios'])} | {_triple(f['global'])} | "
            f"{_triple(f['switch'])} | {_triple(f['lpv'])} | {_triple(f['ceiling'], '+')}")


INTEGRAL_COLUMNS = ("u_roll", "u_pitch", "roll", "pitch")
"""Columns whose running integrals stand in for the rate PID's integrators."""


class _Integrating:
    """An ARX's ``predict_one`` for :func:`free_run` that, when ``integrate``, overwrites the
    two angle-integral regressors with their running values: from the measured value at
    the simulation's start on, ∫angle grows by dt × the model's own angle of each row."""

    def __init__(self, pick: Any, integrate: bool, start: int, extra: np.ndarray,
                 dt: np.ndarray, rows: np.ndarray, angle_cols: list[int], n_base: int) -> None:
        self.pick, self.integrate, self.start, self.i = pick, integrate, start, start
        self.integral = extra[start, 2:].copy()
        self.dt, self.rows, self.angle_cols, self.n_base = dt, rows, angle_cols, n_base
        self.angle = np.zeros(2)

    def __call__(self, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        if self.integrate:
            if self.i > self.start:  # ∫angle up to row k-1 adds the angle of row k-2
                self.integral += self.dt[int(self.rows[self.i - 1]) - 1] * self.angle
            x = x.copy()
            x[self.n_base + 2:self.n_base + 4] = self.integral
            self.angle = x[self.angle_cols].copy()
        self.i += 1
        return self.pick(s).predict_one(x)


def _integrator_fits(raw: pd.DataFrame) -> dict[str, list[list[float]]]:
    """Free-run fit % (p q r) of global and oracle-switched ARX on the validation part,
    without and with the integrals of the sticks and of the angles from the table start as
    extra regressors: the rate PID's integrator is ki·∫(angle_kp·(tilt·u − angle) − rate)
    dt, a linear combination of ∫u, ∫angle and the angle. In free run ∫u is known and ∫angle
    goes on from its measured value, integrating the model's own (integrated) angles."""
    from etsid.ident.arx import ARX
    from etsid.ident.metrics import fit_percent
    from etsid.ident.simulate import envelope, free_run

    table, spec, reg, split = _prepared(raw)
    t = np.asarray(table.index, dtype=float)
    dt = np.diff(t, prepend=t[0])
    before = reg.rows - 1  # the regressors of row k are read at k-1
    extra = np.column_stack([np.cumsum(table[c].to_numpy() * dt)[before]
                             for c in INTEGRAL_COLUMNS])
    names = [str(term) for term in spec.terms]
    angle_cols = [names.index("roll[k-1]"), names.index("pitch[k-1]")]
    n_base = reg.X.shape[1]
    ige = table["alt"].to_numpy()[before] < GE_SPLIT_M
    reg.S = ige[:, None].astype(float)
    base_X, Y, bounds = reg.X, reg.Y, envelope(reg.Y)
    out: dict[str, list[list[float]]] = {}
    for label, X in (("without", base_X), ("with", np.column_stack([base_X, extra]))):
        learn = slice(0, split)
        glob = ARX.fit(X[learn], Y[learn])
        ins = ARX.fit(X[learn][ige[learn]], Y[learn][ige[learn]])
        outs = ARX.fit(X[learn][~ige[learn]], Y[learn][~ige[learn]])
        reg.X = X

        integrate = label == "with"
        runs = {"global": _Integrating(lambda s, m=glob: m, integrate, split, extra, dt,
                                       reg.rows, angle_cols, n_base),
                "switch": _Integrating(lambda s, a=ins, b=outs: a if s[0] else b, integrate,
                                       split, extra, dt, reg.rows, angle_cols, n_base)}
        for key, predict in runs.items():
            sim = free_run(predict, reg, spec, split, len(table), bounds)
            out[f"{key} {label}"] = [fit_percent(Y[split:, o], sim[:, o]) for o in range(3)]
        reg.X = base_X
    return out


def integrator_diagnosis(duration: float) -> None:
    print(f"rate-integrator states: ige-oge {duration:g} s, seeds {list(STUDY_SEEDS)}; "
          "free-run fit % p / q / r on the validation part")
    print("| seed | global ARX | oracle switch | ceiling Δ | global ARX + ∫ | "
          "oracle switch + ∫ | ceiling Δ + ∫ |")
    print("|---|---|---|---|---|---|---|")
    for seed in STUDY_SEEDS:
        f = _integrator_fits(simulate("ige-oge", duration=duration, seed=seed).table)
        cells = []
        for label in ("without", "with"):
            g, w = f[f"global {label}"], f[f"switch {label}"]
            cells += [" / ".join(f"{v:.1f}" for v in g), " / ".join(f"{v:.1f}" for v in w),
                      " / ".join(f"{b - a:+.1f}" for a, b in zip(g, w, strict=True))]
        print(f"| {seed} | " + " | ".join(cells) + " |", flush=True)


SAMPLE_SEED = 7
"""Seed of the bundled sample flight (sample_logs/regenerate.py)."""

SAMPLE_CASES = [(150.0, None, None), (120.0, None, None), (120.0, 250.0, 250.0),
                (120.0, 100.0, 100.0), (120.0, 100.0, 50.0), (150.0, 100.0, 50.0)]
"""(length s, gyro Hz, sticks Hz) of the sample diagnosis; None: the 250 Hz table."""


def sample_diagnosis() -> None:
    import tempfile
    from pathlib import Path

    from etsid.ingest import read_log
    from etsid.sim.writers import write_log

    other = {"rc_out": 5.0, "target": 10.0, "range": 20.0, "velocity": 5.0, "battery": 1.0}
    print(f"the bundled sample's flight (ige-oge seed {SAMPLE_SEED}) by length and log rates; "
          "free-run fit % on the validation part")
    print("| source | length s | gyro / sticks Hz | size MB | eTS p/q/r | ARX p/q/r | "
          "Δ p/q/r | rules | IGE share learn / val | gain ratio IGE/OGE p, q, r | "
          "global ARX | oracle switch | LPV | ceiling Δ |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    flights: dict[float, pd.DataFrame] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for duration, gyro, sticks in SAMPLE_CASES:
            if duration not in flights:
                flights[duration] = simulate("ige-oge", duration=duration,
                                             seed=SAMPLE_SEED).table
            table, source, size = flights[duration], "250 Hz table", "-"
            if gyro is not None:
                path = Path(tmp) / f"f{duration:g}_{gyro:g}_{sticks:g}.bag"
                write_log(table, path, rates={"imu": gyro, "rc_in": sticks, **other})
                table, source = read_log(path), "ROS 1 bag"
                size = f"{path.stat().st_size / 1e6:.2f}"
            run = identify(table, IdentConfig())
            ets, arx = _fits(run.metrics), _fits(run.metrics, arx=True)
            rates = "250 / 250" if gyro is None else f"{gyro:g} / {sticks:g}"
            print(f"| {source} | {duration:g} | {rates} | {size} | "
                  + " / ".join(f"{f:.1f}" for f in ets) + " | "
                  + " / ".join(f"{f:.1f}" for f in arx) + " | "
                  + " / ".join(f"{a - b:+.1f}" for a, b in zip(ets, arx, strict=True))
                  + f" | {run.metrics['rules']['frozen']} | {_oracle(table)} |", flush=True)


def oracle(duration: float) -> None:
    print(f"oracle ceiling: ige-oge {duration:g} s, seeds {list(STUDY_SEEDS)}; IGE = alt < "
          f"{GE_SPLIT_M} m; free-run fit % on the validation part")
    print("| seed | IGE share learn / val | DC gain ratio IGE/OGE p, q, r | global ARX p/q/r | "
          "oracle switch p/q/r | LPV p/q/r | ceiling Δ p/q/r (best of the two) |")
    print("|---|---|---|---|---|---|---|")
    for seed in STUDY_SEEDS:
        _oracle_row(seed, duration)


def _band_cells(bands: dict[str, list[dict[str, Any]]], b: int) -> list[str]:
    """Cells of band ``b``: global ARX, switch, LPV free-run fit % p/q/r and the ceiling Δ
    (``n.i.`` where identify calls the band not informative, ``n.a.`` without a switch)."""
    def fit(key: str, y: str, field: str) -> float | None:
        if key not in bands:
            return float("nan")
        return bands[key][b]["outputs"].get(y, {}).get(field, {}).get("fit")

    def cell(v: float | None, sign: str = "") -> str:
        return "n.i." if v is None else "n.a." if np.isnan(v) else f"{v:{sign}.1f}"

    cells = [" / ".join(cell(fit(key, y, field)) for y in "pqr")
             for key, field in (("lpv", "arx_free_run"), ("switch", "free_run"),
                                ("lpv", "free_run"))]
    deltas = []
    for y in "pqr":
        g, sw, lp = fit("lpv", y, "arx_free_run"), fit("switch", y, "free_run"), \
            fit("lpv", y, "free_run")
        deltas.append(cell(None if None in (g, sw, lp) else np.nanmax([sw, lp]) - g, "+"))
    return [*cells, " / ".join(deltas)]


def gen2_oracle(airframe: str, seeds: list[int], with_ets: bool,
                split_zr: float | None = None, powers: tuple[int, ...] = (2,)) -> None:
    """The oracle diagnosis on the second generator's regime flights
    (``benchmarks/regime_bands.py --generator gen2``), per seed and per identify band; with
    ``with_ets`` also the scheduled eTS Δ of ``identify`` with ``IdentConfig()``."""
    from regime_bands import flight

    from etsid.ident.regimes import rotor_radius

    rows: list[str] = []
    per_band: list[str] = []
    ceil, ets_d = [], []
    for seed in seeds:
        raw = flight("gen2", seed, airframe)
        radius = rotor_radius(raw.attrs)
        assert radius is not None
        regimes = rotor_regimes(radius, split_zr, powers)
        f = oracle_fits(raw, regimes)
        ceil.append(f["ceiling"])
        cells = [f"{f['ige'][0]:.2f} / {f['ige'][1]:.2f}", _triple(f["global"]),
                 _triple(f["switch"]), _triple(f["lpv"]), _triple(f["ceiling"], "+")]
        if with_ets:
            out = identify(raw, IdentConfig()).metrics["outputs"]
            arx = [out[y]["arx"]["validation"]["free_run"]["fit"] for y in "pqr"]
            if max(abs(a - b) for a, b in zip(arx, f["global"], strict=True)) > 0.05:
                cells[1] += f" (identify's ARX {_triple(arx)})"
            ets_d.append([out[y]["validation"]["free_run"]["fit"] - a
                          for y, a in zip("pqr", arx, strict=True)])
            cells.append(_triple(ets_d[-1], "+"))
        rows.append(f"| {seed} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
        per_band += [f"| {seed} | {band['name']} | {band['n_validation']} | "
                     + " | ".join(_band_cells(f["bands"], b)) + " |"
                     for b, band in enumerate(f["bands"]["lpv"])]
    print(f"\noracle ceiling: gen2 {airframe} regime flights (180 s), seeds {seeds}; in ground "
          f"effect = {regimes.label}; LPV on x and x·(2R/alt)^k, k = "
          f"{', '.join(map(str, powers))}; free-run fit % on identify's "
          "validation part")
    print("| seed | IGE share learn / val | global ARX p/q/r | oracle switch p/q/r | LPV p/q/r | "
          "ceiling Δ p/q/r" + (" | scheduled eTS Δ p/q/r |" if with_ets else " |"))
    print("|---|---|---|---|---|---|" + ("---|" if with_ets else ""))
    print("\n".join(rows))
    print("mean ceiling Δ p / q / r: " + " / ".join(f"{v:+.2f}" for v in np.mean(ceil, 0)))
    if with_ets:
        print("mean scheduled eTS Δ p / q / r: "
              + " / ".join(f"{v:+.2f}" for v in np.mean(ets_d, axis=0)))
    print("\nper identify band (free-run fit % on the band's validation rows)")
    print("| seed | band | val rows | global ARX p/q/r | oracle switch p/q/r | LPV p/q/r | "
          "ceiling Δ p/q/r |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(per_band))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default=None,
                    help="benchmark: the number of seeds (3); --oracle --generator gen2: the "
                         "seeds, comma-separated (41,42,43)")
    ap.add_argument("--study", action="store_true", help="the inner-split selection study")
    ap.add_argument("--oracle", action="store_true", help="the oracle-ceiling diagnosis")
    ap.add_argument("--integrators", action="store_true",
                    help="with --oracle: does a state for the rate PID's integrator raise it?")
    ap.add_argument("--sample", action="store_true",
                    help="the bundled sample's flight (seed 7) by length and log rates")
    ap.add_argument("--duration", type=float, default=150.0,
                    help="ige-oge flight length, s (--oracle and the benchmark)")
    ap.add_argument("--ige-oge-only", action="store_true",
                    help="benchmark: skip the single-regime flights")
    ap.add_argument("--generator", choices=("etsid", "gen2"), default="etsid",
                    help="with --oracle: etsid's ige-oge or the second generator's regime "
                         "flights (benchmarks/regime_bands.py)")
    ap.add_argument("--airframe", choices=("quad10", "hexa15"), default="hexa15",
                    help="with --oracle --generator gen2: gen2's airframe")
    ap.add_argument("--ets", action="store_true",
                    help="with --oracle --generator gen2: also identify (IdentConfig()) and "
                         "print the scheduled eTS Δ over ARX")
    ap.add_argument("--split-zr", type=float, default=None,
                    help="with --oracle --generator gen2: the oracle's regime edge in z/R "
                         "(default 2, identify's ground-effect band)")
    ap.add_argument("--lpv-powers", default="2",
                    help="with --oracle --generator gen2: the LPV ARX's x·(2R/alt)^k, k "
                         "comma-separated")
    args = ap.parse_args()
    if args.oracle and args.generator == "gen2":
        gen2_oracle(args.airframe, [int(s) for s in (args.seeds or "41,42,43").split(",")],
                    args.ets, args.split_zr,
                    tuple(int(k) for k in args.lpv_powers.split(",")))
    elif args.oracle and args.integrators:
        integrator_diagnosis(args.duration)
    elif args.oracle:
        oracle(args.duration)
    elif args.sample:
        sample_diagnosis()
    elif args.study:
        study()
    else:
        benchmark(int(args.seeds or 3), args.duration, not args.ige_oge_only)


if __name__ == "__main__":
    main()
