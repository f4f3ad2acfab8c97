"""The default rate model: input families, lags and one-line refusals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident.defaults import INPUT_LAGS, OUTPUT_LAGS, default_model


def _table(*cols: str) -> pd.DataFrame:
    frame = pd.DataFrame({c: np.zeros(4) for c in cols},
                         index=pd.Index(np.arange(4.0), name="t"))
    frame.attrs["mapping"] = {"u_roll": "actuator_controls_0.control[0]"}
    return frame


def test_sticks_first_with_thrust_and_sources() -> None:
    model = default_model(_table("p", "q", "r", "u_roll", "u_pitch", "u_yaw", "u_thrust",
                                 "sp_p", "sp_q", "sp_r"))
    assert model.inputs == ["u_roll", "u_pitch", "u_yaw", "u_thrust"]
    assert model.spec.outputs == ("p", "q", "r")
    assert model.spec.text.startswith("p[k-1],p[k-2],p[k-3],p[k-4],q[k-1]")
    assert len(model.spec.terms) == 3 * OUTPUT_LAGS + 4 * INPUT_LAGS
    assert (OUTPUT_LAGS, INPUT_LAGS) == (4, 6)  # the lag study in docs/identify.md
    assert "actuator_controls_0.control[0]" in model.note


def test_setpoints_when_no_sticks_and_custom_lags() -> None:
    model = default_model(_table("p", "q", "r", "sp_p", "sp_q", "sp_r"), 1, 1)
    assert model.family == "rate setpoints"
    assert model.spec.text == "p[k-1],q[k-1],r[k-1],sp_p[k-1],sp_q[k-1],sp_r[k-1]"


def test_all_nan_inputs_do_not_count() -> None:
    table = _table("p", "q", "r", "u_roll", "u_pitch", "u_yaw", "m1", "m2", "m3", "m4")
    table["u_yaw"] = np.nan
    assert default_model(table).family == "motor outputs"


def test_refusals_list_the_columns() -> None:
    with pytest.raises(IdentError, match="needs p, q, r: no data in r; the table has: p, q"):
        default_model(_table("p", "q"))
    with pytest.raises(IdentError, match="the table has: p, q, r, alt"):
        default_model(_table("p", "q", "r", "alt"))
