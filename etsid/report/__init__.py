"""Reports of identification runs: paper-style figures, index.html and report.md.

>>> from etsid.report import FIGURES
>>> sorted(FIGURES)
['consequents', 'rates', 'residuals', 'structure', 'validation']
"""

from __future__ import annotations

from etsid.report.build import Report, make_report
from etsid.report.figures import FIGURES
from etsid.report.tables import rules_text, summary_table

__all__ = ["FIGURES", "Report", "make_report", "rules_text", "summary_table"]
