"""RUN_DIR: the files an identification or prediction run writes, and reading them back.

``predictions.parquet``, ``history.parquet``, ``consequents.parquet``, ``rules.json``,
``rules_final.json`` (identify only), ``metrics.json`` and ``config.json``; see
docs/identify.md for the contract.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import hashlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from etsid import __version__
from etsid.errors import IdentError
from etsid.escape import clean, printable
from etsid.files import open_binary, read_json, read_parquet_frame
from etsid.files import sha256 as file_sha256
from etsid.schemas import CONFIG, METRICS, validate

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ident.regressors import RegressorSpec

FILES = ("predictions.parquet", "history.parquet", "metrics.json", "config.json", "rules.json")


@dataclass
class Run:
    """Everything a run produced, in memory.

    Attributes
    ----------
    predictions : DataFrame
        Column ``t`` (s), ``segment``, ``part`` and per output ``y``, ``y_hat``, ``y_val``,
        ``y_sim``, ``y_arx``, ``y_arx_sim``.
    metrics, config : dict
        Contents of metrics.json and config.json.
    history : DataFrame
        Per learned sample: step, t, n_rules, potential, focal_max, focal_min, events.
    consequents : DataFrame
        Long format: step, t, rule_id, output, term, value.
    rules : dict
        The rule base of rules.json (schema etsid.rules/2, with ``regressors``).
    rules_final : dict or None
        The rule base after the online pass over the whole log.
    """

    predictions: pd.DataFrame
    metrics: dict[str, Any]
    config: dict[str, Any]
    history: pd.DataFrame
    consequents: pd.DataFrame
    rules: dict[str, Any]
    rules_final: dict[str, Any] | None = None
    extra: dict[str, Any] = field(default_factory=dict)


def sha256(path: str | Path) -> str:
    """SHA-256 of a file (hex), or of every file below a directory in name order."""
    path = Path(path)
    digest = hashlib.sha256()
    if not path.is_dir():
        return file_sha256(path, IdentError)
    for item in sorted(p for p in path.rglob("*") if p.is_file()):
        with open_binary(item, "hash", IdentError) as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()


def jsonable(obj: Any) -> Any:
    """Plain JSON types; NaN/inf become None, numpy scalars and arrays become Python."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def run_header(command: str, table: pd.DataFrame, source: str | Path | None
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


def rules_json(data: dict[str, Any] | None, spec: RegressorSpec,
               rate: dict[str, Any] | None = None,
               rotor_radius_m: float | None = None,
               fallback: dict[str, Any] | None = None) -> dict[str, Any]:
    """rules.json: the rule base ``data`` (``ETS.to_dict``) with the regressor spec and
    the identification rate that :func:`etsid.ident.predict` needs to apply it, the
    rotor radius (m) of the vehicle it was learnt on when known (its regime bands in z/R),
    and the per-output fall-back identify chose (:mod:`etsid.ident.fallback`), if any."""
    out = dict(data or {})
    if fallback:
        out["fallback"] = fallback
    out["regressors"] = spec.to_dict()
    if rotor_radius_m:
        out["regressors"]["rotor_radius_m"] = float(rotor_radius_m)
    if rate and rate.get("rate_hz"):
        # predict decimates another table to the same rate before applying the rules
        out["regressors"]["sample_rate_hz"] = rate["rate_hz"]
        out["regressors"]["decimation"] = rate
    return out


RUN_FILES = (*FILES, "consequents.parquet", "rules_final.json")
"""Every file :func:`write_run` may write: a new run replaces them all as one."""

LOCK = ".etsid-run.lock"
"""Lock file in a RUN_DIR, held while a finished run is moved in."""


def _dump(data: dict[str, Any], path: Path) -> None:
    path.write_text(json.dumps(jsonable(data), indent=2) + "\n")


def _parquet(frame: pd.DataFrame, path: Path) -> None:
    """``frame`` as parquet without dictionary encoding: measured floats and step counters
    rarely repeat, so the dictionary pyarrow builds by default is dropped again (the
    predictions file took 2–3× as long to write, and was larger)."""
    frame.to_parquet(path, index=False, use_dictionary=False)


def _write_files(run: Run, out: Path) -> None:
    _parquet(run.predictions, out / "predictions.parquet")
    _parquet(run.history, out / "history.parquet")
    _parquet(run.consequents, out / "consequents.parquet")
    # rules.json is written with plain json (not jsonable) so floats round-trip exactly
    (out / "rules.json").write_text(json.dumps(run.rules, indent=1) + "\n")
    if run.rules_final is not None:
        (out / "rules_final.json").write_text(json.dumps(run.rules_final, indent=1) + "\n")
    _dump(run.metrics, out / "metrics.json")
    _dump(run.config, out / "config.json")


@contextlib.contextmanager
def _locked(directory: Path) -> Iterator[None]:
    """An exclusive lock on ``directory`` (``flock`` of :data:`LOCK`; none where there is
    no ``fcntl``): two runs finishing into one RUN_DIR move their files in one at a time."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    with open(directory / LOCK, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def os_reason(err: OSError) -> str:
    """The cause of a failed write in a few words (``No space left on device``), also for
    the errors pyarrow raises, which carry the errno only in their text."""
    found = re.search(r"\[errno (\d+)\]", str(err), flags=re.IGNORECASE)
    if found:
        return os.strerror(int(found.group(1)))
    if err.strerror:
        return err.strerror
    text = str(err).strip().splitlines()
    return text[0] if text else type(err).__name__


def os_errno(err: OSError) -> int | None:
    """The errno of an OSError, also when only its text has it (pyarrow)."""
    found = re.search(r"\[errno (\d+)\]", str(err), flags=re.IGNORECASE)
    return int(found.group(1)) if found else err.errno


def write_run(run: Run, out: str | Path) -> Path:
    """Write ``run`` into the directory ``out`` (created if needed) whole; returns it.

    The files are written into a private staging folder inside ``out`` and moved into
    place under a lock, replacing every file of an earlier run: two runs into one
    ``--out`` never mix their files, and a run that fails (a full disk) leaves the
    earlier run as it was and no partial file.

    Raises
    ------
    IdentError
        The directory or a file cannot be written (one line, e.g. no space left).
    """
    out = Path(out)
    staging: Path | None = None
    try:
        out.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=".run-", dir=out))
        _write_files(run, staging)
        written = {p.name for p in staging.iterdir()}
        with _locked(out):
            for name in RUN_FILES:
                if name in written:
                    os.replace(staging / name, out / name)
                else:  # an earlier run's file this run does not have
                    (out / name).unlink(missing_ok=True)
    except OSError as err:
        raise IdentError(f"{out}: cannot write the run directory ({os_reason(err)})"
                         ) from err
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
    return out


def read_run(path: str | Path) -> Run:
    """Read a RUN_DIR written by :func:`write_run`.

    Raises
    ------
    IdentError
        Not a directory, or a required file is missing or unreadable.
    """
    path = Path(path)
    if not path.is_dir():
        raise IdentError(f"{path}: not a run directory (run `etsid identify LOG --out {path}`)")
    missing = [name for name in FILES if not (path / name).exists()]
    if missing:
        raise IdentError(f"{path}: not a complete run directory, missing {', '.join(missing)}")
    try:
        predictions = read_parquet_frame(path / "predictions.parquet", "table", IdentError)
        history = read_parquet_frame(path / "history.parquet", "table", IdentError)
        cons_path = path / "consequents.parquet"
        consequents = (read_parquet_frame(cons_path, "table", IdentError) if cons_path.exists()
                       else pd.DataFrame())
    except (OSError, ValueError) as err:
        raise IdentError(f"{path}: unreadable run file ({err})") from err
    metrics = clean(validate(read_json(path / "metrics.json", "run", IdentError),
                             METRICS, path / "metrics.json", IdentError, "metrics.json"))
    config = clean(validate(read_json(path / "config.json", "run", IdentError),
                            CONFIG, path / "config.json", IdentError, "config.json"))
    rules = clean(read_json(path / "rules.json", "rules", IdentError))
    final_path = path / "rules_final.json"
    rules_final = (clean(read_json(final_path, "rules", IdentError)) if final_path.exists()
                   else None)
    predictions.columns = [printable(c) if isinstance(c, str) else c
                           for c in predictions.columns]
    outputs = metrics.get("outputs") if isinstance(metrics, dict) else None
    if not isinstance(outputs, dict) or not outputs:
        raise IdentError(f"{path}: metrics.json has no 'outputs' (not written by etsid)")
    need = ["t"] + [f"{y}{suffix}" for y in outputs for suffix in ("", "_hat")]
    absent = [c for c in need if c not in predictions.columns]
    if absent:
        raise IdentError(f"{path}: predictions.parquet lacks column(s) {', '.join(absent)}")
    return Run(predictions, metrics, config, history, consequents, rules, rules_final)
