"""numba's compiled kernels go to the user cache (XDG), never beside the installed code."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from etsid.cachedir import numba_cache_dir, user_cache_root

ROOT = Path(__file__).resolve().parent.parent
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
    assert numba_cache_dir({}) == Path.home() / ".cache" / "etsid" / "numba"


@pytest.mark.parametrize("numba_first", [False, True])
def test_kernels_are_cached_in_the_user_cache(tmp_path: Path, numba_first: bool) -> None:
    """Also when numba was imported before etsid (its configuration already read)."""
    cache = tmp_path / "xdg"
    assert _probe({"XDG_CACHE_HOME": str(cache)}, numba_first) == str(cache / "etsid" / "numba")
    assert list((cache / "etsid" / "numba").rglob("*.nbi"))


def test_numba_cache_dir_set_by_the_user_wins(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    assert _probe({"NUMBA_CACHE_DIR": str(mine), "XDG_CACHE_HOME": str(tmp_path / "x")}) \
        == str(mine)
    assert not (tmp_path / "x" / "etsid").exists()
