"""Column reads without the cost of ``table.attrs``.

pandas deep-copies a frame's ``attrs`` into every Series it hands out, so each
``table[name]`` of a log's table (provenance: mapping, signal rates and counts) costs about
a millisecond; identify reads columns a few hundred times. :func:`bare` is the same columns
(no copy of the data) without the attrs, for reading.
"""

from __future__ import annotations

import pandas as pd


def bare(table: pd.DataFrame) -> pd.DataFrame:
    """``table``'s columns and index, sharing its data, with empty ``attrs``."""
    return pd.DataFrame(table, copy=False)
