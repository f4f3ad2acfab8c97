"""Rule-base JSON (schema ``etsid.rules/1``): export, schema-checked import, files.

Floats are written with Python's shortest round-trip repr, so export → import restores
every state array bit for bit: the loaded model predicts and continues learning exactly
as the original would have.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np

from etsid.errors import ModelError

SCHEMA_NAME = "etsid.rules/1"
SCHEMA_PATH = Path(__file__).with_name("rules.schema.json")
#: top-level fields the identification code may add freely
FREE_FIELDS = ("regressors", "lags")


@lru_cache(maxsize=1)
def schema() -> dict[str, Any]:
    """The JSON Schema shipped with the package."""
    return json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))


def _listify(a: Any) -> Any:
    if isinstance(a, np.ndarray):
        return a.tolist()
    return a


def model_to_dict(model: Any) -> dict[str, Any]:
    """Serialise a fitted :class:`~etsid.ets.ETS` (see ``rules.schema.json``)."""
    if not model._fitted:
        raise ModelError("cannot export a model that has not learned anything yet")
    st = model.state_
    n, R = model.n_inputs_, model.n_rules
    k = int(st["si"][0])
    params = model.get_params()
    params.pop("input_names")
    params.pop("output_names")
    for key in ("radius", "x_range", "y_range"):
        v = params[key]
        params[key] = None if v is None else _listify(np.asarray(v, dtype=float))
    params["radius"] = _listify(params["radius"])
    raw = model.consequents_raw()
    glob = model.rls == "global"
    rules = []
    for i in range(R):
        life = k - int(st["birth"][i])
        rules.append(
            {
                "id": int(st["ids"][i]),
                "focal_point": st["cz"][i].tolist(),
                "radius": st["rad"][i].tolist(),
                "scatter": st["scat"][i].tolist(),
                "potential": float(st["pot"][i]),
                "birth": int(st["birth"][i]),
                "support": int(st["support"][i]),
                "age": float(k - st["tsum"][i] / st["support"][i]),
                "utility": float(st["lamsum"][i] / (life + 1.0)),
                "firing_sum": float(st["lamsum"][i]),
                "time_sum": float(st["tsum"][i]),
                "consequent": st["Pi"][i].tolist(),
                "consequent_original_units": raw[i].tolist(),
                "covariance": None if glob else st["Cl"][i].tolist(),
            }
        )
    p = R * (n + 1)
    xin, yout = model.names_()
    return {
        "schema": SCHEMA_NAME,
        "params": params,
        "inputs": xin,
        "outputs": yout,
        "y_1d": bool(model.y_1d_),
        "normalisation": {
            "low": st["lo"].tolist(),
            "high": st["hi"].tolist(),
            "fixed": [bool(f) for f in st["fixed"]],
        },
        "learner": {
            "samples": k,
            "next_rule_id": int(st["si"][2]),
            "mean": st["mean"].tolist(),
            "m2": st["m2"].tolist(),
            "global_covariance": st["Cg"][:p, :p].tolist() if glob else None,
        },
        "rules": rules,
    }


def _fail(msg: str, source: str) -> ModelError:
    return ModelError(f"{source}: {msg}")


def _matrix(v: Any, shape: tuple[int, ...], what: str, source: str) -> np.ndarray:
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise _fail(f"{what} is not a rectangular array of numbers", source) from err
    if a.shape != shape:
        raise _fail(f"{what} has shape {a.shape}, expected {shape}", source)
    if not np.all(np.isfinite(a)):
        raise _fail(f"{what} contains non-finite numbers", source)
    return a


def model_from_dict(cls: type, data: Any, source: str = "rule base") -> Any:
    """Validate ``data`` against the schema and rebuild the model; ModelError if invalid."""
    try:
        jsonschema.validate(data, schema())
    except jsonschema.ValidationError as err:
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        raise _fail(
            f"not a valid {SCHEMA_NAME} rule base at {where}: {err.message}", source
        ) from err
    params = dict(data["params"])
    n, m = len(data["inputs"]), len(data["outputs"])
    try:
        model = cls(**params, input_names=data["inputs"], output_names=data["outputs"])
        model._init_state(n, m)
    except ValueError as err:
        raise _fail(f"invalid parameters: {err}", source) from err
    st = model.state_
    d = n + m
    norm, lrn, rules = data["normalisation"], data["learner"], data["rules"]
    st["lo"][:] = _matrix(norm["low"], (d,), "normalisation/low", source)
    st["hi"][:] = _matrix(norm["high"], (d,), "normalisation/high", source)
    fixed = norm["fixed"]
    if len(fixed) != d:
        raise _fail(f"normalisation/fixed has {len(fixed)} entries, expected {d}", source)
    st["fixed"][:] = np.array(fixed, dtype=np.int8)
    if np.any(st["hi"] < st["lo"]):
        raise _fail("normalisation/high is below normalisation/low", source)
    st["mean"][:] = _matrix(lrn["mean"], (d,), "learner/mean", source)
    st["m2"][:] = _matrix(lrn["m2"], (d,), "learner/m2", source)
    R = len(rules)
    if model.max_rules < R:
        raise _fail(f"{R} rules exceed params/max_rules = {model.max_rules}", source)
    if lrn["samples"] < R:
        raise _fail(f"{R} rules but only {lrn['samples']} samples learned", source)
    ids = [r["id"] for r in rules]
    if len(set(ids)) != R or (R and max(ids) >= lrn["next_rule_id"]):
        raise _fail("rule ids must be unique and below learner/next_rule_id", source)
    glob = model.rls == "global"
    for i, r in enumerate(rules):
        w = f"rules/{i}"
        st["ids"][i] = r["id"]
        st["cz"][i] = _matrix(r["focal_point"], (d,), f"{w}/focal_point", source)
        st["rad"][i] = _matrix(r["radius"], (n,), f"{w}/radius", source)
        if np.any(st["rad"][i] <= 0):
            raise _fail(f"{w}/radius must be positive", source)
        st["scat"][i] = _matrix(r["scatter"], (n,), f"{w}/scatter", source)
        st["pot"][i] = r["potential"]
        st["birth"][i] = r["birth"]
        st["support"][i] = r["support"]
        st["lamsum"][i] = r["firing_sum"]
        st["tsum"][i] = r["time_sum"]
        st["Pi"][i] = _matrix(r["consequent"], (n + 1, m), f"{w}/consequent", source)
        if not glob:
            if r["covariance"] is None:
                raise _fail(f"{w}/covariance is required with local RLS", source)
            st["Cl"][i] = _matrix(r["covariance"], (n + 1, n + 1), f"{w}/covariance", source)
    if glob:
        p = R * (n + 1)
        if lrn["global_covariance"] is None:
            raise _fail("learner/global_covariance is required with global RLS", source)
        st["Cg"][:p, :p] = _matrix(lrn["global_covariance"], (p, p), "learner/global_covariance",
                                   source)  # fmt: skip
    st["si"][:] = (lrn["samples"], R, lrn["next_rule_id"])
    model.y_1d_ = bool(data["y_1d"])
    if data["y_1d"] and m != 1:
        raise _fail("y_1d is true but the model has several outputs", source)
    model.extra_ = {key: data[key] for key in FREE_FIELDS if key in data}
    return model


def save(model: Any, path: str | Path, **extra: Any) -> None:
    """Write ``model`` to ``path``; ``extra`` may hold ``regressors`` and ``lags``."""
    unknown = set(extra) - set(FREE_FIELDS)
    if unknown:
        raise ValueError(f"unknown extra fields {sorted(unknown)}; allowed: {FREE_FIELDS}")
    data = model_to_dict(model)
    data.update(getattr(model, "extra_", {}))
    data.update(extra)
    try:
        text = json.dumps(data, indent=1, allow_nan=False)
    except ValueError as err:
        raise ModelError(f"{path}: the model holds non-finite numbers, not saved") from err
    Path(path).write_text(text + "\n", encoding="utf-8")


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed in a rule base")


def load(cls: type, path: str | Path) -> Any:
    """Read and validate a rule-base file written by :func:`save`."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"), parse_constant=_no_constant)
    except OSError as err:
        raise ModelError(f"{p}: cannot read rule base ({err.strerror or err})") from err
    except (UnicodeDecodeError, ValueError) as err:
        raise ModelError(
            f"{p}: not a JSON file ({err}); expected a {SCHEMA_NAME} rule base"
        ) from err
    return model_from_dict(cls, data, source=str(p))
