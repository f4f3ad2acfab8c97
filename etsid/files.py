"""One way to open every file etsid reads.

Logs, tables and their sidecars, vehicle files, rule bases, run and batch folders' JSON,
list files, mapping files, bag metadata, figures and the package's own schemas are all
opened here. Every open:

- follows links, then refuses anything that is not a regular file by its type (a FIFO
  never ends, ``/dev/zero`` never ends, a socket blocks) and anything under ``/proc`` or
  ``/sys`` (their "regular" files are generated without end or size);
- opens with ``O_NONBLOCK`` and checks the type again on the open descriptor, so a file
  swapped for a FIFO between the check and the open cannot block;
- reads at most the byte bound of its kind (:data:`LIMITS`): a vehicle file is a few
  kilobytes, a rule base at most 100 MiB, a log has no bound here (its reader reads it in
  bounded pieces);
- raises the caller's own error class (:class:`~etsid.errors.EtsidError` subclass) with one
  line naming the file and what is wrong.

JSON and TOML documents are parsed here too, with depth bounds and without NaN/Infinity
constants. A test (tests/test_files.py) walks the package source and fails if a file is
opened any other way outside this module.

Import-light on purpose: standard library only (pyarrow and pandas are imported inside the
functions that read tables).
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from etsid.errors import EtsidError

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa

MIB = 1 << 20
LIMITS: dict[str, int | None] = {
    "log": None,
    "table": None,
    "hash": None,
    "sidecar": 16 * MIB,
    "vehicle": 1 * MIB,
    "mapping": 1 * MIB,
    "rules": 100 * MIB,
    "run": 64 * MIB,
    "batch": 16 * MIB,
    "gap": 64 * MIB,
    "list": 16 * MIB,
    "bag-metadata": 16 * MIB,
    "figure": 64 * MIB,
    "package": 16 * MIB,
    "calibration": 1 * MIB,
}
"""Bytes etsid reads of one file of each kind (``None``: streamed or read in bounded pieces
by its reader). A vehicle file or a mapping is a few kB; a sidecar or batch.json well under
1 MiB; run-folder JSON grows with the rule history (a 1-hour flight: a few MiB)."""

WORDS: dict[str, str] = {
    "log": "logs", "table": "tables", "hash": "inputs", "sidecar": "table sidecars",
    "vehicle": "vehicle files", "mapping": "mapping files", "rules": "rule bases",
    "run": "run folders' files", "batch": "batch folders' files", "gap": "gap reports",
    "list": "lists of inputs", "bag-metadata": "bag metadata files", "figure": "figures",
    "package": "package files", "calibration": "calibration files",
}
REFUSED_ROOTS = ("/proc", "/sys")
"""Pseudo file systems whose "regular" files are generated, without end or size."""
MAX_DEPTH = 64
"""Nesting a JSON or TOML document etsid reads may have (its own files nest < 10 deep)."""


def special_kind(mode: int) -> str:
    """What a file that is not a regular file is (its ``st_mode``), in words."""
    kinds = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
             (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
             (stat.S_ISDIR, "a directory"))
    return next((name for test, name in kinds if test(mode)), "a special file")


def _size(n: int) -> str:
    return f"{n / MIB:.0f} MiB" if n >= MIB else f"{n / 1024:.0f} KiB"


def _refuse(path: Path, kind: str, mode: int, size: int, real: str,
            error: type[EtsidError]) -> None:
    words = WORDS.get(kind, "files")
    if not stat.S_ISREG(mode):
        raise error(f"{path}: not a regular file but {special_kind(mode)}: {words} are "
                    "read from regular files")
    if any(real == root or real.startswith(root + "/") for root in REFUSED_ROOTS):
        raise error(f"{path}: a file of {real.split('/')[1]}/ (generated, without end): "
                    f"{words} are read from regular files")
    limit = LIMITS.get(kind)
    if limit is not None and size > limit:
        raise error(f"{path}: {_size(size)} is too large for one of the {words} (limit "
                    f"{_size(limit)})")


def check(path: str | Path, kind: str, error: type[EtsidError] = EtsidError) -> Path:
    """``path`` when it is a regular file of at most the bound of ``kind``.

    For the libraries that open a path themselves (pymavlink, pyulog, rosbags, sqlite):
    prefer :func:`open_binary`, which checks the descriptor it reads.

    Raises
    ------
    EtsidError
        (``error``) No such file, not a regular file after following links, a file of
        ``/proc`` or ``/sys``, or larger than ``LIMITS[kind]``.
    """
    p = Path(path)
    try:
        info = os.stat(p)
    except FileNotFoundError as err:
        raise error(f"{p}: no such file") from err
    except OSError as err:
        raise error(f"{p}: cannot read ({err.strerror or err})") from err
    _refuse(p, kind, info.st_mode, info.st_size, os.path.realpath(p), error)
    return p


def open_handle(path: str | Path, kind: str, error: type[EtsidError] = EtsidError
                ) -> IO[bytes]:
    """An open binary handle on the regular file ``path``; the caller closes it (prefer
    :func:`open_binary`). The type and size are checked on the open descriptor."""
    p = Path(path)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(p, flags)
    except FileNotFoundError as err:
        raise error(f"{p}: no such file") from err
    except IsADirectoryError as err:
        raise error(f"{p}: a directory, not a file") from err
    except OSError as err:
        raise error(f"{p}: cannot read ({err.strerror or err})") from err
    try:
        info = os.fstat(fd)
        _refuse(p, kind, info.st_mode, info.st_size, os.path.realpath(p), error)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


@contextlib.contextmanager
def open_binary(path: str | Path, kind: str, error: type[EtsidError] = EtsidError
                ) -> Iterator[IO[bytes]]:
    """An open binary handle on the regular file ``path`` (see the module notes), closed
    on exit. The bound of ``kind`` is on the file's size; :func:`read_bytes` also stops
    reading at it."""
    with open_handle(path, kind, error) as handle:
        yield handle


def read_bytes(path: str | Path, kind: str, error: type[EtsidError] = EtsidError) -> bytes:
    """The bytes of ``path``, at most the bound of ``kind`` (whatever its size said)."""
    limit = LIMITS.get(kind)
    with open_binary(path, kind, error) as handle:
        try:
            data = handle.read() if limit is None else handle.read(limit + 1)
        except OSError as err:
            raise error(f"{path}: cannot read ({err.strerror or err})") from err
    if limit is not None and len(data) > limit:
        raise error(f"{path}: too large for one of the {WORDS.get(kind, 'files')} (limit "
                    f"{_size(limit)})")
    return data


def read_text(path: str | Path, kind: str, error: type[EtsidError] = EtsidError) -> str:
    """The UTF-8 text of ``path`` (bounded as :func:`read_bytes`)."""
    data = read_bytes(path, kind, error)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not UTF-8 text (byte {err.start})") from err


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def depth(value: Any) -> int:
    """Nesting depth of lists and dicts in ``value`` (a scalar: 0), without recursion."""
    deepest, todo = 0, [(value, 1)]
    while todo:
        item, level = todo.pop()
        children = (item.values() if isinstance(item, dict)
                    else item if isinstance(item, list) else None)
        if children is None:
            continue
        deepest = max(deepest, level)
        todo.extend((c, level + 1) for c in children if isinstance(c, dict | list))
    return deepest


def loads_json(text: str | bytes, source: str | Path, error: type[EtsidError] = EtsidError,
               what: str = "JSON", max_depth: int = MAX_DEPTH) -> Any:
    """Parse JSON from a file (or a file's metadata), bounded in depth, no NaN/Infinity.

    Raises
    ------
    EtsidError
        (``error``) "SOURCE: not valid JSON (...)" or nested deeper than ``max_depth``.
    """
    try:
        value = json.loads(text, parse_constant=_no_constant)
    except RecursionError as err:
        raise error(f"{source}: {what} nested too deeply (more than {max_depth} levels)") from err
    except (ValueError, TypeError) as err:  # JSONDecodeError and UnicodeDecodeError too
        first = str(err).splitlines()[0][:160] if str(err) else type(err).__name__
        raise error(f"{source}: not valid {what} ({first})") from err
    if depth(value) > max_depth:
        raise error(f"{source}: {what} nested too deeply (more than {max_depth} levels)")
    return value


def read_json(path: str | Path, kind: str, error: type[EtsidError] = EtsidError,
              what: str = "JSON", max_depth: int = MAX_DEPTH) -> Any:
    """The JSON document in ``path``, bounded in bytes (``kind``) and depth."""
    return loads_json(read_bytes(path, kind, error), path, error, what, max_depth)


def loads_toml(text: str, source: str | Path, error: type[EtsidError] = EtsidError,
               what: str = "TOML", max_depth: int = MAX_DEPTH) -> dict[str, Any]:
    """Parse TOML text from a file, bounded in depth."""
    try:
        value = tomllib.loads(text)
    except RecursionError as err:
        raise error(f"{source}: {what} nested too deeply (more than {max_depth} levels)") from err
    except tomllib.TOMLDecodeError as err:
        raise error(f"{source}: invalid {what} ({err})") from err
    if depth(value) > max_depth:
        raise error(f"{source}: {what} nested too deeply (more than {max_depth} levels)")
    return value


def read_toml(path: str | Path, kind: str, error: type[EtsidError] = EtsidError,
              what: str = "TOML", max_depth: int = MAX_DEPTH) -> dict[str, Any]:
    """The TOML document in ``path``, bounded in bytes (``kind``) and depth."""
    data = read_bytes(path, kind, error)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not a {what} (not UTF-8 text: byte {err.start})") from err
    return loads_toml(text, path, error, what, max_depth)


def sha256(path: str | Path, error: type[EtsidError] = EtsidError) -> str:
    """SHA-256 (hex) of the regular file ``path``, streamed in 1 MiB blocks."""
    import hashlib

    digest = hashlib.sha256()
    with open_binary(path, "hash", error) as handle:
        for block in iter(lambda: handle.read(MIB), b""):
            digest.update(block)
    return digest.hexdigest()


def read_parquet(path: str | Path, kind: str = "table", error: type[EtsidError] = EtsidError,
                 columns: list[str] | None = None) -> pa.Table:
    """The Arrow table in the Parquet file ``path`` (read from the checked descriptor)."""
    import pyarrow.parquet as pq

    with open_binary(path, kind, error) as handle:
        return pq.read_table(handle, columns=columns)


def parquet_metadata(path: str | Path, kind: str = "table",
                     error: type[EtsidError] = EtsidError) -> Any:
    """The footer metadata of the Parquet file ``path`` (``pyarrow.parquet.FileMetaData``)."""
    import pyarrow.parquet as pq

    with open_binary(path, kind, error) as handle:
        return pq.read_metadata(handle)


def read_parquet_frame(path: str | Path, kind: str = "run",
                       error: type[EtsidError] = EtsidError) -> pd.DataFrame:
    """A Parquet file as a pandas DataFrame (pandas metadata honoured, like
    ``pandas.read_parquet``)."""
    return read_parquet(path, kind, error).to_pandas()


def read_parquet_dataset(folder: str | Path, kind: str = "batch",
                         error: type[EtsidError] = EtsidError) -> pd.DataFrame:
    """The Parquet dataset below ``folder`` (hive partitions ``key=value/``) as a DataFrame;
    every file is checked to be a regular file first (each is then read by pyarrow)."""
    import pyarrow.dataset as ds

    root = Path(folder)
    if not root.is_dir():
        raise error(f"{root}: not a folder")
    for item in sorted(root.rglob("*")):
        if item.is_symlink() or not (item.is_dir() or item.is_file()):
            raise error(f"{item}: not a regular file or folder (a link, FIFO or device): "
                        f"{WORDS.get(kind, 'files')} are read from regular files")
    try:
        dataset = ds.dataset(root, format="parquet", partitioning="hive")
        return dataset.to_table().to_pandas()
    except (OSError, ValueError, TypeError) as err:  # pyarrow's errors derive from these
        first = str(err).splitlines()[0][:160] if str(err) else type(err).__name__
        raise error(f"{root}: not a readable Parquet dataset ({first})") from err


def read_csv(path: str | Path, kind: str = "table", error: type[EtsidError] = EtsidError,
             **options: Any) -> pd.DataFrame:
    """A CSV file as a pandas DataFrame (read from the checked descriptor)."""
    import pandas as pd

    with open_binary(path, kind, error) as handle:
        return pd.read_csv(handle, **options)
