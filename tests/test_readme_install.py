"""The README's two install commands, for real, one after the other in one fresh venv.

Command 1 installs etsid (``pip install .``) and runs it; command 2 installs it editable with
the test extra (``pip install -e ".[test]"``) into the same venv. numba used to write its
compiled kernels into ``site-packages/etsid/**/__pycache__``; pip does not know those files,
so command 2's uninstall left the folders behind and ``etsid`` became an empty namespace
package (``ImportError: cannot import name '__version__'``). Here both orders run in one
venv (1 → 2 → 1), each followed by ``etsid --version``, ``python -m etsid`` from the folder
that holds the clone, and after command 2 one small test of the suite.

Cheap where it can be: only the files a user's clone needs are copied, pip resolves every
dependency normally (served from pip's own cache after the first install, as for any
user), and a single cached kernel stands in for ``etsid identify``'s compilation. Needs
the package index (or pip's cache) the CI install used; it takes a few minutes.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = "sample_logs/hexa_ige_oge.bag"
KERNEL = ("import numpy as np; from etsid.sim.body import quat_to_euler; "
          "print(quat_to_euler(np.array([1.0, 0.0, 0.0, 0.0])))")
"""Compile and cache one numba kernel (``cache=True``), as identify and simulate do."""

pytestmark = pytest.mark.slow


def _clone(dest: Path) -> Path:
    """The files of a fresh clone that the install and the small test need."""
    dest.mkdir(parents=True)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, dest / name)
    shutil.copytree(ROOT / "etsid", dest / "etsid",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (dest / "tests").mkdir()
    shutil.copy2(ROOT / "tests" / "test_table.py", dest / "tests" / "test_table.py")
    (dest / SAMPLE).parent.mkdir()
    shutil.copy2(ROOT / SAMPLE, dest / SAMPLE)
    return dest


def _run(args: list[str], cwd: Path, env: dict[str, str], timeout: float = 1200) -> str:
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert done.returncode == 0, f"{' '.join(args)}\n{done.stdout[-2000:]}{done.stderr[-3000:]}"
    return done.stdout


def test_readme_commands_in_one_venv_in_either_order(tmp_path: Path) -> None:
    clone = _clone(tmp_path / "etsid")  # named as `git clone` names it
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    python, etsid = str(bindir / "python"), str(bindir / "etsid")
    pip_env = {k: v for k, v in os.environ.items()
               if k not in ("PYTHONPATH", "PYTHONSAFEPATH", "NUMBA_CACHE_DIR")}
    user_cache = tmp_path / "user-cache"
    env = {**pip_env, "XDG_CACHE_HOME": str(user_cache)}  # etsid's runs; pip keeps its cache
    site = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                     tmp_path, env).strip())

    def check(version_cwd: Path) -> None:
        assert _run([etsid, "--version"], tmp_path, env).strip() == "etsid, version 0.1.0"
        # `python -m etsid` from the folder that holds the clone (a folder named etsid)
        out = _run([python, "-m", "etsid", "--version"], version_cwd, env)
        assert out.strip() == "etsid, version 0.1.0"

    # command 1: install, then run (inspect the sample, compile a cached kernel)
    _run([python, "-m", "pip", "install", "-q", "."], clone, pip_env)
    assert "hexa_ige_oge.bag" in _run([etsid, "inspect", SAMPLE], clone, env)
    _run([python, "-c", KERNEL], tmp_path, env)
    assert not list((site / "etsid").rglob("*.nbi")), "numba cache inside site-packages"
    assert list((user_cache / "etsid" / "numba").rglob("*.nbi")), "no cache in the user dir"
    check(tmp_path)

    # command 2 into the same venv: editable with the test extra, then one test of the suite
    _run([python, "-m", "pip", "install", "-q", "-e", ".[test]"], clone, pip_env)
    assert not (site / "etsid").exists(), "command 1's package folder left behind"
    check(tmp_path)
    _run([python, "-c", KERNEL], tmp_path, env)
    assert not list((clone / "etsid").rglob("*.nbi")), "numba cache inside the clone"
    out = _run([python, "-m", "pytest", "-p", "no:cacheprovider",
                "tests/test_table.py::test_resample_linear_hold_and_angle"], clone, env)
    assert "1 passed" in out, out  # pyproject's addopts: -q, a summary line

    # and command 1 again after command 2 (the other order)
    _run([python, "-m", "pip", "install", "-q", "."], clone, pip_env)
    _run([python, "-c", KERNEL], tmp_path, env)
    check(tmp_path)
    assert not list((site / "etsid").rglob("*.nbi"))
