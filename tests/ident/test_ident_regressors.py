"""Regressor specs and lag matrices: syntax, segments, NaN rows, free-run feedback."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from etsid.errors import IdentError
from etsid.ident.regressors import RegressorSpec, Term, build, feedback_map, parse_terms


def _table(y: np.ndarray, u: np.ndarray, seg: np.ndarray | None = None) -> pd.DataFrame:
    frame = pd.DataFrame({"y": y, "u": u},
                         index=pd.Index(np.arange(len(y)) * 0.5, name="t"))
    if seg is not None:
        frame["segment"] = seg.astype(np.int64)
    return frame


def test_parse_single_lags_and_ranges() -> None:
    assert parse_terms("co2[k-1], input_gas_rate[k-4]") == [Term("co2", 1),
                                                          Term("input_gas_rate", 4)]
    assert parse_terms("u[k-1..k-3]") == [Term("u", 1), Term("u", 2), Term("u", 3)]
    assert parse_terms("u[k..k-1],y[k-2]") == [Term("u", 0), Term("u", 1), Term("y", 2)]
    spec = RegressorSpec.parse("y[k-1..k-2],u[k]", outputs=["y"])
    assert spec.text == "y[k-1],y[k-2],u[k]"
    assert spec.max_lag == 2
    assert RegressorSpec.from_dict(spec.to_dict()) == spec


@pytest.mark.parametrize(("text", "match"), [
    ("y(k-1)", "bad regressor"),
    ("y[k+1]", "bad regressor"),
    ("y[k-1],y[k-1]", "appears twice"),
    ("", "empty regressor"),
    ("y[k],u[k-1]", "output itself"),
])
def test_parse_errors(text: str, match: str) -> None:
    with pytest.raises(IdentError, match=match):
        RegressorSpec.parse(text, outputs=["y"])


def test_build_shifts_values_and_counts_skipped_rows() -> None:
    y = np.arange(10.0)
    u = 100 + np.arange(10.0)
    u[6] = np.nan
    reg = build(_table(y, u), RegressorSpec.parse("y[k-1],u[k-2]", ["y"]))
    # rows 0, 1 lack history; u[6] is needed by row 8 only
    assert reg.rows.tolist() == [2, 3, 4, 5, 6, 7, 9]
    assert reg.skipped == {"history": 2, "missing": 1}
    assert reg.X[0].tolist() == [1.0, 100.0]
    assert reg.Y[:, 0].tolist() == [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 9.0]
    assert reg.t.tolist() == [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.5]


def test_build_never_straddles_a_segment_boundary() -> None:
    y = np.arange(12.0)
    seg = np.array([0] * 5 + [1] * 4 + [2] * 3)
    reg = build(_table(y, -y, seg), RegressorSpec.parse("y[k-1..k-2],u[k-1]", ["y"]))
    assert reg.rows.tolist() == [2, 3, 4, 7, 8, 11]
    assert reg.skipped["history"] == 6


def test_build_refuses_missing_columns_listing_what_exists() -> None:
    with pytest.raises(IdentError, match=r"missing column\(s\) w.*the table has: y, u"):
        build(_table(np.ones(5), np.ones(5)), RegressorSpec.parse("w[k-1]", ["y"]))


def test_build_refuses_when_no_row_is_usable() -> None:
    with pytest.raises(IdentError, match="no row has a full regressor history"):
        build(_table(np.ones(3), np.ones(3)), RegressorSpec.parse("u[k-5]", ["y"]))


def test_feedback_map_marks_lagged_outputs() -> None:
    spec = RegressorSpec.parse("a[k-1],u[k-1],b[k-2],a[k-3]", ["a", "b"])
    assert feedback_map(spec) == [(0, 0, 1), (2, 1, 2), (3, 0, 3)]


@settings(max_examples=60, deadline=None)
@given(n=st.integers(5, 60), lags=st.lists(st.integers(0, 4), min_size=1, max_size=3,
                                             unique=True),
       cuts=st.lists(st.integers(1, 59), max_size=4), nans=st.lists(st.integers(0, 59),
                                                                    max_size=5))
def test_every_used_row_reads_its_own_segment(n: int, lags: list[int], cuts: list[int],
                                              nans: list[int]) -> None:
    y = np.arange(n, dtype=float)
    u = 1000 + np.arange(n, dtype=float)
    for i in nans:
        if i < n:
            u[i] = np.nan
    seg = np.zeros(n, dtype=np.int64)
    for c in cuts:
        if c < n:
            seg[c:] += 1
    spec = RegressorSpec.parse(",".join(f"u[k-{lag}]" for lag in lags) + ",y[k-1]", ["y"])
    try:
        reg = build(_table(y, u, seg), spec)
    except IdentError:
        return
    for row, x in zip(reg.rows, reg.X, strict=True):
        for term, value in zip(spec.terms, x, strict=True):
            src = row - term.lag
            assert seg[src] == seg[row]
            assert value == (u if term.name == "u" else y)[src]
    assert len(reg.rows) + reg.n_skipped == n
