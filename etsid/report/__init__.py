"""Reports of identification runs: paper-style figures, index.html and report.md.

>>> from etsid.report import FIGURES
>>> sorted(FIGURES)
['consequents', 'rates', 'residuals', 'structure', 'validation']
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from etsid.report.build import Report, make_report
    from etsid.report.figures import FIGURES
    from etsid.report.tables import rules_text, summary_table

_LAZY = {"FIGURES": "etsid.report.figures", "Report": "etsid.report.build",
         "make_report": "etsid.report.build", "rules_text": "etsid.report.tables",
         "summary_table": "etsid.report.tables"}
"""Public names → the module that defines them, imported when the name is first used:
importing the package (or :mod:`etsid.report.choices`, the choices of ``etsid report
--help``) loads no matplotlib."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'etsid.report' has no attribute {name!r}")


__all__ = ["FIGURES", "Report", "make_report", "rules_text", "summary_table"]
