"""The eTS benchmarks run on a peer library: PyPI ``evolvingfuzzysystems`` (eTS, exTS, Simpl_eTS).

Same protocol as ``benchmarks/ets.py``: Box–Jenkins one-step online predict-then-learn of
y(k) from [y(k−1), u(k−4)] (RMSE in % CO2, first prediction excluded); Mackey–Glass x(t+85)
from [x(t), x(t−6), x(t−12), x(t−18)], learn on t = 201…3200, test on t = 5001…5500 frozen.
Inputs are min–max normalised with the training ranges (the peers do not normalise).

The peer library is NOT an etsid dependency; run this in its own environment::

    python3 -m venv .peers && .peers/bin/pip install evolvingfuzzysystems pandas
    .peers/bin/python benchmarks/peers_ets.py

Each model is run with its defaults and over a small grid of its radius-like parameter;
the best result per model is reported, with the parameter, so the peers get a fair chance.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
GRIDS = {"eTS": ("r", [0.05, 0.1, 0.2, 0.4]), "exTS": ("rho", [0.2, 0.35, 0.5, 0.7]),
         "Simpl_eTS": ("r", [0.05, 0.1, 0.2, 0.4])}


def scale(train: np.ndarray, *arrays: np.ndarray) -> list[np.ndarray]:
    lo, hi = train.min(axis=0), train.max(axis=0)
    return [(a - lo) / np.where(hi > lo, hi - lo, 1.0) for a in (train, *arrays)]


def online(model: object, X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Predict each sample before learning it; returns predictions and seconds per sample."""
    model.fit(X[:1], y[:1])  # type: ignore[attr-defined]
    pred = np.full(len(y), np.nan)
    t0 = time.process_time()
    for k in range(1, len(y)):
        pred[k] = np.ravel(model.predict(X[k:k + 1]))[0]  # type: ignore[attr-defined]
        model.evolve(X[k:k + 1], y[k:k + 1])  # type: ignore[attr-defined]
    return pred, (time.process_time() - t0) / (len(y) - 1)


def n_rules(model: object) -> int:
    return len(model.parameters)  # type: ignore[attr-defined]


def box_jenkins(make: type, **params: float) -> dict[str, float]:
    gf = pd.read_csv(DATA / "gas_furnace.csv")
    u, y = gf["input_gas_rate"].to_numpy(), gf["co2"].to_numpy()
    k = np.arange(4, len(y))
    (X,) = scale(np.c_[y[k - 1], u[k - 4]])
    model = make(**params)
    pred, sec = online(model, X, y[k])
    rmse = float(np.sqrt(np.nanmean((pred[1:] - y[k][1:]) ** 2)))
    return {"rmse": rmse, "rules": n_rules(model), "µs/sample": sec * 1e6}


def mackey_glass(make: type, **params: float) -> dict[str, float]:
    x = pd.read_csv(DATA / "mackey_glass_tau17.csv")["x"].to_numpy()

    def task(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.c_[x[t], x[t - 6], x[t - 12], x[t - 18]], x[t + 85]

    Xtr, ytr = task(np.arange(201, 3201))
    Xte, yte = task(np.arange(5001, 5501))
    Xtr, Xte = scale(Xtr, Xte)
    model = make(**params)
    online(model, Xtr, ytr)
    pred = np.ravel(model.predict(Xte))
    ndei = float(np.sqrt(np.mean((pred - yte) ** 2)) / np.std(yte))
    return {"ndei": ndei, "rules": n_rules(model)}


def main() -> None:
    import evolvingfuzzysystems.eFS as efs

    warnings.filterwarnings("ignore")
    print("| model | task | best parameter | result | rules | µs/sample |")
    print("|---|---|---|---|---|---|")
    for name, (param, grid) in GRIDS.items():
        make = getattr(efs, name)
        for task, run, key in (("Box–Jenkins RMSE", box_jenkins, "rmse"),
                               ("Mackey–Glass test NDEI", mackey_glass, "ndei")):
            best: tuple[float, str, dict[str, float]] | None = None
            for value in [None, *grid]:
                kwargs = {} if value is None else {param: value}
                try:
                    result = run(make, **kwargs)
                except Exception as err:  # a peer failing on a setting is a result too
                    print(f"<!-- {name} {kwargs}: {type(err).__name__}: {err} -->")
                    continue
                if np.isfinite(result[key]) and (best is None or result[key] < best[0]):
                    label = "default" if value is None else f"{param}={value}"
                    best = (result[key], label, result)
            if best is None:
                print(f"| {name} | {task} | – | failed | – | – |")
                continue
            res = best[2]
            speed = f"{res['µs/sample']:.0f}" if "µs/sample" in res else "–"
            print(f"| {name} | {task} | {best[1]} | {best[0]:.3f} | {res['rules']} | {speed} |")


if __name__ == "__main__":
    main()
