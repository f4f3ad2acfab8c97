"""One schema per file etsid writes and reads back, checked before the content is used.

A table's attrs (Parquet metadata ``etsid.attrs`` or the CSV sidecar), a run folder's
``metrics.json`` and ``config.json``, a batch folder's ``batch.json`` and result rows are
validated here with JSON Schema (``rules.json`` and ``gap.json`` ship their own schema
files: etsid/ets/rules.schema.json, etsid/gap/gap.schema.json; a vehicle file is checked
field by field against etsid/sim/vehicle_params.py). The schemas type every field etsid's
code reads and leave the rest open, so files written by older versions still load; a
wrong type or a value out of range is one line naming the file and the field, never an
internal error later.

Sizes are bounded too: strings, lists and objects have a ``max*`` each, and the documents
were already read within the byte and depth bounds of :mod:`etsid.files`.
"""

from __future__ import annotations

import math
from typing import Any

from etsid.errors import EtsidError

STR = {"type": "string", "maxLength": 100_000}
NAME = {"type": "string", "maxLength": 1000}
NUM = {"type": "number"}
NUM_OR_NULL = {"type": ["number", "null"]}
POS_OR_NULL = {"type": ["number", "null"], "exclusiveMinimum": 0}
INT = {"type": "integer"}
BOOL = {"type": "boolean"}
OBJ = {"type": "object", "maxProperties": 100_000}
LIST = {"type": "array", "maxItems": 10_000_000}


def _list_of(item: dict[str, Any], most: int = 1_000_000) -> dict[str, Any]:
    return {"type": "array", "items": item, "maxItems": most}


def _map_of(value: dict[str, Any], most: int = 100_000) -> dict[str, Any]:
    return {"type": "object", "additionalProperties": value, "maxProperties": most}


def _object(required: tuple[str, ...] = (), **properties: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "properties": properties, "required": list(required),
            "maxProperties": 100_000}


TABLE_ATTRS = _object(
    source=NAME, format=NAME, start_time=NUM_OR_NULL, rate_hz=POS_OR_NULL,
    physics_hz=POS_OR_NULL, command_log=NAME,
    reference={"type": ["string", "null"], "maxLength": 1000},
    mapping=_map_of({"type": ["string", "null"], "maxLength": 1000}),
    signals=_map_of(_object(source=NAME, count=INT, rate_hz=NUM_OR_NULL)),
    dropped=_list_of(OBJ), repaired=_list_of(_object(reason=STR, count=INT, signal=NAME)),
    gaps=_list_of(_object(start=NUM, end=NUM, signal=NAME, column=NAME)),
    warnings=_list_of(STR, 100_000), log=OBJ, vehicle=NAME, autopilot=NAME, firmware=NAME,
    hardware=NAME, scenario=NAME, rotor_radius_m={"type": "number", "exclusiveMinimum": 0},
    seed=INT, ground_effect=BOOL, params=OBJ, noise=OBJ, hover_command=NUM,
    motor_layout=_object(x=_list_of(NUM, 64), y=_list_of(NUM, 64), spin=_list_of(NUM, 64)),
    decimation=OBJ, input_selection=OBJ, replay_mode=NAME, replay_of=NAME,
)
"""``table.attrs`` as saved with a table (etsid/table.py)."""

_FIT = {"type": ["number", "null"]}
_METRIC = _object(rmse=_FIT, ndei=_FIT, vaf=_FIT, fit=_FIT, n=INT)
METRICS = _object(
    ("outputs",),
    n_samples=INT, rules={"type": ["object", "integer"]}, skipped={"type": ["object",
                                                                            "integer"]},
    validation=OBJ, flight=_object(warnings=_list_of(STR, 100_000)),
    outputs=_map_of(_object(
        unit={"type": ["string", "null"], "maxLength": 1000}, noise_std=NUM_OR_NULL,
        online=_METRIC, validation=_object(one_step=_METRIC, free_run=OBJ), arx=OBJ,
        persistence=OBJ), 1000),
    sample_rate={"type": ["number", "null", "object"]}, regimes={"type": ["object", "array",
                                                                         "null"]},
    warnings=_list_of(STR, 100_000),
)
"""A run folder's metrics.json (etsid/ident/rundir.py)."""

CONFIG = _object(
    schema=NAME, command=NAME, kind=NAME, etsid_version=NAME, created=NAME,
    input=_object(path={"type": ["string", "null"], "maxLength": 10_000},  # null: a table in memory
                  sha256={"type": ["string", "null"], "maxLength": 200}),
    model=_object(outputs=_list_of(NAME, 1000)), parameters=OBJ, ets=OBJ, skipped=OBJ,
    warnings=_list_of(STR, 100_000),
)
"""A run folder's config.json."""

_COUNT = {"type": ["integer", "null"], "minimum": 0}
BATCH = _object(
    ("command",),
    schema=NAME, command=NAME, options_digest=NAME, options=OBJ, inputs=_COUNT, jobs=_COUNT,
    scheduler=NAME, resume=BOOL, retry_failed=BOOL, started=NAME, ended=NAME, ok=_COUNT,
    failed=_COUNT, skipped=_COUNT, wall_s={"type": ["number", "null"], "minimum": 0},
    finished={"type": ["string", "null"], "maxLength": 1000},
)
"""A batch folder's batch.json (etsid/batch/run.py)."""


def validate(document: Any, schema: dict[str, Any], source: object,
             error: type[EtsidError] = EtsidError, what: str = "file") -> Any:
    """``document`` when it satisfies ``schema``; else one line naming ``source``, the
    field (``outputs.co2.unit``) and what is wrong.

    Raises
    ------
    EtsidError
        (``error``) The first violation, in the order jsonschema finds most relevant.
    """
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema)
    worst = jsonschema.exceptions.best_match(validator.iter_errors(document))
    if worst is None:
        return document
    where = ".".join(str(p) for p in worst.absolute_path) or "(top level)"
    message = worst.message if len(worst.message) <= 160 else worst.message[:157] + "..."
    raise error(f"{source}: {what} field {where}: {message}")


def finite_or_none(value: Any) -> float | None:
    """``value`` as a finite float, else None (NaN, ±inf, ±1e308 overflowing sums, text)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    value = float(value)
    return value if math.isfinite(value) else None
