"""Inputs given as URLs: which schemes a batch may open, and a local copy that cannot escape.

Only ``file://`` URLs are opened unless the user names further fsspec protocols
(``--protocol s3``): a list file from elsewhere cannot make a worker open outbound
connections (``ftp://``, ``hdfs://``, ``http://``) it was not asked to. A URL's path is
normalised (``/a/sub/..`` is ``/a``) before anything is opened. A ``file://`` URL is read
in place (no copy); any other is copied into a fresh private temporary folder (mode 0700)
under a file name made here — never a name taken from the URL — and the folder is removed
afterwards. A directory URL is copied only when it is a ROS 2 bag (``metadata.yaml``), and
then only its own files, not what lies below them.
"""

from __future__ import annotations

import contextlib
import posixpath
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from etsid.errors import BatchError

DEFAULT_PROTOCOLS = ("file",)
"""URL schemes a batch opens without being told (``--protocol`` adds others)."""

BAG_METADATA = "metadata.yaml"

_NOT_A_BAG = ("{item}: a directory, not a log (only a ROS 2 bag directory, with "
              f"{BAG_METADATA}, is one log; name a directory as an input to search it)")


def is_url(text: str) -> bool:
    """True for an fsspec URL (``scheme://…``), False for a local path."""
    scheme, sep, _ = text.partition("://")
    return bool(sep) and scheme.isidentifier() and len(scheme) > 1


def url_scheme(url: str) -> str:
    """The scheme of a URL, lower case (``S3://b/x`` → ``s3``)."""
    return url.partition("://")[0].lower()


def normalise_url(url: str) -> str:
    """``scheme://`` + the normalised path: ``..`` and ``.`` resolved, repeated slashes
    joined (``file:///a/sub/..`` → ``file:///a``); a trailing slash is kept."""
    scheme, _, rest = url.partition("://")
    if not rest:
        return url
    lead = "/" if rest.startswith("/") else ""
    path = posixpath.normpath(rest)
    if path in (".", "/"):
        path = lead or "."
    trail = "/" if rest.endswith("/") and not path.endswith("/") else ""
    return f"{scheme.lower()}://{path}{trail}"


def check_url(url: str, protocols: tuple[str, ...] = DEFAULT_PROTOCOLS) -> str:
    """The normalised URL when its scheme is allowed.

    Raises
    ------
    BatchError
        A scheme not in ``protocols`` (nothing is opened).
    """
    scheme = url_scheme(url)
    if scheme not in {p.lower() for p in protocols}:
        allowed = ", ".join(sorted({p.lower() for p in protocols}))
        raise BatchError(f"{url}: URL scheme {scheme!r} is not allowed (allowed: {allowed}; "
                         f"name it with --protocol {scheme} to read such URLs)")
    return normalise_url(url)


def url_fs(url: str) -> tuple[Any, str]:
    """fsspec file system and path of a URL (needs fsspec)."""
    try:
        import fsspec
    except ImportError as err:
        raise BatchError(f"{url}: URLs need fsspec (pip install \"etsid[cluster]\")") from err
    try:
        return fsspec.core.url_to_fs(url)
    except (ImportError, ValueError, TypeError, OSError) as err:
        raise BatchError(f"{url}: cannot open this URL ({_reason(err)})") from err


def _shown(item: str, most: int = 200) -> str:
    """``item`` cut to ``most`` characters for a message (with how long it was)."""
    return item if len(item) <= most else f"{item[:most]}… ({len(item)} characters)"


def _reason(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0]}" if text else type(err).__name__


def file_url_path(url: str) -> Path:
    """The local path of a normalised ``file://`` URL."""
    return Path(url.partition("://")[2] or "/")


def _safe_name(remote: str, fallback: str) -> str:
    """A file name for a copy: the URL's last component cut to letters, digits, ``-_.``
    (never ``..`` or empty); its suffix kept, since the readers go by it."""
    base = remote.rstrip("/").rsplit("/", 1)[-1]
    name = "".join(c if c.isalnum() or c in "-_." else "_" for c in base)[:80].strip(".")
    return name or fallback


def _inside(path: Path, root: Path) -> Path:
    if not path.resolve().is_relative_to(root.resolve()):  # pragma: no cover - by design
        raise BatchError(f"{path}: a copy would land outside its temporary folder")
    return path


@contextlib.contextmanager
def local_copy(item: str, protocols: tuple[str, ...] = DEFAULT_PROTOCOLS) -> Iterator[Path]:
    """A local path for ``item``: a local path as it is, a ``file://`` URL's path, or a copy
    of any other URL in a private temporary folder removed afterwards.

    Raises
    ------
    BatchError
        No such file, a scheme not allowed, a directory URL that is not a ROS 2 bag, or a
        fetch that failed (one line).
    """
    if not is_url(item):
        path = Path(item)
        try:
            found = path.exists()
        except OSError as err:  # e.g. a name longer than the system allows
            raise BatchError(f"{_shown(item)}: not a usable path ({err.strerror or err})"
                             ) from err
        if not found:
            raise BatchError(f"{item}: no such file or directory")
        yield path
        return
    url = check_url(item, protocols)
    if url_scheme(url) == "file":
        path = file_url_path(url)
        if not path.exists():
            raise BatchError(f"{item}: no such file or directory")
        if path.is_dir() and not (path / BAG_METADATA).is_file():
            raise BatchError(_NOT_A_BAG.format(item=item))
        yield path
        return
    fs, remote = url_fs(url)
    tmp = Path(tempfile.mkdtemp(prefix="etsid-batch-"))
    try:
        yield _fetch(fs, remote.rstrip("/") or remote, tmp, item)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _fetch(fs: Any, remote: str, tmp: Path, item: str) -> Path:
    """Copy one remote log (a file, or a bag directory's own files) into ``tmp``."""
    try:
        if not fs.isdir(remote):
            local = _inside(tmp / _safe_name(remote, "log"), tmp)
            fs.get_file(remote, str(local))
            return local
        entries = [e for e in fs.ls(remote, detail=True) if e.get("type") == "file"]
        names = {posixpath.basename(e["name"].rstrip("/")): e["name"] for e in entries}
        if BAG_METADATA not in names:
            raise BatchError(_NOT_A_BAG.format(item=item))
        bag = _inside(tmp / _safe_name(remote, "bag"), tmp)
        bag.mkdir()
        for name, remote_file in sorted(names.items()):
            fs.get_file(remote_file, str(_inside(bag / _safe_name(name, "file"), tmp)))
        return bag
    except BatchError:
        raise
    except Exception as err:  # any fsspec back end: network, permission, missing file
        raise BatchError(f"{item}: cannot fetch ({_reason(err)})") from err
