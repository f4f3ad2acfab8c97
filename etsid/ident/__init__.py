"""Identification: NARX regressors, online eTS runs over a log, metrics and an ARX baseline.

>>> from etsid.ident import RegressorSpec
>>> RegressorSpec.parse("y[k-1..k-2],u[k-1]", outputs=["y"]).text
'y[k-1],y[k-2],u[k-1]'
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from etsid.ident.config import IdentConfig
    from etsid.ident.defaults import default_model
    from etsid.ident.metrics import fit_percent, ndei, rmse, scores, vaf
    from etsid.ident.prediction import load_rules, predict
    from etsid.ident.regressors import Regression, RegressorSpec, Term, build
    from etsid.ident.run import identify
    from etsid.ident.rundir import Run, read_run, write_run

_LAZY = {"IdentConfig": "etsid.ident.config", "identify": "etsid.ident.run",
         "load_rules": "etsid.ident.prediction", "predict": "etsid.ident.prediction",
         "default_model": "etsid.ident.defaults",
         **dict.fromkeys(("fit_percent", "ndei", "rmse", "scores", "vaf"), "etsid.ident.metrics"),
         **dict.fromkeys(("Regression", "RegressorSpec", "Term", "build"),
                         "etsid.ident.regressors"),
         **dict.fromkeys(("Run", "read_run", "write_run"), "etsid.ident.rundir")}
"""Public names → the module that defines them, imported when the name is first used:
importing the package (or a light module of it such as :mod:`etsid.ident.choices`, the
choices of ``etsid identify --help``) loads no numpy, pandas or numba."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'etsid.ident' has no attribute {name!r}")


__all__ = [
    "IdentConfig",
    "Regression",
    "RegressorSpec",
    "Run",
    "Term",
    "build",
    "default_model",
    "fit_percent",
    "identify",
    "load_rules",
    "ndei",
    "predict",
    "read_run",
    "rmse",
    "scores",
    "vaf",
    "write_run",
]
