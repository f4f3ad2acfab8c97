"""numba's compiled kernels go to the user cache (XDG), never beside the installed code."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from etsid.cachedir import numba_cache_dir, prune_stale, source_key, user_cache_root

ROOT = Path(__file__).resolve().parent.parent
PACKAGE_ROOT = ROOT / "etsid"
PROBE = ("import numpy as np{first}; import etsid; from numba.core import config; "
         "from etsid.sim.body import quat_to_euler; quat_to_euler(np.array([1.0, 0, 0, 0])); "
         "print(config.CACHE_DIR)")


def _probe(env_extra: dict[str, str], numba_first: bool = False) -> str:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(env_extra, PYTHONPATH=str(ROOT))
    code = PROBE.format(first="; import numba" if numba_first else "")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip().splitlines()[-1]


@pytest.mark.skipif(sys.platform in ("win32", "darwin"), reason="XDG is the Linux rule")
def test_xdg_cache_home_is_honoured_and_relative_values_ignored() -> None:
    assert user_cache_root({"XDG_CACHE_HOME": "/x/cache"}) == Path("/x/cache")
    assert user_cache_root({"XDG_CACHE_HOME": "relative"}) == Path.home() / ".cache"
    assert numba_cache_dir({}, key="k") == Path.home() / ".cache" / "etsid" / "numba" / "k"


@pytest.mark.parametrize("numba_first", [False, True])
def test_kernels_are_cached_in_the_user_cache(tmp_path: Path, numba_first: bool) -> None:
    """Also when numba was imported before etsid (its configuration already read)."""
    cache = tmp_path / "xdg"
    assert _probe({"XDG_CACHE_HOME": str(cache)}, numba_first) \
        == str(cache / "etsid" / "numba" / source_key())
    assert list((cache / "etsid" / "numba").rglob("*.nbi"))


def test_numba_cache_dir_set_by_the_user_wins(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    assert _probe({"NUMBA_CACHE_DIR": str(mine), "XDG_CACHE_HOME": str(tmp_path / "x")}) \
        == str(mine)
    assert not (tmp_path / "x" / "etsid").exists()


def test_other_sources_get_another_folder(tmp_path: Path) -> None:
    """numba checks a kernel against its own file only: a changed callee must not reuse it."""
    package = tmp_path / "pkg"
    (package / "sim").mkdir(parents=True)
    (package / "sim" / "dynamics.py").write_text("A = 1\n")
    (package / "engine.py").write_text("B = 2\n")
    before = source_key(package)
    assert source_key(package) == before
    (package / "sim" / "dynamics.py").write_text("A = 2\n")
    assert source_key(package) != before
    assert source_key(PACKAGE_ROOT) == source_key()


def test_stale_folders_of_other_sources_are_pruned(tmp_path: Path) -> None:
    root = tmp_path / "numba"
    old, recent, current = root / "old", root / "recent", root / "current"
    for folder in (old, recent, current):
        folder.mkdir(parents=True)
        (folder / "k.nbi").write_bytes(b"x")
    month_ago = time.time() - 30 * 86400.0
    os.utime(old, (month_ago, month_ago))
    os.utime(current, (month_ago, month_ago))
    assert prune_stale(current) == 1
    assert sorted(p.name for p in root.iterdir()) == ["current", "recent"]
