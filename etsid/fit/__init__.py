"""``etsid fit``: an airframe's physical parameters from its own logs, as a vehicle file.

Reads FlightTables (never log files: the CLI reads them), pools flights of one airframe and
fits physically derived regressions (:mod:`etsid.fit.thrust`, :mod:`etsid.fit.rotation`,
:mod:`etsid.fit.drag`) with robust least squares and autocorrelation-corrected standard
errors (:mod:`etsid.fit.regress`). Every parameter carries a verdict
(:data:`etsid.fit.result.VERDICTS`); what logs cannot separate is declared, never fitted.
Imports nothing of ``etsid.gap``. Method and results: docs/fit.md.
"""

from etsid.fit.result import FitResult, Param
from etsid.fit.run import fit_tables

__all__ = ["FitResult", "Param", "fit_tables"]
