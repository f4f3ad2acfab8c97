"""Where etsid keeps compiled code: a per-user cache folder, never the installed package.

numba's ``cache=True`` writes its compiled kernels (``*.nbi``/``*.nbc``) beside the source
by default, i.e. into ``site-packages/etsid/**/__pycache__``. pip does not know those files,
so uninstalling etsid leaves the folders behind and Python then imports ``etsid`` from them
as an empty namespace package (``pip install .`` followed by ``pip install -e .`` in one
venv broke every command). :func:`use_user_cache` points numba at
``$XDG_CACHE_HOME/etsid/numba`` (``~/.cache/etsid/numba``; ``~/Library/Caches`` on macOS,
``%LOCALAPPDATA%`` on Windows) before any kernel is compiled. A ``NUMBA_CACHE_DIR`` already
set by the user wins. This module imports nothing heavy: it runs on every ``import etsid``.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

APP = "etsid"


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


def numba_cache_dir(environ: dict[str, str] | None = None) -> Path:
    """``<user cache>/etsid/numba``: where numba keeps etsid's compiled kernels."""
    return user_cache_root(environ) / APP / "numba"


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
    Returns the folder in use. Works also when numba was imported before etsid.
    """
    chosen = os.environ.get("NUMBA_CACHE_DIR", "")
    if not chosen:
        path = numba_cache_dir()
        if not _writable(path):
            uid = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
            path = Path(tempfile.gettempdir()) / f"{APP}-{uid}" / "numba"
        chosen = str(path)
        os.environ["NUMBA_CACHE_DIR"] = chosen  # read by numba at import, and by workers
    config = sys.modules.get("numba.core.config")
    if config is not None and not getattr(config, "CACHE_DIR", ""):
        config.CACHE_DIR = chosen  # numba already imported: its config was read without us
    return chosen
