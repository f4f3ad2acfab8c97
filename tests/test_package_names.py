"""Packages that load their public names when first used (``ets``, ``ident``, ``sim``,
``report``, ``batch``) still give every name of their ``__all__``, and the same object as
the module that defines it, whatever was imported before."""

from __future__ import annotations

import importlib
import subprocess
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAZY_PACKAGES = ("etsid.ets", "etsid.ident", "etsid.sim", "etsid.report", "etsid.batch")


@pytest.mark.parametrize("name", LAZY_PACKAGES)
def test_every_public_name_is_the_defining_modules(name: str) -> None:
    package = importlib.import_module(name)
    for public in package.__all__:
        value = getattr(package, public)
        assert not isinstance(value, types.ModuleType), public
        home = package._LAZY.get(public)
        if home is not None:
            assert value is getattr(importlib.import_module(home), public), public


def test_a_submodule_import_does_not_hide_the_function_of_its_name() -> None:
    """``etsid.sim.replay`` is the function (as when the package imported it eagerly), also
    after the submodule ``etsid.sim.replay`` was imported first."""
    code = ("import types, etsid.sim.replay\nfrom etsid.sim import replay\n"
            "import etsid.sim\n"
            "print(isinstance(replay, types.FunctionType), etsid.sim.replay is replay)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.split()
    assert out == ["True", "True"]
