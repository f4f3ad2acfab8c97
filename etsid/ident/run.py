"""Identification and prediction runs: online eTS over a log, frozen validation, ARX beside it.

:func:`identify` learns online (predict, then learn) over every usable row. The model as it
stood after the first ``1 − validate`` of the rows is the *frozen* model: it is saved as
rules.json and evaluated on the rest (one-step and free-run). Because the online pass is
one pass in time order, the frozen model is exactly a model trained on the first part only.
:func:`predict` applies a saved rule base to another table.
"""

from __future__ import annotations

import datetime as dt
import itertools
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid import __version__
from etsid.errors import IdentError, ModelError
from etsid.ets import ETS
from etsid.ident.arx import ARX, rls_online
from etsid.ident.defaults import INPUT_LAGS, OUTPUT_LAGS, default_model
from etsid.ident.metrics import scores
from etsid.ident.regressors import Regression, RegressorSpec, build
from etsid.ident.resample import DEFAULT_RATE_HZ, decimate
from etsid.ident.rundir import Run, jsonable, sha256
from etsid.ident.simulate import free_run
from etsid.progress import progress
from etsid.table import COLUMNS

CHUNK = 4096
"""Samples learned per call between progress-bar updates."""

MIN_TRAIN = 10
"""Fewest usable rows the learning part may have."""

NORMALISE_MODES = ("learn", "running", "apriori")
"""How eTS normalises its inputs and outputs (``--normalise``, docs/identify.md)."""

RANGE_MARGIN = 0.05
"""Fixed ranges are widened by this fraction of their width on each side."""

APRIORI_RANGES = {"u_roll": (-1.0, 1.0), "u_pitch": (-1.0, 1.0), "u_yaw": (-1.0, 1.0),
                  "u_thrust": (0.0, 1.0)}
"""FlightTable contract ranges of the loop commands (``--normalise apriori``)."""


@dataclass
class IdentConfig:
    """Every parameter of an identification run (stored in config.json).

    Parameters
    ----------
    outputs
        Columns to predict; ``None`` chooses the default rate model (p, q, r).
    regressors
        Regressor spec (``"co2[k-1],input_gas_rate[k-4]"``); ``None`` with default
        outputs uses the default lags; required when ``outputs`` is given.
    output_lags, input_lags
        Lags of the default rate model, samples.
    radius, omega, variant, max_rules, rls, forgetting, utility_threshold, min_support,
    prune_after, adaptive_spread, history_every
        eTS parameters (see :class:`etsid.ets.ETS`).
    validate
        Fraction of the usable rows, at the end, held out for frozen validation (0 … 0.9).
    normalise
        eTS normalisation ranges: ``learn`` (fixed, min/max of the learning part widened
        by :data:`RANGE_MARGIN`), ``running`` (the eTS running min/max, strictly causal)
        or ``apriori`` (fixed: :data:`APRIORI_RANGES` for the loop commands, learning-part
        ranges for the rest). See :func:`fixed_ranges`.
    ident_rate
        Identification rate, Hz: the table is block-mean decimated by the integer factor
        whose rate is nearest (:func:`etsid.ident.resample.decimate`). ``None``: 50 Hz for
        the default rate model, the table's own rate with ``outputs``; 0: the table's rate.
    inputs
        Input family of the default rate model: ``auto``, ``sticks``, ``torque`` or
        ``setpoints`` (:mod:`etsid.ident.inputs`).
    """

    outputs: list[str] | None = None
    regressors: str | None = None
    output_lags: int = OUTPUT_LAGS
    input_lags: int = INPUT_LAGS
    radius: float = 2.0
    omega: float = 1000.0
    variant: str = "ets+"
    max_rules: int = 30
    rls: str = "local"
    forgetting: float = 1.0
    utility_threshold: float = 0.05
    min_support: int = 3
    prune_after: int = 50
    adaptive_spread: bool = False
    history_every: int = 250
    validate: float = 0.3
    ident_rate: float | None = None
    inputs: str = "auto"
    normalise: str = "learn"

    def rate_for(self, default_model: bool) -> float | None:
        """The identification rate to aim for, Hz (None: keep the table's rate)."""
        if self.ident_rate is None:
            return DEFAULT_RATE_HZ if default_model else None
        if not np.isfinite(self.ident_rate) or self.ident_rate < 0:
            raise IdentError(f"--ident-rate must be ≥ 0 Hz, got {self.ident_rate}")
        return float(self.ident_rate) or None

    def ets_params(self) -> dict[str, Any]:
        """Keyword arguments of :class:`ETS`."""
        keys = ("radius", "omega", "variant", "max_rules", "rls", "forgetting",
                "utility_threshold", "min_support", "prune_after", "adaptive_spread",
                "history_every")
        return {k: getattr(self, k) for k in keys}


@dataclass
class _Model:
    spec: RegressorSpec
    notes: list[str] = field(default_factory=list)
    inputs: dict[str, Any] = field(default_factory=dict)


def _choose_model(table: pd.DataFrame, config: IdentConfig) -> _Model:
    if config.outputs:
        if not config.regressors:
            raise IdentError("--output needs --regressors, e.g. --regressors "
                             f"\"{config.outputs[0]}[k-1],u[k-1]\"")
        spec = RegressorSpec.parse(config.regressors, config.outputs)
        return _Model(spec, [], {"family": "user", "columns": [
            c for c in spec.columns if c not in spec.outputs]})
    chosen = default_model(table, config.output_lags, config.input_lags, config.inputs)
    spec = chosen.spec
    if config.regressors:
        spec = RegressorSpec.parse(config.regressors, spec.outputs)
    info: dict[str, Any] = {"family": chosen.family, "kind": chosen.kind,
                            "columns": chosen.inputs, "sources": chosen.sources,
                            "mode": config.inputs, "reason": chosen.reason}
    selection = table.attrs.get("input_selection")
    if isinstance(selection, dict):
        info["selection"] = selection
    return _Model(spec, [chosen.note], info)


def _rate_note(work: pd.DataFrame) -> str:
    d = work.attrs.get("decimation") or {}
    if d.get("factor", 1) > 1:
        return (f"identification rate {d['rate_hz']:.4g} Hz: {d['native_rate_hz']:.4g} Hz "
                f"table, block mean of {d['factor']} samples (noise σ / √{d['factor']})")
    return f"identification rate {d.get('rate_hz', 0):.4g} Hz (the table's rate)"


def noise_std(table: pd.DataFrame, outputs: tuple[str, ...]) -> dict[str, float]:
    """Known sensor-noise σ per output from ``table.attrs["noise"]`` (gyro σ for p, q, r)."""
    noise = table.attrs.get("noise") or {}
    out: dict[str, float] = {}
    gyro = noise.get("gyro_std") if isinstance(noise, dict) else None
    for y in outputs:
        value: Any = noise.get(f"{y}_std") if isinstance(noise, dict) else None
        if value is None and y in ("p", "q", "r") and gyro is not None:
            value = gyro
            if isinstance(gyro, dict):
                value = gyro.get(y)
            elif isinstance(gyro, (list, tuple)) and len(gyro) == 3:
                value = gyro["pqr".index(y)]
        if isinstance(value, (int, float)) and np.isfinite(value):
            out[y] = float(value)
    return out


def _learn(model: ETS, reg: Regression, stop_at: int, show: bool,
           label: str) -> tuple[np.ndarray, dict[str, Any] | None]:
    """Online pass over ``reg``; returns the one-step predictions and the model dict as it
    stood after ``stop_at`` rows (None when ``stop_at`` is not inside the data)."""
    n = len(reg.X)
    yhat = np.full(reg.Y.shape, np.nan)
    frozen: dict[str, Any] | None = None
    bounds = sorted({0, n, *range(0, n, CHUNK), *([stop_at] if 0 < stop_at <= n else [])})
    with progress(n, label, show) as bar:
        for a, b in itertools.pairwise(bounds):
            yhat[a:b] = np.asarray(model.run(reg.X[a:b], reg.Y[a:b])).reshape(b - a, -1)
            if b == stop_at:
                frozen = model.to_dict()
            bar.update(b - a)
    return yhat, frozen


def _history(model: ETS, reg: Regression) -> tuple[pd.DataFrame, pd.DataFrame]:
    """history.parquet and consequents.parquet frames of the last ``len(reg)`` learned
    samples (a loaded model continues its step count)."""
    hist = model.history
    frame = hist.to_frame()
    first_step = int(frame["step"].iloc[-len(reg.t)]) - 1 if len(frame) >= len(reg.t) else 0
    frame = frame[frame["step"] > first_step].reset_index(drop=True)
    pos = frame["step"].to_numpy() - first_step - 1
    frame.insert(1, "t", reg.t[pos])
    kinds = {"birth": "births", "replace": "replacements", "removal": "removals"}
    for col in kinds.values():
        frame[col] = np.zeros(len(frame), dtype=np.int64)
    text = [""] * len(frame)
    for event in hist.events:
        i = int(event["step"]) - first_step - 1
        if 0 <= i < len(frame):
            frame.loc[i, kinds[event["kind"]]] += 1
            text[i] = (text[i] + "; " if text[i] else "") + f"{event['kind']} {event['rule_id']}"
    frame["events"] = text
    rows = []
    inputs, outputs = model.names_()
    terms = ["1", *inputs]
    for snap in hist.snapshots:
        i = int(snap["step"]) - first_step - 1
        if not 0 <= i < len(reg.t):
            continue
        cons = np.asarray(snap["consequents"])
        for r, rid in enumerate(np.asarray(snap["rule_ids"])):
            for j, term in enumerate(terms):
                for o, out in enumerate(outputs):
                    rows.append((int(snap["step"]), float(reg.t[i]), int(rid), out, term,
                                 float(cons[r, j, o])))
    cons_frame = pd.DataFrame(rows, columns=["step", "t", "rule_id", "output", "term", "value"])
    return frame, cons_frame


def _unit(name: str) -> str:
    spec = COLUMNS.get(name)
    return spec.unit if spec else ""


def _evaluate(reg: Regression, spec: RegressorSpec, split: int, n_table: int,
              yhat: np.ndarray, frozen: ETS | None) -> dict[str, np.ndarray]:
    """All prediction columns: online, frozen one-step and free-run, ARX online/val/sim."""
    n, m = reg.Y.shape
    cols = {k: np.full((n, m), np.nan) for k in ("y_val", "y_sim", "y_arx_val", "y_arx_sim")}
    cols["y_hat"] = yhat
    cols["y_arx"] = rls_online(reg.X, reg.Y)
    if frozen is not None and split < n:
        cols["y_val"][split:] = np.asarray(frozen.predict(reg.X[split:])).reshape(n - split, m)
        cols["y_sim"][split:] = free_run(frozen.predict_one, reg, spec, split, n_table)
    if split >= reg.X.shape[1] + 1 and split < n:
        arx = ARX.fit(reg.X[:split], reg.Y[:split])
        cols["y_arx_val"][split:] = arx.predict(reg.X[split:])
        cols["y_arx_sim"][split:] = free_run(arx.predict_one, reg, spec, split, n_table)
    return cols


def _metrics(reg: Regression, spec: RegressorSpec, split: int, cols: dict[str, np.ndarray],
             sigma: dict[str, float], sigma_native: dict[str, float] | None = None
             ) -> dict[str, Any]:
    n = len(reg.Y)
    out: dict[str, Any] = {}
    val = slice(split, n)
    for o, y in enumerate(spec.outputs):
        meas = reg.Y[:, o]
        entry: dict[str, Any] = {"unit": _unit(y), "noise_std": sigma.get(y),
                                 "noise_std_native": (sigma_native or {}).get(y)}
        entry["online"] = scores(meas, cols["y_hat"][:, o])
        if split < n:
            entry["validation"] = {"one_step": scores(meas[val], cols["y_val"][val, o]),
                                   "free_run": scores(meas[val], cols["y_sim"][val, o])}
        else:
            entry["validation"] = None
        arx: dict[str, Any] = {"online": scores(meas, cols["y_arx"][:, o])}
        if split < n and np.isfinite(cols["y_arx_val"][val, o]).any():
            arx["validation"] = {"one_step": scores(meas[val], cols["y_arx_val"][val, o]),
                                 "free_run": scores(meas[val], cols["y_arx_sim"][val, o])}
        else:
            arx["validation"] = None
        entry["arx"] = arx
        if y in sigma and sigma[y] > 0:
            for block in (entry["online"], *((entry["validation"] or {}).values()),
                          arx["online"], *((arx["validation"] or {}).values())):
                if block.get("rmse") is not None:
                    block["rmse_over_noise"] = block["rmse"] / sigma[y]
        out[y] = entry
    return out


def _predictions(reg: Regression, spec: RegressorSpec, table: pd.DataFrame, split: int,
                 cols: dict[str, np.ndarray]) -> pd.DataFrame:
    frame: dict[str, Any] = {"t": reg.t}
    if "segment" in table.columns:
        frame["segment"] = table["segment"].to_numpy()[reg.rows]
    part = np.full(len(reg.t), "learn", dtype=object)
    part[split:] = "validation"
    frame["part"] = part
    for o, y in enumerate(spec.outputs):
        frame[y] = reg.Y[:, o]
        for key in ("y_hat", "y_val", "y_sim", "y_arx", "y_arx_val", "y_arx_sim"):
            frame[y + key[1:]] = cols[key][:, o]
    return pd.DataFrame(frame)


def _run_header(command: str, table: pd.DataFrame, source: str | Path | None
                ) -> dict[str, Any]:
    """The first keys of config.json: schema, command, version, time and input file."""
    return {
        "schema": "etsid.run/1",
        "command": command,
        "etsid_version": __version__,
        "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "input": _input_info(table, source),
    }


def _input_info(table: pd.DataFrame, source: str | Path | None) -> dict[str, Any]:
    t = np.asarray(table.index, dtype=float)
    info: dict[str, Any] = {
        "path": str(source) if source is not None else table.attrs.get("source"),
        "sha256": sha256(source) if source is not None and Path(source).exists() else None,
        "format": table.attrs.get("format"),
        "rows": len(table),
        "t_start": float(t[0]) if t.size else None,
        "t_end": float(t[-1]) if t.size else None,
        "rate_hz": table.attrs.get("rate_hz"),
        "mapping": table.attrs.get("mapping"),
    }
    return info


def _learn_range(v: np.ndarray) -> tuple[float, float]:
    """[low, high] of learning-part values, widened by :data:`RANGE_MARGIN` of the width
    on each side; a (near-)constant column gets width 1 around its value (the eTS rule for
    a zero range) so that later excursions are not blown up."""
    v = v[np.isfinite(v)]
    if v.size == 0:
        return -0.5, 0.5
    lo, hi = float(v.min()), float(v.max())
    width = hi - lo
    if width <= 1e-9 * max(1.0, abs(lo), abs(hi)):
        mid = 0.5 * (lo + hi)
        return mid - 0.5, mid + 0.5
    return lo - RANGE_MARGIN * width, hi + RANGE_MARGIN * width


def fixed_ranges(reg: Regression, spec: RegressorSpec, split: int,
                 mode: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """eTS ``x_range``, ``y_range`` for ``--normalise mode`` (None, None for ``running``).

    ``learn``: each regressor's and output's min/max over the learning part (the first
    ``split`` rows), widened by :data:`RANGE_MARGIN`. ``apriori``: regressors of the loop
    commands get :data:`APRIORI_RANGES` (the FlightTable contract), everything else as in
    ``learn``.
    """
    if mode not in NORMALISE_MODES:
        raise IdentError(f"--normalise {mode!r}: choose one of {', '.join(NORMALISE_MODES)}")
    if mode == "running":
        return None, None
    X, Y = reg.X[:split], reg.Y[:split]
    x_range = np.array([_learn_range(X[:, j]) for j in range(X.shape[1])])
    y_range = np.array([_learn_range(Y[:, o]) for o in range(Y.shape[1])])
    if mode == "apriori":
        for j, term in enumerate(spec.terms):
            if term.name in APRIORI_RANGES:
                x_range[j] = APRIORI_RANGES[term.name]
    return x_range, y_range


def _split_index(n: int, validate: float) -> int:
    if not 0.0 <= validate <= 0.9:
        raise IdentError(f"--validate must be between 0 and 0.9, got {validate}")
    split = n - round(validate * n)
    if split < MIN_TRAIN:
        raise IdentError(f"only {n} usable rows: too few to learn on {split} of them "
                         "(lower --validate or use a longer log)")
    return split


MIN_RATE_HZ = 20.0
"""Below this sample rate a multirotor's body-rate dynamics (bandwidth of a few Hz) alias."""
SAMPLES_PER_PARAMETER = 10
"""Fewer usable samples than this many per consequent parameter of one rule: a warning."""


def data_warnings(table: pd.DataFrame, n_samples: int, n_regressors: int,
                  rate_model: bool) -> list[str]:
    """Warnings about data too slow or too short to identify from (printed and in config).

    Parameters
    ----------
    n_samples
        Usable regression rows.
    n_regressors
        Regressors per output (a rule has ``n_regressors + 1`` parameters per output).
    rate_model
        True for the body-rate model (the sample-rate check applies to it only).
    """
    notes = []
    t = table.index.to_numpy()
    rate = (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else 0.0
    if rate_model and 0 < rate < MIN_RATE_HZ:
        notes.append(f"warning: body rates sampled at {rate:.3g} Hz; a multirotor's rate "
                     f"dynamics need ≥ {MIN_RATE_HZ:g} Hz (telemetry streams are often "
                     "slow: log at a higher rate), expect poor fits")
    needed = SAMPLES_PER_PARAMETER * (n_regressors + 1)
    if n_samples < needed:
        notes.append(f"warning: only {n_samples} usable samples for {n_regressors + 1} "
                     f"parameters per rule and output (want ≥ {needed}): the log is too "
                     "short for a reliable model; fewer lags (--output-lags/--input-lags) "
                     "or a longer flight help")
    return notes


def identify(table: pd.DataFrame, config: IdentConfig | None = None,
             source: str | Path | None = None, show_progress: bool = False) -> Run:
    """Identify an eTS model of ``table`` (see the module docstring for the protocol).

    Parameters
    ----------
    table
        A FlightTable or any table indexed by ``t`` (s) with the needed columns.
    config
        Model and run parameters (defaults: the rate model of :mod:`etsid.ident.defaults`).
    source
        Path of the file the table came from (hashed into config.json).
    show_progress
        Draw a progress bar on stderr.

    Raises
    ------
    IdentError
        Missing columns, bad regressor spec, too few usable rows, or bad eTS parameters.
    """
    config = config or IdentConfig()
    rate_hz = config.rate_for(not config.outputs)
    chosen = _choose_model(table, config)
    spec = chosen.spec
    sigma_native = noise_std(table, spec.outputs)
    table = decimate(table, rate_hz)
    chosen.notes.append(_rate_note(table))
    reg = build(table, spec)
    n = len(reg.X)
    chosen.notes.extend(data_warnings(table, n, reg.X.shape[1], rate_model=not config.outputs))
    split = _split_index(n, config.validate)
    x_range, y_range = fixed_ranges(reg, spec, split, config.normalise)
    model = _new_model(config, spec, x_range, y_range)
    try:
        yhat, frozen_dict = _learn(model, reg, split if split < n else -1, show_progress,
                                   "identify")
    except ValueError as err:
        raise IdentError(f"bad eTS parameter: {err}") from err
    if split == n:
        frozen_dict = model.to_dict()
    frozen = ETS.from_dict(frozen_dict) if frozen_dict is not None else None
    cols = _evaluate(reg, spec, split, len(table), yhat, frozen)
    history, consequents = _history(model, reg)
    sigma = noise_std(table, spec.outputs)
    frozen_rules = frozen.n_rules if frozen is not None else 0
    metrics = {
        "n_samples": n,
        "rules": {"final": model.n_rules, "peak": int(history["n_rules"].max()),
                  "frozen": frozen_rules},
        "skipped": reg.skipped,
        "validation": _validation_info(reg, split, config.validate),
        "outputs": _metrics(reg, spec, split, cols, sigma, sigma_native),
        "sample_rate": _rate_info(table),
    }
    run_config = {
        **_run_header("identify", table, source),
        "model": {**spec.to_dict(), "inputs": chosen.inputs, "notes": chosen.notes,
                  "sample_rate": _rate_info(table)},
        "parameters": asdict(config),
        "ets": {**config.ets_params(), "normalise": config.normalise},
        "skipped": reg.skipped,
        "warnings": list(table.attrs.get("warnings") or []),
    }
    rate = _rate_info(table)
    return Run(_predictions(reg, spec, table, split, cols), jsonable(metrics), run_config,
               history, consequents, _rules_dict(frozen_dict, spec, rate),
               _rules_dict(model.to_dict(), spec, rate))


def _rate_info(table: pd.DataFrame) -> dict[str, Any]:
    """Identification rate facts of a (decimated) table for metrics/config/rules."""
    d = dict(table.attrs.get("decimation") or {})
    return {"rate_hz": d.get("rate_hz"), "native_rate_hz": d.get("native_rate_hz"),
            "factor": d.get("factor", 1), "method": d.get("method", "none"),
            "requested_hz": d.get("requested_hz")}


def _validation_info(reg: Regression, split: int, fraction: float) -> dict[str, Any]:
    n = len(reg.t)
    return {"fraction": fraction, "n_learn": split, "n_validation": n - split,
            "t_start": float(reg.t[split]) if split < n else None}


def _new_model(config: IdentConfig, spec: RegressorSpec, x_range: np.ndarray | None = None,
               y_range: np.ndarray | None = None) -> ETS:
    try:
        return ETS(**config.ets_params(), input_names=spec.input_names,
                   output_names=list(spec.outputs), x_range=x_range, y_range=y_range)
    except (ValueError, TypeError) as err:
        raise IdentError(f"bad eTS parameter: {err}") from err


def _rules_dict(data: dict[str, Any] | None, spec: RegressorSpec,
                rate: dict[str, Any] | None = None) -> dict[str, Any]:
    out = dict(data or {})
    out["regressors"] = spec.to_dict()
    if rate and rate.get("rate_hz"):
        # predict decimates another table to the same rate before applying the rules
        out["regressors"]["sample_rate_hz"] = rate["rate_hz"]
        out["regressors"]["decimation"] = rate
    return out


def load_rules(path: str | Path) -> tuple[ETS, RegressorSpec, dict[str, Any]]:
    """A rule base and its regressor spec from rules.json (or a RUN_DIR holding one).

    Raises
    ------
    IdentError
        Missing file, invalid rule base, or no regressor spec in it.
    """
    import json

    path = Path(path)
    if path.is_dir():
        path = path / "rules.json"
    if not path.exists():
        raise IdentError(f"{path}: no such rule-base file")
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise IdentError(f"{path}: not a JSON rule base ({err})") from err
    if not isinstance(data, dict) or "regressors" not in data:
        raise IdentError(f"{path}: the rule base has no 'regressors' spec; "
                         "it was not written by etsid identify")
    spec = RegressorSpec.from_dict(data["regressors"])
    try:
        model = ETS.from_dict(data)
    except ModelError as err:
        raise IdentError(f"{path}: {err}") from err
    return model, spec, data


def predict(table: pd.DataFrame, rules: str | Path, learn: bool = False,
            sim_from: float | None = None, source: str | Path | None = None,
            show_progress: bool = False) -> Run:
    """Apply a saved rule base to ``table``: one-step and free-run, optionally learning on.

    Parameters
    ----------
    table
        The flight to predict (must have the rule base's columns).
    rules
        rules.json written by :func:`identify` (or a RUN_DIR).
    learn
        Continue learning while predicting (``y_hat`` is then predict-then-learn, as in
        identify's online pass); without it the rules stay frozen.
    sim_from
        Time (s) from which the free-run simulation starts (default: the first usable row).
        The rows before it are the ARX baseline's learning part. Use identify's
        ``validation.t_start`` to reproduce its validation predictions exactly.
    source, show_progress
        As for :func:`identify`.
    """
    path = Path(rules)
    model, spec, data = load_rules(path)
    sigma_native = noise_std(table, spec.outputs)
    rate_hz = (data.get("regressors") or {}).get("sample_rate_hz")
    table = decimate(table, float(rate_hz) if rate_hz else None)
    reg = build(table, spec)
    n = len(reg.X)
    split = 0 if sim_from is None else int(np.searchsorted(reg.t, sim_from, side="left"))
    frozen = ETS.from_dict(data)
    if learn:
        yhat, _ = _learn(model, reg, -1, show_progress, "predict")
    else:
        yhat = np.asarray(frozen.predict(reg.X)).reshape(n, -1)
    cols = _evaluate(reg, spec, split, len(table), yhat, frozen)
    cols["y_val"][:split] = np.nan
    if not learn:
        cols["y_val"][split:] = yhat[split:]
    history, consequents = (_history(model, reg) if learn else
                            (pd.DataFrame(columns=["step", "t", "n_rules", "potential",
                                                   "focal_max", "focal_min"]),
                             pd.DataFrame(columns=["step", "t", "rule_id", "output", "term",
                                                   "value"])))
    sigma = noise_std(table, spec.outputs)
    peak = int(history["n_rules"].max()) if len(history) else frozen.n_rules
    metrics = {
        "n_samples": n,
        "rules": {"final": model.n_rules, "peak": max(peak, frozen.n_rules),
                  "frozen": frozen.n_rules},
        "skipped": reg.skipped,
        "validation": _validation_info(reg, split, (n - split) / n),
        "outputs": _metrics(reg, spec, split, cols, sigma, sigma_native),
        "sample_rate": _rate_info(table),
    }
    run_config = {
        **_run_header("predict", table, source),
        "rules": {"path": str(path), "sha256": sha256(path if path.is_file()
                                                      else path / "rules.json")},
        "model": {**spec.to_dict(), "inputs": {"columns": [
            c for c in spec.columns if c not in spec.outputs]}, "notes": []},
        "parameters": {"learn": learn, "sim_from": sim_from},
        "ets": {**{k: data["params"].get(k) for k in ("radius", "omega", "variant")},
                "fixed_ranges": data["params"].get("x_range") is not None}
        if isinstance(data.get("params"), dict) else {},
        "skipped": reg.skipped,
        "warnings": list(table.attrs.get("warnings") or []),
    }
    return Run(_predictions(reg, spec, table, split, cols), jsonable(metrics), run_config,
               history, consequents, data, _rules_dict(model.to_dict(), spec) if learn else None)
