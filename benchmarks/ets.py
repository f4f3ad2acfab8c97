"""Benchmarks of the eTS core: speed (µs/sample) and quality (Box–Jenkins, Mackey–Glass).

Run from the repository root::

    python benchmarks/ets.py            # everything, prints Markdown tables
    python benchmarks/ets.py --samples 200000 --skip-quality

Speed is CPU time (``time.process_time``), best of ``--repeats`` runs over a warm model
(compiled kernels loaded from the numba cache, first 1000 samples learned before timing).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd

from etsid.ets import ETS

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"


def drone_like(N: int, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Smooth low-pass-filtered inputs and three nonlinear coupled outputs."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    X = lfilter([0.05], [1.0, -0.95], rng.normal(size=(N, n)), axis=0)
    Y = np.c_[np.tanh(X[:, 0] + X[:, 1]), X[:, 1] * X[:, 2], np.sin(X[:, 3])]
    return X, Y + 0.01 * rng.normal(size=Y.shape)


def speed(N: int, repeats: int) -> list[dict]:
    rows = []
    for n, rls in ((4, "local"), (9, "local"), (4, "global")):
        X, Y = drone_like(N, n)
        best = np.inf
        for _ in range(repeats):
            # fixed spreads, utility 0.05, no forgetting: the settings of the recorded
            # speed figures (the ETS defaults before issue 11's study)
            model = ETS(radius=0.3, rls=rls, max_rules=20, adaptive_spread=False,
                        utility_threshold=0.05, forgetting=1.0)
            model.run(X[:1000], Y[:1000])
            t0 = time.process_time()
            model.run(X, Y)
            best = min(best, time.process_time() - t0)
        rows.append({"inputs": n, "outputs": 3, "rls": rls, "samples": N,
                     "mean rules": round(float(model.history.n_rules.mean()), 1),
                     "µs/sample": round(best / N * 1e6, 3)})  # fmt: skip
    return rows


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
    args = ap.parse_args()
    ETS().run(np.zeros((2, 1)), np.zeros(2))  # load the compiled kernels before any timing
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
    if not args.skip_speed:
        print(f"Speed (CPU time, best of {args.repeats})\n")
        print(_table(speed(args.samples, args.repeats)))


if __name__ == "__main__":
    main()
