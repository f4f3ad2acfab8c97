"""What a batch runs over: log files found in directories, list files and fsspec URLs.

An input is a local path or an fsspec URL (``file://…``, and ``s3://…``, ``gcs://…``, …
when their protocol is allowed); the reader always gets a local path (a URL other than
``file://`` is copied to a private temporary folder by the worker, see
:mod:`etsid.batch.fetch`).

* a file with a log or saved-table extension is one log;
* a directory is searched recursively for every supported log format; a directory with
  ``metadata.yaml`` is one ROS 2 bag and is not searched further;
* a ``.txt`` / ``.list`` / ``.lst`` file lists one input per line (``#`` starts a
  comment; relative paths are relative to the list file);
* for ``gap``, a ``.csv`` file of ``SIM,REAL`` pairs (optional header ``sim,real``).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable
from pathlib import Path

from etsid.batch.fetch import (
    BAG_METADATA,
    DEFAULT_PROTOCOLS,
    check_url,
    is_url,
    url_fs,
)
from etsid.errors import BatchError
from etsid.files import read_text

LOG_SUFFIXES = (".tlog", ".bin", ".ulg", ".bag", ".db3", ".mcap")
"""File extensions searched for in directories (the readers of :mod:`etsid.ingest`)."""

TABLE_SUFFIXES = (".parquet", ".csv")
"""Saved FlightTables: taken when named, never searched for (a folder of results is full of
Parquet files that are not flight tables)."""

LIST_SUFFIXES = (".txt", ".list", ".lst")
"""Files that list inputs, one per line."""

__all__ = ["BAG_METADATA", "find_inputs", "is_url", "read_pairs", "run_name"]


def _local_key(path: Path) -> str:
    return os.path.normpath(os.path.abspath(path))


def _walk_local(root: Path, exclude: Path | None, tables: list[str]) -> list[str]:
    """Logs below ``root``: files with a log extension and ROS 2 bag directories; the saved
    tables met on the way are appended to ``tables``."""
    found: list[str] = []
    for dirpath, dirnames, filenames in os.walk(root):
        here = Path(dirpath)
        if exclude is not None and _local_key(here) == _local_key(exclude):
            dirnames[:] = []
            continue
        if BAG_METADATA in filenames and here != root:
            found.append(str(here))
            dirnames[:] = []
            continue
        if BAG_METADATA in filenames:  # the root itself is a bag
            return [str(root)]
        dirnames.sort()
        found.extend(str(here / name) for name in sorted(filenames)
                     if Path(name).suffix.lower() in LOG_SUFFIXES)
        tables.extend(str(here / name) for name in sorted(filenames)
                      if Path(name).suffix.lower() in TABLE_SUFFIXES)
    return found


def _walk_url(url: str, tables: list[str]) -> list[str]:
    """Logs below a directory URL (needs fsspec); a bag directory is one input; the saved
    tables met on the way are appended to ``tables``. ``url`` is normalised and of an
    allowed scheme (:func:`etsid.batch.fetch.check_url`)."""
    fs, root = url_fs(url)
    protocol = url.split("://", 1)[0]
    try:
        if not fs.isdir(root):
            return [url]
        files = sorted(fs.find(root))
    except Exception as err:  # any fsspec back end: network, permission
        raise BatchError(f"{url}: cannot list this URL ({type(err).__name__}: "
                         f"{str(err).strip().splitlines()[0] if str(err).strip() else ''})"
                         ) from err
    bags = sorted({str(Path(f).parent) for f in files if Path(f).name == BAG_METADATA})
    found = [f"{protocol}://{b}" for b in bags]
    for f in files:
        if Path(f).suffix.lower() in LOG_SUFFIXES and not any(
                f.startswith(b.rstrip("/") + "/") for b in bags):
            found.append(f"{protocol}://{f}")
        elif Path(f).suffix.lower() in TABLE_SUFFIXES:
            tables.append(f"{protocol}://{f}")
    return sorted(found)


def _read_list(path: Path) -> list[str]:
    lines = read_text(path, "list", BatchError).splitlines()
    items = []
    for line in lines:
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        if is_url(text) or Path(text).is_absolute():
            items.append(text)
        else:
            items.append(str(path.parent / text))
    return items


def find_inputs(items: Iterable[str | Path], exclude: Path | None = None,
                unsearched: list[str] | None = None,
                protocols: tuple[str, ...] = DEFAULT_PROTOCOLS) -> list[str]:
    """Expand INPUTS into the logs of a batch, in a stable order, each once.

    Parameters
    ----------
    items
        Files, directories, list files or fsspec URLs, as given on the command line.
    exclude
        A directory never searched (the batch's own ``--out``).
    unsearched
        When given, the saved tables (``.parquet``, ``.csv``) found in the directories
        searched are appended to it: they are inputs only when named.
    protocols
        URL schemes that may be opened (``--protocol``): a URL of another scheme is not
        opened here and becomes an error row (:func:`etsid.batch.fetch.check_url`).

    Notes
    -----
    A named path that does not exist stays an input: it becomes an error row
    ("no such file or directory") rather than stopping the batch.
    """
    seen: set[str] = set()
    out: list[str] = []
    tables = unsearched if unsearched is not None else []

    def add(item: str) -> None:
        key = item if is_url(item) else _local_key(Path(item))
        if key not in seen:
            seen.add(key)
            out.append(item)

    for raw in items:
        item = str(raw)
        if is_url(item):
            try:
                url = check_url(item, protocols)
            except BatchError:
                add(item)  # never opened: the worker's error row says why
                continue
            for found in _walk_url(url, tables):
                add(found)
            continue
        path = Path(item)
        try:
            is_dir, is_file = path.is_dir(), path.is_file()
        except OSError:  # a name longer than the system allows: that input's error row
            add(item)
            continue
        if is_dir:
            for found in _walk_local(path, exclude, tables):
                add(found)
        elif is_file and path.suffix.lower() in LIST_SUFFIXES:
            for listed in find_inputs(_read_list(path), exclude, tables, protocols):
                add(listed)
        else:
            add(item)
    return out


def read_pairs(items: Iterable[str | Path]) -> list[tuple[str, str]]:
    """``(sim, real)`` pairs from CSV files of two columns ``SIM,REAL``.

    A first row ``sim,real`` (any case) is a header; relative paths are relative to the
    CSV file; blank lines and lines starting with ``#`` are skipped.

    Raises
    ------
    BatchError
        A file that cannot be read or a row without exactly two paths.
    """
    pairs: list[tuple[str, str]] = []
    for raw in items:
        path = Path(raw)
        rows = list(csv.reader(read_text(path, "list", BatchError).splitlines()))
        for number, row in enumerate(rows, start=1):
            cells = [c.strip() for c in row]
            if not cells or not any(cells) or cells[0].startswith("#"):
                continue
            if number == 1 and [c.lower() for c in cells] == ["sim", "real"]:
                continue
            if len(cells) != 2 or not all(cells):
                raise BatchError(f"{path}: line {number}: expected SIM,REAL (two paths), "
                                 f"got {','.join(cells)!r}")
            pairs.append(tuple(  # type: ignore[arg-type]
                c if is_url(c) or Path(c).is_absolute() else str(path.parent / c)
                for c in cells))
    return pairs


def run_name(item: str) -> str:
    """A readable folder name for an input: its base name with the format after a dash
    (``flight.bag`` → ``flight-bag``), so the runs of one flight in several formats differ."""
    name = item.rstrip("/").rsplit("/", 1)[-1] or "log"
    suffix = Path(name).suffix.lower()
    stem = (f"{Path(name).stem[:55]}-{suffix[1:]}"
            if suffix in (*LOG_SUFFIXES, *TABLE_SUFFIXES) else name)
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in stem)[:60] or "log"
