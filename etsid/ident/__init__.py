"""Identification: NARX regressors, online eTS runs over a log, metrics and an ARX baseline.

>>> from etsid.ident import RegressorSpec
>>> RegressorSpec.parse("y[k-1..k-2],u[k-1]", outputs=["y"]).text
'y[k-1],y[k-2],u[k-1]'
"""

from __future__ import annotations

import importlib
from typing import Any

from etsid.ident.defaults import default_model
from etsid.ident.metrics import fit_percent, ndei, rmse, scores, vaf
from etsid.ident.regressors import Regression, RegressorSpec, Term, build
from etsid.ident.rundir import Run, read_run, write_run

_LAZY = {"IdentConfig": "etsid.ident.config", "identify": "etsid.ident.run",
         "load_rules": "etsid.ident.prediction", "predict": "etsid.ident.prediction"}
"""Public names whose modules import the eTS core (numba): loaded when first used."""


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
