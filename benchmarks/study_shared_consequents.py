"""Study (issue 41): partially shared consequents for the scheduled rate model, offline.

The scheduled eTS of ``etsid identify`` gives every rule its own full consequent, so out of
ground effect a rule fitted on its own regime's rows has more variance than ARX fitted on
every row (docs/identify.md, "Where the structure choice keeps one rule"). The model
studied here shares the part that does not change with height:

    y = θ0ᵀ x_e + Σ_i w_i(s) δ_iᵀ x_g

``x_e = [1, x̃]`` the normalised regressors (identify's learning-part ranges), ``s`` the
scheduling value (inv_alt[k-1]), ``w_i`` the interpolation weights of
``ETS(blend="interpolate")`` between the two focal points enclosing ``s`` (the outermost
rule alone beyond them), with the focal points of the scheduled eTS identify froze on the
same flight, held fixed; ``x_g`` a subset of ``x_e``:

- ``inputs``: the loop-command columns (u_roll, u_pitch, u_yaw, u_thrust lags) and the bias;
- ``bias``: the bias only;
- ``all``: every column (the rules' full consequents plus a shared part: ≈ today's model).

One RLS (forgetting 1, C₀ = ω I with identify's ω, normalised outputs) over the stacked
regressor ``[x_e, w_1 x_g, …, w_R x_g]`` learns online, predict then learn, over the
learning part; frozen at its end, it is simulated over the validation part with
:func:`etsid.ident.simulate.free_run` (the package's free run, attitude states included) and
scored per altitude band with :func:`etsid.ident.regimes.regime_summary_of`, beside the
ARX and eTS of the same identify run.

The regression, split, ranges, table and frozen eTS are those of ``identify`` itself
(captured by wrapping :func:`etsid.ident.run.prediction_columns`). When the structure
choice keeps one rule (``IdentConfig()``), the focal points come from a second run forced
scheduled (``structure="scheduled", unscheduled="r"``, the per-output variant of
docs/identify.md); its ARX is the same.

    python benchmarks/study_shared_consequents.py --variants inputs,bias,all,rp,states
    python benchmarks/study_shared_consequents.py --omega 1e4
    python benchmarks/study_shared_consequents.py --variants inputs,all,states --omega-delta 0.1

Development seeds only (default 31,32,33,1,2,3,4,43 of ``hexa15``; 51–53 are refused).
Flights and captures are cached in ``--cache`` (about 1.5 min per seed the first time).
Results: docs/study_shared_consequents.md (no package change: sharing did not pay).
"""

from __future__ import annotations

import argparse
import pickle
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

VARIANTS = ("inputs", "bias", "all")
"""The ``x_g`` subsets of the brief (module docstring); also ``rp`` (u_roll, u_pitch lags
and the bias), ``thrust`` (u_thrust lags and the bias) and ``states`` (the complement of
``inputs``: lagged rates, attitude and the bias)."""
COMMANDS = ("u_roll", "u_pitch", "u_yaw", "u_thrust")
"""Loop-command columns of the default rate model (gen2 logs sticks and thrust)."""
BANDS = ("in ground effect", "transition", "out of ground effect")


def capture(seed: int, airframe: str, cache: Path) -> dict[str, Any]:
    """identify's regression, split, table, frozen eTS and metrics for ``seed`` (cached):
    ``default`` (``IdentConfig()``) and ``scheduled`` (that run, or a forced one when the
    default keeps one rule)."""
    path = cache / f"{airframe}_{seed}.pkl"
    if path.exists():
        with path.open("rb") as fh:  # our own cache, written below
            return pickle.load(fh)
    from regime_bands import flight

    import etsid.ident.run as run_mod
    from etsid.ident import IdentConfig, identify

    grabbed: dict[str, Any] = {}
    original = run_mod.prediction_columns

    def wrapped(reg, spec, split, n_table, yhat, frozen, table=None, fallback=None):
        cols, diverged = original(reg, spec, split, n_table, yhat, frozen, table, fallback)
        grabbed.update(reg=reg, spec=spec, split=split, n_table=n_table, table=table,
                       frozen=None if frozen is None else frozen.to_dict(), cols=cols)
        return cols, diverged

    run_mod.prediction_columns = wrapped
    try:
        table = flight("gen2", seed, airframe)
        out: dict[str, Any] = {}
        run = identify(table, IdentConfig())
        out["default"] = {**grabbed, "metrics": run.metrics}
        if (run.metrics.get("structure") or {}).get("chosen") == "scheduled":
            out["scheduled"] = out["default"]
        else:
            grabbed.clear()
            run = identify(table, IdentConfig(structure="scheduled", unscheduled="r"))
            out["scheduled"] = {**grabbed, "metrics": run.metrics}
    finally:
        run_mod.prediction_columns = original
    cache.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as fh:
        pickle.dump(out, fh)
    return out


def focal_values(rules: dict[str, Any]) -> np.ndarray:
    """Focal value of every rule of a frozen rules dict on its one antecedent (raw s)."""
    from etsid.ets import ETS

    model = ETS.from_dict(rules, trusted=True)  # written by identify in this process
    return np.sort(np.asarray(model.state_["cz"][:model.n_rules, 0], dtype=float))


def interp_weights(s: np.ndarray, focal: np.ndarray) -> np.ndarray:
    """(N, R) weights of ``blend="interpolate"``: linear between the two focal values that
    enclose s, the outermost rule alone beyond them (``focal`` sorted ascending)."""
    s = np.asarray(s, dtype=float).reshape(-1)
    R = len(focal)
    w = np.zeros((len(s), R))
    if R == 1:
        w[:, 0] = 1.0
        return w
    hi = np.clip(np.searchsorted(focal, s, side="right"), 1, R - 1)
    lo = hi - 1
    t = np.clip((s - focal[lo]) / (focal[hi] - focal[lo]), 0.0, 1.0)
    rows = np.arange(len(s))
    w[rows, lo] = 1.0 - t
    w[rows, hi] += t
    return w


class SharedRLS:
    """y = θ0ᵀ x_e + Σ_i w_i(s) δ_iᵀ x_e[g]: one RLS (forgetting 1) over the stacked
    regressor, prior covariance ω on θ0 and ``omega_delta`` (default ω) on the δ_i; outputs
    in ``plain`` get θ0ᵀ x_e only (their own RLS), as identify leaves yaw unscheduled.
    ``lo``/``width``: regressor normalisation (original units)."""

    def __init__(self, lo: np.ndarray, width: np.ndarray, focal: np.ndarray,
                 g: np.ndarray, m: int, omega: float, plain: list[int],
                 omega_delta: float | None = None) -> None:
        self.lo, self.width, self.focal, self.g = lo, width, focal, g
        self.sched = [o for o in range(m) if o not in plain]
        self.plain = list(plain)
        n1 = len(lo) + 1
        d = n1 + len(focal) * len(g) if len(focal) > 1 else n1
        self.theta = np.zeros((d, len(self.sched)))
        self.C = np.diag(np.r_[np.full(n1, omega),
                               np.full(d - n1, omega if omega_delta is None else omega_delta)])
        self.theta0 = np.zeros((n1, len(self.plain)))
        self.C0 = omega * np.eye(n1)
        self.m = m

    def _xe(self, x: np.ndarray) -> np.ndarray:
        return np.concatenate(([1.0], (np.asarray(x, float) - self.lo) / self.width))

    def _phi(self, xe: np.ndarray, s: float) -> np.ndarray:
        if len(self.focal) == 1:
            return xe
        w = interp_weights(np.array([s]), self.focal)[0]
        return np.concatenate([xe, *(wi * xe[self.g] for wi in w)])

    def predict_one(self, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Outputs (m,) for one regressor row ``x`` and scheduling row ``s``."""
        xe = self._xe(x)
        y = np.empty(self.m)
        y[self.sched] = self._phi(xe, float(np.asarray(s).reshape(-1)[0])) @ self.theta
        y[self.plain] = xe @ self.theta0
        return y

    @staticmethod
    def _rls(theta: np.ndarray, C: np.ndarray, phi: np.ndarray, y: np.ndarray) -> None:
        Cphi = C @ phi
        k = Cphi / (1.0 + phi @ Cphi)
        theta += np.outer(k, y - phi @ theta)
        C -= np.outer(k, Cphi)

    def learn(self, X: np.ndarray, Y: np.ndarray, S: np.ndarray) -> np.ndarray:
        """Predict then learn every row in order; the one-step predictions (N, m)."""
        out = np.empty((len(X), self.m))
        for i in range(len(X)):
            out[i] = self.predict_one(X[i], S[i])
            xe = self._xe(X[i])
            self._rls(self.theta, self.C, self._phi(xe, float(S[i, 0])), Y[i, self.sched])
            if self.plain:
                self._rls(self.theta0, self.C0, xe, Y[i, self.plain])
        return out


def shared_columns(spec: Any, variant: str) -> np.ndarray:
    """Indices into x_e = [1, x̃] of the scheduled part x_g of ``variant``."""
    if variant == "all":
        return np.arange(len(spec.terms) + 1)
    if variant == "bias":
        return np.array([0])
    names = {"inputs": COMMANDS, "rp": ("u_roll", "u_pitch"), "thrust": ("u_thrust",)}
    if variant == "states":
        return np.array([0] + [j + 1 for j, t in enumerate(spec.terms)
                               if t.name not in COMMANDS])
    return np.array([0] + [j + 1 for j, t in enumerate(spec.terms)
                           if t.name in names[variant]])


def band_fits(run: dict[str, Any], sim: np.ndarray, one: np.ndarray
              ) -> dict[str, dict[str, float | None]]:
    """Free-run fit % per band (None: not informative) and over the whole validation part
    (``whole``) of a simulation ``sim`` of rows ``split …`` of ``run``'s regression."""
    from etsid.ident.metrics import fit_percent
    from etsid.ident.regimes import regime_summary_of

    reg, split, outputs = run["reg"], run["split"], list(run["spec"].outputs)
    cols = {k: np.array(v, copy=True) for k, v in run["cols"].items()}
    cols["y_sim"][split:], cols["y_val"][split:] = sim, one
    summary = regime_summary_of(None, run["table"], reg, outputs, cols, split)
    out: dict[str, dict[str, float | None]] = {}
    for band in summary["per_regime"]:
        out[band["name"]] = {y: (band["outputs"].get(y) or {}).get("free_run", {}).get("fit")
                             if (band["outputs"].get(y) or {}).get("informative") else None
                             for y in outputs}
    out["whole"] = {y: fit_percent(reg.Y[split:, o], sim[:, o])
                    for o, y in enumerate(outputs)}
    return out


def study(run: dict[str, Any], variant: str, omega: float, unscheduled: str,
          omega_delta: float | None = None) -> dict[str, dict[str, float | None]]:
    """Learn the shared model of ``variant`` on ``run``'s learning part, freeze it, free-run
    the validation part; band fits as :func:`band_fits`. ``unscheduled``: which outputs get
    the shared part only — ``identify`` (those the run's eTS leaves unscheduled), ``r`` or
    ``none``."""
    from etsid.ident.ranges import fixed_ranges
    from etsid.ident.simulate import envelope, free_run

    reg, spec, split = run["reg"], run["spec"], run["split"]
    x_range, _ = fixed_ranges(reg, spec, split, "learn")
    lo = x_range[:, 0]
    width = np.where(x_range[:, 1] > lo, x_range[:, 1] - lo, 1.0)
    plain = ([int(o) for o in run["frozen"]["params"].get("shared_outputs") or []]
             if unscheduled == "identify" else
             [list(spec.outputs).index("r")] if unscheduled == "r" else [])
    model = SharedRLS(lo, width, focal_values(run["frozen"]), shared_columns(spec, variant),
                      len(spec.outputs), omega, plain, omega_delta)
    model.learn(reg.X[:split], reg.Y[:split], reg.S[:split])
    one = np.array([model.predict_one(reg.X[i], reg.S[i]) for i in range(split, len(reg.X))])
    sim = free_run(model, reg, spec, split, run["n_table"], envelope(reg.Y))
    return band_fits(run, sim, one)


def reference_fits(run: dict[str, Any], key: str) -> dict[str, dict[str, float | None]]:
    """Band fits of identify's own eTS (``key`` "y_sim") or ARX ("y_arx_sim") of ``run``."""
    split = run["split"]
    return band_fits(run, run["cols"][key][split:], run["cols"][key.replace("sim", "val")]
                     [split:])


def delta(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else a - b


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="31,32,33,1,2,3,4,43")
    ap.add_argument("--airframe", default="hexa15", choices=("hexa15", "quad10"))
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--omega", type=float, default=None,
                    help="RLS prior (default: identify's ω of the scheduled rules)")
    ap.add_argument("--omega-delta", type=float, default=None,
                    help="RLS prior of the scheduled terms δ_i (default: --omega)")
    ap.add_argument("--unscheduled", choices=("identify", "r", "none"), default="identify",
                    help="outputs given the shared part only: those identify's eTS leaves "
                    "unscheduled (default; r, and q on seed 1), r, or none")
    ap.add_argument("--cache",
                    default=str(Path(tempfile.gettempdir()) / "study_shared_consequents"))
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if set(seeds) & {51, 52, 53}:
        raise SystemExit("seeds 51–53 are reserved fresh seeds: not in this study")
    variants = [v for v in args.variants.split(",") if v]
    models = ["eTS (identify)", "eTS (scheduled)", *variants]
    rows: dict[str, list[dict[str, float | None]]] = {k: [] for k in models}
    print("| seed | rules (focal alt m) | band | model | Δ fit vs ARX p | q |")
    print("|---|---|---|---|---|---|")
    for seed in seeds:
        runs = capture(seed, args.airframe, Path(args.cache))
        sched = runs["scheduled"]
        omega = args.omega if args.omega is not None else \
            float(sched["frozen"]["params"].get("omega", 1e3))
        arx = reference_fits(sched, "y_arx_sim")
        fits = {"eTS (identify)": reference_fits(runs["default"], "y_sim"),
                "eTS (scheduled)": reference_fits(sched, "y_sim")}
        for v in variants:
            fits[v] = study(sched, v, omega, args.unscheduled, args.omega_delta)
        focal = focal_values(sched["frozen"])
        label = f"{len(focal)} ({', '.join(f'{1 / f:.2f}' for f in focal[::-1])})"
        chosen = (runs["default"]["metrics"].get("structure") or {}).get("chosen")
        for band in (*BANDS, "whole"):
            for name in models:
                d = {y: delta(fits[name].get(band, {}).get(y), arx.get(band, {}).get(y))
                     for y in "pq"}
                rows[name].append({"seed": seed, "band": band, **d})
                cells = " | ".join("n.i." if d[y] is None else f"{d[y]:+.2f}" for y in "pq")
                tag = f"{name} [{chosen}]" if name == "eTS (identify)" else name
                print(f"| {seed} | {label} | {band} | {tag} | {cells} |", flush=True)
    print()
    print("| model | mean Δ whole p | q | worst band p | q | bands < −0.05 (p, q) "
          "| mean Δ out of GE p | q | mean Δ in GE p | q |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in models:
        whole = [r for r in rows[name] if r["band"] == "whole"]
        bands = [r for r in rows[name] if r["band"] != "whole"]
        mean = [np.mean([r[y] for r in whole]) for y in "pq"]
        worst = [min(r[y] for r in bands if r[y] is not None) for y in "pq"]
        below = [sum(1 for r in bands if r[y] is not None and r[y] < -0.05) for y in "pq"]
        per = [np.mean([r[y] for r in bands if r["band"] == b and r[y] is not None])
               for b in (BANDS[2], BANDS[0]) for y in "pq"]
        print(f"| {name} | {mean[0]:+.2f} | {mean[1]:+.2f} | {worst[0]:+.2f} | "
              f"{worst[1]:+.2f} | {below[0]}, {below[1]} | "
              + " | ".join(f"{v:+.2f}" for v in per) + " |")


if __name__ == "__main__":
    main()
