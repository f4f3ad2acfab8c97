"""Rule-base JSON (schema ``etsid.rules/2``; ``etsid.rules/1`` files still load):
export, schema-checked import, files.

Version 2 adds ``antecedents`` (scheduled or not, the names and the dimension of the
antecedent inputs); a version-1 file is an unscheduled model (antecedents = inputs).

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
from etsid.ets.state import LearnedState
from etsid.files import read_bytes, read_text

SCHEMA_NAME = "etsid.rules/2"
#: versions this module reads (it writes :data:`SCHEMA_NAME`)
SCHEMA_NAMES = ("etsid.rules/1", "etsid.rules/2")
MAX_FILE_BYTES = 100 * 2**20
"""A rules.json larger than this is refused before it is read (bounded memory and time)."""
MAX_RULES = 1000
"""Most rules a rule base may hold or allow (``params/max_rules``), as ``--max-rules``."""
MAX_VALUES = 10_000_000
"""Values (numbers, strings, … counted by their commas before parsing) a rule-base file may
hold: 320 MB of parsed floats at most. A global covariance of 150 rules of 20 regressors
holds 9.5 million."""
MAX_KEYS = 100_000
"""Keys a rule base may have in all (1000 rules of 16 keys: 16 000), counted before
parsing; and in one object."""
MAX_MESSAGE_CHARS = 300
"""Length of what an error message quotes of a rule base."""
MAX_ABS_NUMBER = 1e100
"""Numbers beyond ±this (and integers beyond 64 bits) are refused: no model state is that
large, and numpy would overflow on them."""
SCHEMA_PATH = Path(__file__).with_name("rules.schema.json")
#: top-level fields the identification code may add freely
FREE_FIELDS = ("regressors", "lags")


@lru_cache(maxsize=1)
def schema() -> dict[str, Any]:
    """The JSON Schema shipped with the package."""
    return json.loads(read_text(SCHEMA_PATH, "package", ModelError))


def _listify(a: Any) -> Any:
    if isinstance(a, np.ndarray):
        return a.tolist()
    return a


def model_to_dict(model: Any) -> dict[str, Any]:
    """Serialise a fitted :class:`~etsid.ets.ETS` (see ``rules.schema.json``)."""
    try:
        state = model.export_state()
    except ValueError as err:
        raise ModelError("cannot export a model that has not learned anything yet") from err
    R, k = state.n_rules, state.samples
    params = model.get_params()
    params.pop("input_names")
    params.pop("output_names")
    params.pop("antecedent_names")
    for key in ("radius", "x_range", "y_range", "s_range"):
        v = params[key]
        params[key] = None if v is None else _listify(np.asarray(v, dtype=float))
    params["radius"] = _listify(params["radius"])
    params["shared_outputs"] = [int(o) for o in params["shared_outputs"]]
    raw = model.consequents_raw()
    age, utility = state.age(), state.utility()
    rules = []
    for i in range(R):
        rules.append(
            {
                "id": int(state.rule_ids[i]),
                "focal_point": state.focal_points[i].tolist(),
                "radius": state.radii[i].tolist(),
                "scatter": state.scatter[i].tolist(),
                "potential": float(state.potentials[i]),
                "birth": int(state.births[i]),
                "support": int(state.support[i]),
                "age": float(age[i]),
                "utility": float(utility[i]),
                "firing_sum": float(state.firing_sums[i]),
                "time_sum": float(state.time_sums[i]),
                "consequent": state.consequents[i].tolist(),
                "consequent_original_units": raw[i].tolist(),
                "covariance": None if state.covariances is None
                else state.covariances[i].tolist(),
            }
        )
    xin, yout = model.names()
    return {
        "schema": SCHEMA_NAME,
        "params": params,
        "inputs": xin,
        "outputs": yout,
        "antecedents": {
            "scheduled": bool(state.scheduled),
            "names": model.antecedents(),
            "dimension": int(model.n_antecedents_),
        },
        "y_1d": state.y_1d,
        "normalisation": {
            "low": state.low.tolist(),
            "high": state.high.tolist(),
            "fixed": [bool(f) for f in state.fixed],
        },
        "learner": {
            "samples": k,
            "next_rule_id": state.next_rule_id,
            "mean": state.mean.tolist(),
            "m2": state.m2.tolist(),
            "global_covariance": None if state.global_covariance is None
            else state.global_covariance.tolist(),
            "shared_covariance": None if state.shared_covariance is None
            else state.shared_covariance.tolist(),
        },
        "rules": rules,
    }


def _fail(msg: str, source: str) -> ModelError:
    text = msg if len(msg) <= MAX_MESSAGE_CHARS else msg[:MAX_MESSAGE_CHARS] + " …"
    return ModelError(f"{source}: {' '.join(text.split())}")


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


def check_caps(data: Any, source: str) -> None:
    """Cheap checks made before the schema check, so that its time and memory stay bounded.

    Refuses a rule list longer than :data:`MAX_RULES`, ``params/max_rules`` beyond it,
    integers beyond 64 bits and numbers beyond :data:`MAX_ABS_NUMBER` or non-finite.
    """
    if not isinstance(data, dict):
        raise _fail(f"not a {SCHEMA_NAME} rule base (the top level is not an object)", source)
    rules = data.get("rules")
    if isinstance(rules, list):
        if len(rules) > MAX_RULES:
            raise _fail(f"{len(rules)} rules, more than the {MAX_RULES} a rule base may hold",
                        source)
        if not rules:
            raise _fail("the rule base holds no rules (nothing to predict with)", source)
    params = data.get("params")
    if isinstance(params, dict):
        cap = params.get("max_rules")
        if isinstance(cap, (int, float)) and not isinstance(cap, bool) and not (
                1 <= cap <= MAX_RULES):
            text = str(cap)
            shown = text if len(text) <= 20 else f"{text[:12]}… ({len(text)} digits)"
            raise _fail(f"params/max_rules = {shown} is outside 1…{MAX_RULES}", source)
    check_shapes(data, source)
    stack: list[tuple[str, Any]] = [("", data)]
    while stack:
        where, node = stack.pop()
        if isinstance(node, dict):
            if len(node) > MAX_KEYS:
                raise _fail(f"the object at {where or '/'} has {len(node)} keys, more than "
                            f"the {MAX_KEYS} a rule base has", source)
            stack.extend((f"{where}/{k}", v) for k, v in node.items())
        elif isinstance(node, list):
            stack.extend((f"{where}/{i}", v) for i, v in enumerate(node))
        elif isinstance(node, bool) or node is None or isinstance(node, str):
            continue
        elif isinstance(node, int):
            if not -(2**63) <= node < 2**63:
                raise _fail(f"the integer at {where or '/'} does not fit in 64 bits", source)
        elif isinstance(node, float) and not (abs(node) <= MAX_ABS_NUMBER):
            raise _fail(f"the number at {where or '/'} is {node!r}, beyond "
                        f"±{MAX_ABS_NUMBER:.0e}", source)


def _length(data: Any, path: str) -> int | None:
    """Length of the list at the slash-separated ``path`` of ``data`` (None: not a list)."""
    node = data
    for key in path.split("/"):
        if isinstance(node, dict):
            node = node.get(key)
        elif isinstance(node, list) and key.isdigit() and int(key) < len(node):
            node = node[int(key)]
        else:
            return None
    return len(node) if isinstance(node, list) else None


def check_shapes(data: dict[str, Any], source: str) -> None:
    """Lengths of the arrays against the sizes the rule base declares (its inputs, outputs,
    antecedent dimension and rule count), checked before anything walks the arrays: a
    focal point of millions of numbers is refused at once, not after the schema check
    has gone through it. Fields of the wrong kind are left to the schema check."""
    if len(data) > MAX_KEYS:
        raise _fail(f"the top level has {len(data)} keys; a rule base has about 10", source)
    n, m = _length(data, "inputs"), _length(data, "outputs")
    rules = data.get("rules")
    if n is None or m is None or not isinstance(rules, list):
        return
    ante = data.get("antecedents")
    scheduled = isinstance(ante, dict) and ante.get("scheduled") is True
    na = ante.get("dimension") if scheduled else n  # type: ignore[union-attr]
    if not isinstance(na, int) or isinstance(na, bool) or not 0 <= na <= MAX_KEYS:
        return
    d = na + m + (n if scheduled else 0)
    sizes: dict[str, tuple[int, int | None]] = {
        "normalisation/low": (d, None), "normalisation/high": (d, None),
        "normalisation/fixed": (d, None), "learner/mean": (d, None), "learner/m2": (d, None),
        "learner/global_covariance": (len(rules) * (n + 1), len(rules) * (n + 1)),
        "learner/shared_covariance": (n + 1, n + 1),
    }
    if scheduled:
        sizes["antecedents/names"] = (na, None)
    for i in range(len(rules)):
        sizes.update({f"rules/{i}/focal_point": (d, None), f"rules/{i}/radius": (na, None),
                      f"rules/{i}/scatter": (na, None), f"rules/{i}/consequent": (n + 1, m),
                      f"rules/{i}/consequent_original_units": (n + 1, m),
                      f"rules/{i}/covariance": (n + 1, n + 1)})
    for path, (rows, cols) in sizes.items():
        got = _length(data, path)
        if got is not None and got != rows:
            raise _fail(f"{path} has the wrong shape: {got} entries, expected {rows} (from "
                        f"the rule base's {n} inputs, {m} outputs and {len(rules)} rules)",
                        source)
        if got and cols is not None:
            for j in range(rows):
                width = _length(data, f"{path}/{j}")
                if width is not None and width != cols:
                    raise _fail(f"{path}/{j} has the wrong shape: {width} entries, expected "
                                f"{cols}", source)


def model_from_dict(cls: type, data: Any, source: str = "rule base",
                    trusted: bool = False) -> Any:
    """Validate ``data`` against the schema and rebuild the model; ModelError if invalid.
    ``trusted`` (a dict made in this process, or one already validated) skips the cap and
    schema checks; the shape and consistency checks below always run."""
    if not trusted:
        check_caps(data, source)
        try:
            jsonschema.validate(data, schema())
        except jsonschema.ValidationError as err:
            where = "/".join(str(p) for p in err.absolute_path)[:200] or "(top level)"
            raise _fail(
                f"not a valid {SCHEMA_NAME} rule base at {where}: {err.message[:200]}", source
            ) from err
    params = dict(data["params"])
    n, m = len(data["inputs"]), len(data["outputs"])
    ante = data.get("antecedents") or {"scheduled": False}
    scheduled = bool(ante["scheduled"])
    na = int(ante["dimension"]) if scheduled else n
    if scheduled and len(ante["names"]) != na:
        raise _fail(f"antecedents/names has {len(ante['names'])} entries, expected {na}",
                    source)
    model = cls(**params, input_names=data["inputs"], output_names=data["outputs"],
                antecedent_names=ante["names"] if scheduled else None)
    d = na + m + (n if scheduled else 0)
    norm, lrn, rules = data["normalisation"], data["learner"], data["rules"]
    low = _matrix(norm["low"], (d,), "normalisation/low", source)
    high = _matrix(norm["high"], (d,), "normalisation/high", source)
    fixed = norm["fixed"]
    if len(fixed) != d:
        raise _fail(f"normalisation/fixed has {len(fixed)} entries, expected {d}", source)
    if np.any(high < low):
        raise _fail("normalisation/high is below normalisation/low", source)
    mean = _matrix(lrn["mean"], (d,), "learner/mean", source)
    m2 = _matrix(lrn["m2"], (d,), "learner/m2", source)
    R = len(rules)
    if model.max_rules < R:
        raise _fail(f"{R} rules exceed params/max_rules = {model.max_rules}", source)
    if lrn["samples"] < R:
        raise _fail(f"{R} rules but only {lrn['samples']} samples learned", source)
    ids = [r["id"] for r in rules]
    if len(set(ids)) != R or (R and max(ids) >= lrn["next_rule_id"]):
        raise _fail("rule ids must be unique and below learner/next_rule_id", source)
    glob = model.rls == "global"
    focal, radii, scatter, consequents, covariances = [], [], [], [], []
    for i, r in enumerate(rules):
        w = f"rules/{i}"
        focal.append(_matrix(r["focal_point"], (d,), f"{w}/focal_point", source))
        radii.append(_matrix(r["radius"], (na,), f"{w}/radius", source))
        if np.any(radii[-1] <= 0):
            raise _fail(f"{w}/radius must be positive", source)
        scatter.append(_matrix(r["scatter"], (na,), f"{w}/scatter", source))
        consequents.append(_matrix(r["consequent"], (n + 1, m), f"{w}/consequent", source))
        if not glob:
            if r["covariance"] is None:
                raise _fail(f"{w}/covariance is required with local RLS", source)
            covariances.append(_matrix(r["covariance"], (n + 1, n + 1), f"{w}/covariance",
                                       source))
    global_covariance = None
    if glob:
        p = R * (n + 1)
        if lrn["global_covariance"] is None:
            raise _fail("learner/global_covariance is required with global RLS", source)
        global_covariance = _matrix(lrn["global_covariance"], (p, p),
                                    "learner/global_covariance", source)
    if data["y_1d"] and m != 1:
        raise _fail("y_1d is true but the model has several outputs", source)
    shared_covariance = None
    if params.get("shared_outputs"):
        if lrn.get("shared_covariance") is None:
            raise _fail("learner/shared_covariance is required with params/shared_outputs",
                        source)
        shared_covariance = _matrix(lrn["shared_covariance"], (n + 1, n + 1),
                                    "learner/shared_covariance", source)

    def stack(rows: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
        return np.array(rows) if rows else np.zeros((0, *shape))

    state = LearnedState(
        n_inputs=n, n_outputs=m, y_1d=bool(data["y_1d"]), samples=lrn["samples"],
        next_rule_id=lrn["next_rule_id"], low=low, high=high,
        fixed=np.array(fixed, dtype=np.int8), mean=mean, m2=m2,
        rule_ids=np.array(ids, dtype=np.int64), focal_points=stack(focal, (d,)),
        radii=stack(radii, (na,)), scatter=stack(scatter, (na,)),
        potentials=np.array([r["potential"] for r in rules], dtype=np.float64),
        births=np.array([r["birth"] for r in rules], dtype=np.int64),
        support=np.array([r["support"] for r in rules], dtype=np.int64),
        firing_sums=np.array([r["firing_sum"] for r in rules], dtype=np.float64),
        time_sums=np.array([r["time_sum"] for r in rules], dtype=np.float64),
        consequents=stack(consequents, (n + 1, m)),
        covariances=None if glob else stack(covariances, (n + 1, n + 1)),
        global_covariance=global_covariance, scheduled=scheduled, n_antecedents=na,
        shared_covariance=shared_covariance,
    )
    try:
        model.restore_state(state)
    except ValueError as err:
        raise _fail(f"invalid parameters: {err}", source) from err
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


def read_document(path: str | Path) -> Any:
    """The JSON document in a rule-base file, read within bounds.

    Raises
    ------
    ModelError
        Missing, unreadable or larger than :data:`MAX_FILE_BYTES`; not JSON; nested too
        deeply; NaN/Infinity constants. Names the file.
    """
    p = Path(path)
    raw = read_bytes(p, "rules", ModelError)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ModelError(f"{p}: not a JSON file ({err}); expected a {SCHEMA_NAME} rule base"
                         ) from err
    values, keys = text.count(",") + 1, text.count('":')
    if values > MAX_VALUES or keys > MAX_KEYS:
        what = (f"about {values} values, more than the {MAX_VALUES}" if values > MAX_VALUES
                else f"about {keys} keys, more than the {MAX_KEYS}")
        raise ModelError(f"{p}: {what} a rule base may hold")
    try:
        return json.loads(text, parse_constant=_no_constant)
    except RecursionError as err:
        raise ModelError(f"{p}: JSON nested too deeply; expected a {SCHEMA_NAME} rule base"
                         ) from err
    except ValueError as err:
        first = str(err).splitlines()[0][:200] if str(err) else type(err).__name__
        raise ModelError(
            f"{p}: not a JSON file ({first}); expected a {SCHEMA_NAME} rule base"
        ) from err


def load(cls: type, path: str | Path) -> Any:
    """Read and validate a rule-base file written by :func:`save`."""
    return model_from_dict(cls, read_document(path), source=str(path))
