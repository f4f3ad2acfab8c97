"""Where etsid keeps compiled code: a per-user cache folder, never the installed package.

numba's ``cache=True`` writes its compiled kernels (``*.nbi``/``*.nbc``) beside the source
by default, i.e. into ``site-packages/etsid/**/__pycache__``. pip does not know those files,
so uninstalling etsid leaves the folders behind and Python then imports ``etsid`` from them
as an empty namespace package (``pip install .`` followed by ``pip install -e .`` in one
venv broke every command). :func:`use_user_cache` points numba at
``$XDG_CACHE_HOME/etsid/numba`` (``~/.cache/etsid/numba``; ``~/Library/Caches`` on macOS,
``%LOCALAPPDATA%`` on Windows) before any kernel is compiled. A ``NUMBA_CACHE_DIR`` already
set by the user wins and is used as it is (not keyed: one folder per etsid version is then
the user's to keep). This module imports nothing heavy: it runs on every ``import etsid``.

numba checks a cached kernel against its own source file only, not against the kernels it
calls in other files: after an upgrade (or an edit) that changed a callee, the old machine
code was loaded and ran silently (a new simulator parameter read by ``sim.dynamics`` was
ignored by the cached ``sim.engine``). The folder is therefore keyed by a hash of the
package's source (:func:`source_key`): other code, other folder. Folders of other versions
left untouched for :data:`STALE_DAYS` days are removed when a new one is made.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

APP = "etsid"
STALE_DAYS = 14.0  # a cache folder of other sources unused this long is removed, days
PACKAGE = Path(__file__).resolve().parent


def source_key(package: Path = PACKAGE) -> str:
    """16 hex digits hashing every ``*.py`` of ``package`` (relative path and bytes).

    About 15 ms for the whole package (2 MB); any edit anywhere gives another key.
    """
    digest = hashlib.blake2b(digest_size=8)
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()


def user_cache_root(environ: dict[str, str] | None = None) -> Path:
    """The platform's per-user cache folder (the platformdirs convention), not created.

    Parameters
    ----------
    environ
        Environment to read (defaults to ``os.environ``); ``XDG_CACHE_HOME`` is honoured on
        Linux and other Unix systems when it is an absolute path.
    """
    env = os.environ if environ is None else environ
    if sys.platform == "win32":
        base = env.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        return Path(base)
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    xdg = env.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg)
    return Path.home() / ".cache"


def numba_cache_dir(environ: dict[str, str] | None = None, key: str | None = None) -> Path:
    """``<user cache>/etsid/numba/<source key>``: where numba keeps etsid's kernels."""
    return user_cache_root(environ) / APP / "numba" / (source_key() if key is None else key)


def prune_stale(folder: Path, days: float = STALE_DAYS) -> int:
    """Remove ``folder``'s sibling cache folders not modified for ``days``; how many."""
    removed = 0
    cutoff = time.time() - days * 86400.0
    for other in folder.parent.iterdir() if folder.parent.is_dir() else ():
        try:
            stale = other != folder and other.is_dir() and other.stat().st_mtime < cutoff
        except OSError:
            continue
        if stale:
            shutil.rmtree(other, ignore_errors=True)
            removed += 1
    return removed


def _touch(path: Path) -> None:
    with contextlib.suppress(OSError):
        os.utime(path)


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def use_user_cache() -> str:
    """Point numba's cache at :func:`numba_cache_dir` unless ``NUMBA_CACHE_DIR`` is set.

    Falls back to a per-user folder under the system temporary directory when the user
    cache cannot be written (a read-only home), so the kernels never land in the package.
    The folder is keyed by :func:`source_key`, so kernels compiled from other sources are
    never loaded.
    Returns the folder in use. Works also when numba was imported before etsid.
    """
    chosen = os.environ.get("NUMBA_CACHE_DIR", "")
    if not chosen:
        key = source_key()
        path = numba_cache_dir(key=key)
        new = not path.is_dir()
        if not _writable(path):
            uid = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
            path = Path(tempfile.gettempdir()) / f"{APP}-{uid}" / "numba" / key
            new = not path.is_dir()
            _writable(path)
        if new:
            prune_stale(path)
        else:
            _touch(path)  # in use: not stale for another version's pruning
        chosen = str(path)
        os.environ["NUMBA_CACHE_DIR"] = chosen  # read by numba at import, and by workers
    config = sys.modules.get("numba.core.config")
    if config is not None and not getattr(config, "CACHE_DIR", ""):
        config.CACHE_DIR = chosen  # numba already imported: its config was read without us
    return chosen
