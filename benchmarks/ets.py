"""Benchmarks of the eTS core: speed (µs/sample) and quality (Box–Jenkins, Mackey–Glass).

Run from the repository root::

    python benchmarks/ets.py            # everything, prints Markdown tables
    python benchmarks/ets.py --samples 200000 --skip-quality
    python benchmarks/ets.py --skip-quality --baseline ../etsid-old   # A/B in one run
    python benchmarks/ets.py --dump out.npz    # outputs of a fixed set of runs
    python benchmarks/ets.py --compare out.npz # ... compared with this code's (max diff)

Speed is CPU time (``time.process_time``), best of ``--repeats`` runs over a warm model
(compiled kernels loaded from the numba cache, first 1000 samples learned before timing,
after one untimed pass that maps the memory every run reuses).
Every speed table also times a plain, allocation-free numba RLS update of the same size
(n + 1 regressors with the bias, 3 outputs, one rule) in the same process and prints the
ratio eTS / RLS: the machine's load changes both alike, the ratio much less.

``--baseline DIR`` (a checkout of another commit, e.g. ``git worktree add ../etsid-old
HEAD~1``) runs the speed rows of that code and of this one in alternating subprocesses
(``PYTHONPATH``), ``--repeats`` rounds, and prints both with their ratio. ``--dump`` and
``--compare`` use the public ``ETS`` API only, so ``PYTHONPATH=DIR python
benchmarks/ets.py --dump base.npz`` records another commit's outputs with this script.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from numba import njit

from etsid.ets import ETS

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"


def drone_like(N: int, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Smooth low-pass-filtered inputs and three nonlinear coupled outputs."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    X = lfilter([0.05], [1.0, -0.95], rng.normal(size=(N, n)), axis=0)
    Y = np.c_[np.tanh(X[:, 0] + X[:, 1]), X[:, 1] * X[:, 2], np.sin(X[:, 3])]
    return X, Y + 0.01 * rng.normal(size=Y.shape)


@njit(cache=True, boundscheck=False)
def rls_run(X, Y, theta, C, g, Yhat) -> None:  # pragma: no cover - timing reference
    """Plain recursive least squares over all rows: x_e = [1, x], one model, no forgetting,
    no allocation per sample (the yardstick the eTS speed is compared with)."""
    N, n = X.shape
    m = Y.shape[1]
    n1 = n + 1
    xe = np.empty(n1)
    for t in range(N):
        xe[0] = 1.0
        for j in range(n):
            xe[j + 1] = X[t, j]
        for a in range(n1):
            acc = 0.0
            for b in range(n1):
                acc += C[a, b] * xe[b]
            g[a] = acc
        den = 1.0
        for a in range(n1):
            den += xe[a] * g[a]
        iden = 1.0 / den
        for o in range(m):
            e = Y[t, o]
            for a in range(n1):
                e -= xe[a] * theta[a, o]
            Yhat[t, o] = Y[t, o] - e
            for a in range(n1):
                theta[a, o] += g[a] * iden * e
        for a in range(n1):
            ga = g[a] * iden
            for b in range(n1):
                C[a, b] -= ga * g[b]


def rls_time(X: np.ndarray, Y: np.ndarray) -> float:
    """CPU seconds of one plain RLS pass over X, Y."""
    n1, m = X.shape[1] + 1, Y.shape[1]
    theta, C = np.zeros((n1, m)), 1000.0 * np.eye(n1)
    g, Yhat = np.empty(n1), np.empty_like(Y)
    rls_run(X[:10], Y[:10], theta, C, g, Yhat)
    t0 = time.process_time()
    rls_run(X, Y, theta, C, g, Yhat)
    return time.process_time() - t0


#: speed rows: label, inputs, ETS arguments. "bench" are the settings of the recorded speed
#: figures (fixed spreads, utility 0.05, no forgetting: the ETS defaults before issue 11's
#: study); "defaults" are today's ETS defaults; max_rules fixes the rule count (the stream
#: fills the cap within the warm-up)
_BENCH = dict(radius=0.3, adaptive_spread=False, utility_threshold=0.05, forgetting=1.0)
SPEED_ROWS = [
    ("bench, 2 rules", 4, dict(_BENCH, max_rules=2)),
    ("defaults, 2 rules", 4, dict(max_rules=2)),
    ("defaults, 10 rules", 4, dict(max_rules=10)),
    ("bench, local", 4, dict(_BENCH, max_rules=20)),
    ("bench, local", 9, dict(_BENCH, max_rules=20)),
    ("bench, global", 4, dict(_BENCH, rls="global", max_rules=20)),
]


def speed(N: int, repeats: int) -> list[dict]:
    """Best-of-``repeats`` CPU µs/sample of every speed row and of the plain RLS."""
    data = {n: drone_like(N, n) for n in sorted({r[1] for r in SPEED_ROWS})}
    # one untimed pass first: the first timed run would otherwise map fresh memory for its
    # predictions and history (a page fault per 4 KiB, ≈ 3 µs each on a VM, 0.02 µs per
    # sample at 4 inputs) that every later run and the RLS reuse
    for X, Y in data.values():
        ETS(**SPEED_ROWS[0][2]).run(X, Y)
    best = np.full(len(SPEED_ROWS), np.inf)
    rls = {n: np.inf for n in data}
    rules = np.zeros(len(SPEED_ROWS))
    for _ in range(repeats):
        for n, (X, Y) in data.items():
            rls[n] = min(rls[n], rls_time(X, Y))
        for i, (_, n, kw) in enumerate(SPEED_ROWS):
            X, Y = data[n]
            model = ETS(**kw)
            model.run(X[:1000], Y[:1000])
            t0 = time.process_time()
            model.run(X, Y)
            best[i] = min(best[i], time.process_time() - t0)
            rules[i] = float(model.history.n_rules[-N:].mean())
    return [{"setting": label, "inputs": n, "outputs": 3, "samples": N,
             "mean rules": round(rules[i], 1), "eTS µs/sample": best[i] / N * 1e6,
             "RLS µs/sample": rls[n] / N * 1e6, "eTS / RLS": best[i] / rls[n]}
            for i, (label, n, kw) in enumerate(SPEED_ROWS)]  # fmt: skip


def speed_ab(baseline: str, N: int, repeats: int) -> list[dict]:
    """Speed rows of the code in ``baseline`` and of this code, alternating subprocesses."""
    here = str(Path(__file__).resolve().parent.parent)
    best: dict[str, list[dict]] = {}
    for _ in range(repeats):
        for tag, root in (("before", baseline), ("after", here)):
            env = dict(os.environ, PYTHONPATH=str(Path(root).resolve()))
            out = subprocess.run(
                [sys.executable, __file__, "--speed-json", "--samples", str(N), "--repeats", "1"],
                env=env, check=True, capture_output=True, text=True,
            ).stdout
            rows = json.loads(out.splitlines()[-1])
            if tag not in best:
                best[tag] = rows
            else:
                for old, new in zip(best[tag], rows, strict=True):
                    for key in ("eTS µs/sample", "RLS µs/sample"):
                        old[key] = min(old[key], new[key])
    table = []
    for b, a in zip(best["before"], best["after"], strict=True):
        rls = min(b["RLS µs/sample"], a["RLS µs/sample"])
        table.append({"setting": a["setting"], "inputs": a["inputs"], "mean rules": a["mean rules"],
                      "RLS µs": rls, "before µs": b["eTS µs/sample"],
                      "after µs": a["eTS µs/sample"], "before / RLS": b["eTS µs/sample"] / rls,
                      "after / RLS": a["eTS µs/sample"] / rls,
                      "speed-up": b["eTS µs/sample"] / a["eTS µs/sample"]})  # fmt: skip
    return table


def dump_outputs() -> dict[str, np.ndarray]:
    """Predictions, learned state and history of a fixed set of runs (public API only)."""
    X, Y = drone_like(20000, 4)
    S = np.c_[X[:, :1] ** 2, X[:, 2:3]]
    runs = {"defaults": {}, "bench": dict(_BENCH, max_rules=20),
            "global": dict(_BENCH, rls="global", max_rules=20),
            "global_forget": dict(radius=0.3, rls="global", max_rules=8, forgetting=0.95),
            "ets": dict(variant="ets", radius=0.5), "evq": dict(clustering="evq", radius=0.3),
            "scheduled": dict(radius=0.3, clustering="evq"),
            "shared": dict(radius=0.4, shared_outputs=[1])}  # fmt: skip
    out: dict[str, np.ndarray] = {}
    for name, kw in runs.items():
        model = ETS(**kw)
        Sa = S if name == "scheduled" else None
        half = len(X) // 2
        yh = [model.run(X[:half], Y[:half], None if Sa is None else Sa[:half]),
              model.run(X[half:], Y[half:], None if Sa is None else Sa[half:])]
        out[f"{name}/yhat"] = np.concatenate(yh)
        out[f"{name}/predict"] = model.predict(X[:500], None if Sa is None else Sa[:500])
        h = model.history
        out[f"{name}/history"] = np.c_[h.step, h.n_rules, h.potential, h.focal_max, h.focal_min]
        out[f"{name}/events"] = np.array(
            [[e["step"], ("birth", "replace", "removal").index(e["kind"]), e["rule_id"]]
             for e in h.events], dtype=np.int64).reshape(-1, 3)
        if h.snapshots:
            out[f"{name}/snapshots"] = np.concatenate([s["consequents"].ravel()
                                                       for s in h.snapshots])
        st = model.export_state()
        for field in ("consequents", "covariances", "global_covariance", "focal_points",
                      "radii", "potentials", "support"):
            v = getattr(st, field)
            if v is not None:
                out[f"{name}/{field}"] = np.asarray(v)
    for label, fn, settings in (("bj", box_jenkins, BJ_SETTINGS), ("mg", mackey_glass,
                                                                     MG_SETTINGS)):
        for k, v in settings.items():
            r = fn(**v)
            out[f"{label} {k}"] = np.array([x for x in r.values() if x is not None
                                            and not isinstance(x, str)][:3], dtype=float)
    return out


def compare(path: str) -> float:
    """Largest difference (relative to max(1, |value|) of the array) from a dump."""
    ref = np.load(path)
    now = dump_outputs()
    if set(ref.files) != set(now):
        raise SystemExit(f"{path}: different runs: {sorted(set(ref.files) ^ set(now))}")
    worst = 0.0
    for key in sorted(now):
        a, b = ref[key].astype(float), now[key].astype(float)
        if a.shape != b.shape:
            print(f"{key}: shape {a.shape} -> {b.shape}")
            worst = np.inf
            continue
        if a.size == 0:
            continue
        d = np.where(np.isnan(a) & np.isnan(b), 0.0, np.abs(a - b))
        rel = float(np.nanmax(d)) / max(1.0, float(np.nanmax(np.abs(a))))
        worst = max(worst, rel)
        if rel > 0:
            print(f"{key}: max difference {rel:.3g}")
    return worst


def box_jenkins(**params) -> dict:
    gf = pd.read_csv(DATA / "gas_furnace.csv")
    u, y = gf["input_gas_rate"].to_numpy(), gf["co2"].to_numpy()
    k = np.arange(4, len(y))
    X, Y = np.c_[y[k - 1], u[k - 4]], y[k]
    model = ETS(**params)
    t0 = time.process_time()
    Yhat = model.run(X, Y)
    dt = time.process_time() - t0
    e = (Yhat - Y)[1:]  # the first sample has no prediction (no rule yet)
    rmse = float(np.sqrt(np.mean(e**2)))
    return {"rmse": rmse, "ndei": rmse / float(np.std(Y[1:])), "rules": model.n_rules,
            "µs/sample": dt / len(Y) * 1e6}  # fmt: skip


def mackey_glass(**params) -> dict:
    x = pd.read_csv(DATA / "mackey_glass_tau17.csv")["x"].to_numpy()

    def task(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.c_[x[t], x[t - 6], x[t - 12], x[t - 18]], x[t + 85]

    Xtr, Ytr = task(np.arange(201, 3201))
    Xte, Yte = task(np.arange(5001, 5501))
    model = ETS(**params)
    model.run(Xtr, Ytr)
    frozen_rules = model.n_rules
    sd = float(np.std(Yte))
    frozen = float(np.sqrt(np.mean((model.predict(Xte) - Yte) ** 2))) / sd
    cont = float(np.sqrt(np.mean((model.run(Xte, Yte) - Yte) ** 2))) / sd
    return {"ndei frozen": frozen, "ndei continued": cont, "rules (frozen)": frozen_rules,
            "rules (continued)": model.n_rules}  # fmt: skip


BJ_SETTINGS = {
    "defaults": {},
    "tuned": dict(variant="ets", radius=0.5, forgetting=0.9, adaptive_spread=True),
}
MG_SETTINGS = {
    "defaults": {},
    "tuned": dict(variant="ets+", radius=0.2, coverage=True, utility_threshold=0.01,
                  min_support=0, max_rules=200, forgetting=1.0, adaptive_spread=False),
}  # fmt: skip


def _table(rows: list[dict]) -> str:
    cols = list(rows[0])
    fmt = [f"{v:.4g}" if isinstance(v, float) else str(v) for r in rows for v in r.values()]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for i in range(len(rows)):
        lines.append("| " + " | ".join(fmt[i * len(cols) : (i + 1) * len(cols)]) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--skip-quality", action="store_true")
    ap.add_argument("--baseline", metavar="DIR",
                    help="also time the code in DIR (another checkout), alternating runs")
    ap.add_argument("--dump", metavar="NPZ", help="write the outputs of fixed runs and stop")
    ap.add_argument("--compare", metavar="NPZ", help="compare with a --dump file and stop")
    ap.add_argument("--speed-json", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    ETS().run(np.zeros((2, 1)), np.zeros(2))  # load the compiled kernels before any timing
    if args.dump:
        np.savez(args.dump, **dump_outputs())
        return
    if args.compare:
        worst = compare(args.compare)
        print(f"largest difference from {args.compare}: {worst:.3g}")
        raise SystemExit(0 if worst <= 1e-12 else 1)
    if args.speed_json:
        print(json.dumps(speed(args.samples, args.repeats)))
        return
    if not args.skip_quality:
        bj = [{"setting": k, "params": str(v or "ETS()"), **box_jenkins(**v)}
              for k, v in BJ_SETTINGS.items()]  # fmt: skip
        print("Box–Jenkins gas furnace, one-step online, y(k) from [y(k-1), u(k-4)]\n")
        print(_table(bj) + "\n")
        mg = [{"setting": k, "params": str(v or "ETS()"), **mackey_glass(**v)}
              for k, v in MG_SETTINGS.items()]  # fmt: skip
        print("Mackey–Glass τ=17, x(t+85) from x(t), x(t-6), x(t-12), x(t-18); "
              "learn 201..3200, test 5001..5500\n")  # fmt: skip
        print(_table(mg) + "\n")
    if args.skip_speed:
        return
    if args.baseline:
        print(f"Speed, {args.baseline} (before) and this code (after), alternating "
              f"subprocesses, best of {args.repeats} (CPU time)\n")
        print(_table(speed_ab(args.baseline, args.samples, args.repeats)))
    else:
        print(f"Speed (CPU time, best of {args.repeats}; RLS: plain numba RLS of the same "
              "size, same run)\n")
        print(_table(speed(args.samples, args.repeats)))


if __name__ == "__main__":
    main()
