"""The study that chose the ``ETS()`` defaults (issue 11): one grid, one criterion, three tasks.

Run from the repository root::

    nice -n 10 python benchmarks/ets_defaults.py          # grid on the inner splits, then test
    python benchmarks/ets_defaults.py --top 15            # show more of the ranking

Every setting of :data:`GRID` is scored on an **inner validation split carved out of the
learning part** of each task; no test sample is seen before the choice:

* **Box–Jenkins** (gas furnace, y(k) from [y(k−1), u(k−4)], one-step online predict-then-
  learn). Learning part: the first 70 % of the record; inner score: the prequential RMSE
  over the learning part (each prediction is made before its sample is learnt, so it is
  out of sample). Test: the published protocol (whole record, the peers' figure) and the
  last 30 % of the record, which no choice ever saw.
* **Mackey–Glass** τ = 17, x(t+85) from [x(t), x(t−6), x(t−12), x(t−18)]. Learning part:
  t = 201…3200; inner: learn 201…2400, frozen NDEI on 2401…3200. Test: learn 201…3200,
  frozen NDEI on 5001…5500 (the published protocol).
* **Flights**: simulated ``hover-ige`` (60 s, seed 301) and ``ige-oge`` (120 s, seed 311)
  — seeds used by no other benchmark or choice. The default rate model of ``etsid
  identify`` (50 Hz, airborne rows, p, q, r from 36 lagged regressors) with the ETS
  setting as given (running ranges, as ``ETS()``); learning part: identify's (first 70 %
  of the excited rows); inner: learn its first 75 %, frozen one-step RMSE on the rest,
  divided by the batch ARX's (least squares on the same inner rows), mean over p, q, r.
* **Static maps** (known answers, added after the first run: its choice, with exTS spreads,
  fitted the piecewise-linear map of the ``ETS`` docstring no better than a straight line):
  ``kink`` y = −2x (x < 0), 0.5x (x ≥ 0), x ~ U(−1, 1), and ``wave`` y = sin(πx₁)(1 + x₂/2)
  + 0.01 noise, x ~ U(−1, 1)². Learn 1500 / 2000 draws, frozen RMSE on 500 fresh draws,
  divided by the RMSE of a straight line (least squares) on the same split; geometric mean
  over three independent draws of each map.
* **Held input** (a safety check, added after the second run: its choice, with forgetting
  0.9, overflowed the RLS covariance to non-finite predictions on a long stream with one
  input held constant — hover with a held command): 20 000 samples, x = [sin(k/500), 0.3,
  0.001 noise], y = x₁². Passes when every prediction is finite and no covariance entry has
  grown beyond 10⁶ Ω (with forgetting f < 1, the covariance of a direction the data never
  excite grows by 1/f per sample: RLS wind-up); a failure makes the setting ineligible.
  Since the kernels' wind-up guard (forget only while trace(C_i) <= Ω (n + 1), docs/ets.md
  "Consequents") forgetting settings pass it (C/Ω ≈ 4); run 5 of docs/ets.md, which chose
  forgetting 0.9, is this script unchanged with the guard in place.

Criterion (one for all tasks): the **worst** of four ratios — Box–Jenkins inner RMSE / 0.376
and Mackey–Glass inner NDEI / 0.615 (the best measured peer, exTS, docs/ets.md), the flights'
eTS / ARX one-step ratio (geometric mean over the two flights) divided by the same ratio of
the previous defaults (no peer has flight figures; > 1 means the setting makes flights worse
than before), and the static maps' eTS / straight-line ratio (geometric mean; ≈ 1 means the
rules learnt nothing a line does not). Lower is better; a setting that is good on some tasks
but breaks another loses, and one that fails the held-input check is out. Ties (within
0.5 %) go to the simpler setting (fewer changes from the previous defaults). The flights,
maps and held input (≈1 s per setting) are evaluated only for settings whose
Box–Jenkins/Mackey–Glass ratio can still win (branch and bound: the result equals scoring
the whole grid).

The flight tables are simulated once and cached in the system temp directory
(``tempfile.gettempdir()/etsid-ets-defaults``); ``--no-cache`` simulates afresh.
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from etsid.ets import ETS
from etsid.ets.params import DEFAULTS

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
PEER_BJ = 0.376  # exTS, Box–Jenkins RMSE (docs/ets.md, benchmarks/peers_ets.py)
PEER_MG = 0.615  # exTS, Mackey–Glass x(t+85) test NDEI
FLIGHTS = (("hover-ige", 301, 60.0), ("ige-oge", 311, 120.0))
PREVIOUS = dict(radius=0.4, omega=1000.0, variant="ets+", forgetting=1.0,
                utility_threshold=0.05, adaptive_spread=False, coverage=False)
"""The defaults before this study (the reference row of the table)."""


def grid() -> list[dict]:
    """The grid: AF04/A10 ranges of each parameter (radius 0.2–0.7, Ω 10²–10⁴, forgetting
    0.9–1, A10's utility ε 0.03–0.1), both variants, exTS spreads on/off, coverage on/off."""
    out = []
    radii, omegas, forgets = (0.2, 0.3, 0.4, 0.5, 0.7), (100.0, 1000.0, 10000.0), \
        (1.0, 0.99, 0.95, 0.9)
    for r, om, f, sp in itertools.product(radii, omegas, forgets, (False, True)):
        base = dict(radius=r, omega=om, forgetting=f, adaptive_spread=sp)
        out.append(dict(base, variant="ets", utility_threshold=0.05, coverage=False))
        for ut, cov in itertools.product((0.03, 0.05, 0.1), (False, True)):
            out.append(dict(base, variant="ets+", utility_threshold=ut, coverage=cov))
    return out


GRID = grid()


# ---------------------------------------------------------------- Box–Jenkins
def _bj_data() -> tuple[np.ndarray, np.ndarray]:
    gf = pd.read_csv(DATA / "gas_furnace.csv")
    u, y = gf["input_gas_rate"].to_numpy(), gf["co2"].to_numpy()
    k = np.arange(4, len(y))
    return np.c_[y[k - 1], u[k - 4]], y[k]


def bj_inner(params: dict) -> float:
    """Prequential RMSE over the learning part (first 70 %), first prediction excluded."""
    X, Y = _bj_data()
    n = round(0.7 * len(Y))
    e = (ETS(**params).run(X[:n], Y[:n]) - Y[:n])[1:]
    return float(np.sqrt(np.mean(e**2)))


def bj_test(params: dict) -> dict[str, float]:
    """Whole-record RMSE (the published protocol) and RMSE over the last 30 %."""
    X, Y = _bj_data()
    n = round(0.7 * len(Y))
    model = ETS(**params)
    e = model.run(X, Y) - Y
    return {"bj": float(np.sqrt(np.mean(e[1:] ** 2))),
            "bj tail": float(np.sqrt(np.mean(e[n:] ** 2))), "bj rules": model.n_rules}


# ---------------------------------------------------------------- Mackey–Glass
def _mg_task(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x = _MG["x"]
    return np.c_[x[t], x[t - 6], x[t - 12], x[t - 18]], x[t + 85]


_MG: dict[str, np.ndarray] = {}


def _mg_frozen(params: dict, learn: np.ndarray, test: np.ndarray) -> tuple[float, int]:
    if not _MG:
        _MG["x"] = pd.read_csv(DATA / "mackey_glass_tau17.csv")["x"].to_numpy()
    Xl, Yl = _mg_task(learn)
    Xt, Yt = _mg_task(test)
    model = ETS(**params)
    model.run(Xl, Yl)
    return float(np.sqrt(np.mean((model.predict(Xt) - Yt) ** 2)) / np.std(Yt)), model.n_rules


def mg_inner(params: dict) -> float:
    return _mg_frozen(params, np.arange(201, 2401), np.arange(2401, 3201))[0]


def mg_test(params: dict) -> dict[str, float]:
    ndei, rules = _mg_frozen(params, np.arange(201, 3201), np.arange(5001, 5501))
    return {"mg": ndei, "mg rules": rules}


# ---------------------------------------------------------------- flights
@dataclass
class FlightSplit:
    """Regressors of one flight's learning part, cut into inner learning and validation."""

    name: str
    X: np.ndarray
    Y: np.ndarray
    inner: int
    arx_rmse: np.ndarray


def _table(scenario: str, seed: int, duration: float, cache: bool) -> pd.DataFrame:
    from etsid.sim import simulate

    cache_dir = Path(tempfile.gettempdir()) / "etsid-ets-defaults"
    path = cache_dir / f"{scenario}-{seed}-{duration:g}.pkl"
    if cache and path.exists():
        return pd.read_pickle(path)
    table = simulate(scenario, duration=duration, seed=seed).table
    if cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        table.to_pickle(path)
    return table


def flight_split(scenario: str, seed: int, duration: float, cache: bool) -> FlightSplit:
    """identify's regressors (default rate model, 50 Hz, airborne rows) and the inner split."""
    from etsid.ident import IdentConfig
    from etsid.ident.arx import ARX
    from etsid.ident.checks import split_excited
    from etsid.ident.flight import apply_selection, excited_mask, select_flight
    from etsid.ident.model_choice import choose_model
    from etsid.ident.regressors import build
    from etsid.ident.resample import decimate

    table = _table(scenario, seed, duration, cache)
    config = IdentConfig()
    spec = choose_model(table, config).spec
    work = decimate(apply_selection(table, select_flight(table, config.segments)),
                    config.rate_for(True))
    reg = build(work, spec)
    excited = excited_mask(work, spec.outputs)[reg.rows]
    split = split_excited(excited, config.validate)  # identify's learning part: [:split]
    inner = split_excited(excited[:split], 0.25)
    X, Y = reg.X[:split], reg.Y[:split]
    arx = ARX.fit(X[:inner], Y[:inner]).predict(X[inner:])
    arx_rmse = np.sqrt(np.mean((arx - Y[inner:]) ** 2, axis=0))
    return FlightSplit(f"{scenario} {seed}", X, Y, inner, arx_rmse)


def flight_inner(params: dict, flight: FlightSplit) -> float:
    """Frozen one-step RMSE on the inner validation / ARX's, mean over the outputs."""
    model = ETS(**params)
    model.run(flight.X[: flight.inner], flight.Y[: flight.inner])
    with np.errstate(all="ignore"):
        yhat = model.predict(flight.X[flight.inner:])
        rmse = np.sqrt(np.mean((yhat - flight.Y[flight.inner:]) ** 2, axis=0))
    ratio = float(np.mean(rmse / flight.arx_rmse))
    return ratio if np.isfinite(ratio) else np.inf


# ---------------------------------------------------------------- static maps
def _maps() -> list[tuple[str, np.ndarray, np.ndarray, int]]:
    """(name, X, y, learn rows): learn on the first rows, validate on 500 fresh draws;
    three independent draws of each map (one draw proved too lucky or unlucky)."""
    out = []
    for draw in range(3):
        rng = np.random.default_rng(11 + draw)
        x = rng.uniform(-1.0, 1.0, size=(2000, 1))
        kink = np.where(x[:, 0] < 0.0, -2.0 * x[:, 0], 0.5 * x[:, 0])
        X2 = rng.uniform(-1.0, 1.0, size=(2500, 2))
        wave = np.sin(np.pi * X2[:, 0]) * (1.0 + 0.5 * X2[:, 1]) + 0.01 * rng.normal(size=2500)
        out += [("kink", x, kink, 1500), ("wave", X2, wave, 2000)]
    return out


MAPS = _maps()


def map_inner(params: dict) -> dict[str, float]:
    """Frozen RMSE on fresh draws / a straight line's: geometric mean over the draws of
    each map, and over both maps."""
    ratios: dict[str, list[float]] = {}
    for name, X, y, n in MAPS:
        model = ETS(**params)
        model.run(X[:n], y[:n])
        with np.errstate(all="ignore"):
            e = float(np.sqrt(np.mean((model.predict(X[n:]) - y[n:]) ** 2)))
        A = np.c_[np.ones(n), X[:n]]
        line = np.c_[np.ones(len(y) - n), X[n:]] @ np.linalg.lstsq(A, y[:n], rcond=None)[0]
        ratio = e / float(np.sqrt(np.mean((line - y[n:]) ** 2)))
        ratios.setdefault(name, []).append(ratio if np.isfinite(ratio) else np.inf)
    out = {k: float(np.exp(np.mean(np.log(v)))) for k, v in ratios.items()}
    out["maps/line"] = float(np.exp(np.mean(np.log(list(out.values())))))
    return out


# ---------------------------------------------------------------- held input (wind-up)
WINDUP_LIMIT = 1e6
"""Largest covariance growth over Ω that the held-input check accepts."""


def _held() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(5)
    k = np.arange(20_000)
    X = np.c_[np.sin(k / 500.0), np.full(k.size, 0.3), 0.001 * rng.normal(size=k.size)]
    return X, X[:, :1] ** 2


HELD = _held()


def held_growth(params: dict) -> float:
    """Largest |covariance entry| / Ω after the held-input stream (inf: non-finite)."""
    model = ETS(**params)
    with np.errstate(all="ignore"):
        yhat = model.run(*HELD)
        growth = float(np.max(np.abs(model.export_state().covariances))) / model.omega
    return growth if np.all(np.isfinite(yhat[1:])) and np.isfinite(growth) else np.inf


# ---------------------------------------------------------------- study
def changes(params: dict) -> int:
    """How many parameters differ from today's defaults (the tie-break: fewer is simpler)."""
    return sum(params[k] != v for k, v in PREVIOUS.items())


def benchmark_score(params: dict) -> dict:
    bj, mg = (v if np.isfinite(v) else np.inf for v in (bj_inner(params), mg_inner(params)))
    return {"bj inner": bj, "mg inner": mg, "bj/peer": bj / PEER_BJ, "mg/peer": mg / PEER_MG}


def flight_score(params: dict, flights: list[FlightSplit]) -> dict:
    fl = [flight_inner(params, f) for f in flights]
    return {**{f.name: v for f, v in zip(flights, fl, strict=True)},
            "flights/arx": float(np.exp(np.mean(np.log(fl))))}


def study(flights: list[FlightSplit], at_least: int = 0
          ) -> tuple[list[tuple[dict, dict]], dict]:
    """Scores of the grid and of the previous defaults; flights only where they can matter
    (and for the first ``at_least`` settings by the benchmark ratio, to show a ranking)."""
    prev = {**benchmark_score(PREVIOUS), **flight_score(PREVIOUS, flights),
            **map_inner(PREVIOUS), "held C/Ω": held_growth(PREVIOUS)}
    rows = [(p, benchmark_score(p)) for p in GRID]
    rows.sort(key=lambda ps: max(ps[1]["bj/peer"], ps[1]["mg/peer"]))
    best, done = np.inf, []
    for i, (p, s) in enumerate(rows):
        if i >= at_least and max(s["bj/peer"], s["mg/peer"]) > best * 1.005:
            break  # no later setting can come within the tie margin of the best
        s["held C/Ω"] = held_growth(p)
        s.update(flight_score(p, flights))
        s.update(map_inner(p))
        s["flights/prev"] = s["flights/arx"] / prev["flights/arx"]
        s["worst"] = max(s["bj/peer"], s["mg/peer"], s["flights/prev"], s["maps/line"])
        if not s["held C/Ω"] <= WINDUP_LIMIT:
            s["worst"] = np.inf
        best = min(best, s["worst"])
        done.append((p, s))
    prev["flights/prev"] = 1.0
    prev["worst"] = max(prev["bj/peer"], prev["mg/peer"], 1.0, prev["maps/line"])
    done.sort(key=lambda ps: ps[1]["worst"])
    return done, prev


def label(params: dict) -> str:
    keys = ("variant", "radius", "omega", "forgetting", "utility_threshold",
            "adaptive_spread", "coverage")
    short = {"utility_threshold": "util", "adaptive_spread": "spread", "forgetting": "f"}
    return ", ".join(f"{short.get(k, k)}={params[k]:g}" if isinstance(params[k], float)
                     else f"{short.get(k, k)}={params[k]}" for k in keys)


def choose(rows: list[tuple[dict, dict]]) -> tuple[dict, dict]:
    """Lowest worst ratio; within 0.5 % of it, the fewest changes from today's defaults."""
    best = min(s["worst"] for _, s in rows)
    near = [(p, s) for p, s in rows if s["worst"] <= best * 1.005]
    return min(near, key=lambda ps: (changes(ps[0]), ps[1]["worst"]))


def _fmt(v: object) -> str:
    if isinstance(v, float) and (v >= 1e4 or not np.isfinite(v)):
        return f"{v:.1e}" if np.isfinite(v) else "out"
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=10, help="rows of the ranking to print")
    ap.add_argument("--no-cache", action="store_true", help="simulate the flights afresh")
    args = ap.parse_args()
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    flights = [flight_split(*f, cache=not args.no_cache) for f in FLIGHTS]
    rows, prev = study(flights, args.top)
    chosen = choose(rows)
    cols = ["bj inner", "mg inner", *[f.name for f in flights], "bj/peer", "mg/peer",
            "flights/arx", "flights/prev", "kink", "wave", "maps/line", "held C/Ω", "worst"]
    print(f"inner-split scores: {len(GRID)} settings, flights and maps scored for "
          f"{len(rows)} (best {args.top} by the worst ratio, then the previous defaults); "
          "flights: eTS/ARX one-step RMSE ratio; maps: eTS/straight-line RMSE ratio\n")
    print("| setting | " + " | ".join(cols) + " |")
    print("|---|" + "---|" * len(cols))
    for p, s in [*rows[: args.top], (PREVIOUS, prev)]:
        mark = " **(chosen)**" if p is chosen[0] else (" (previous defaults)"
                                                     if p is PREVIOUS else "")
        print(f"| {label(p)}{mark} | " + " | ".join(_fmt(s[c]) for c in cols) + " |")
    print(f"\nchosen: {label(chosen[0])}\n\ntest figures (seen only now)\n")
    print("| setting | BJ RMSE (whole record) | BJ RMSE (last 30 %, unseen) | BJ rules | "
          "MG test NDEI (frozen) | MG rules |")
    print("|---|---|---|---|---|---|")
    for name, p in (("chosen", chosen[0]), ("previous defaults", PREVIOUS)):
        t = {**bj_test(p), **mg_test(p)}
        print(f"| {name} | {t['bj']:.3f} | {t['bj tail']:.3f} | {t['bj rules']} | "
              f"{t['mg']:.3f} | {t['mg rules']} |")
    print(f"| peer exTS (best of its grid) | {PEER_BJ} | – | 5 | {PEER_MG} | 10 |")
    now = {k: getattr(DEFAULTS, k) for k in PREVIOUS}
    print(f"\nETS() defaults in this checkout: {label(now)}")


if __name__ == "__main__":
    main()
