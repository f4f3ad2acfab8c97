"""gap.json (schema ``etsid.gap/1``): build, validate against the shipped schema, write."""

from __future__ import annotations

import json
import math
from functools import cache
from pathlib import Path
from typing import Any

import jsonschema

from etsid.errors import GapError
from etsid.escape import clean as printable_strings
from etsid.files import read_json

SCHEMA_NAME = "etsid.gap/1"
SCHEMA_PATH = Path(__file__).with_name("gap.schema.json")


@cache
def schema() -> dict[str, Any]:
    """The JSON Schema of gap.json, its effect-name enum from the effect registry
    (:func:`etsid.gap.effects.vocabulary`; the shipped file carries the same list for
    readers without etsid, and a test keeps the two equal)."""
    from etsid.gap.effects import vocabulary

    data = read_json(SCHEMA_PATH, "package", GapError)
    data["properties"]["effects"]["items"]["properties"]["name"]["enum"] = list(vocabulary())
    return data


def clean(value: Any) -> Any:
    """JSON-safe copy: numpy scalars to Python, non-finite floats to None, tuples to lists."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [clean(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, str):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def validate(data: dict[str, Any]) -> None:
    """Raise :class:`GapError` if ``data`` does not follow the gap.json schema."""
    try:
        jsonschema.validate(data, schema())
    except jsonschema.ValidationError as err:
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        raise GapError(f"gap.json would not follow {SCHEMA_NAME} at {where}: "
                       f"{err.message}") from err


def write_gap_json(data: dict[str, Any], out_dir: str | Path) -> Path:
    """Validate ``data`` and write it to ``out_dir/gap.json``."""
    data = clean(data)
    validate(data)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
        path = out / "gap.json"
        path.write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    except OSError as err:
        raise GapError(f"{out}: cannot write gap.json ({err.strerror})") from err
    return path


def load_gap_json(path: str | Path) -> dict[str, Any]:
    """Read and validate a gap.json."""
    data = read_json(path, "gap", GapError, "gap.json")
    validate(data)
    return printable_strings(data)
