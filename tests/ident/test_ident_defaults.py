"""The default rate model and identify's defaults: input families, lags, eTS parameters and
one-line refusals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ets.params import DEFAULTS
from etsid.ident import IdentConfig, RegressorSpec, identify
from etsid.ident.defaults import default_model
from etsid.ident.synthetic import rate_table


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
    lags = {c: sorted(t.lag for t in model.spec.terms if t.name == c) for c in model.spec.columns}
    assert lags["p"] == lags["q"] == lags["r"] == [1, 2, 3, 4]
    assert all(lags[u] == [1, 2, 3, 4, 5, 6] for u in model.inputs)
    assert len(model.spec.terms) == 3 * 4 + 4 * 6
    assert "actuator_controls_0.control[0]" in model.note


@pytest.fixture(scope="module")
def default_run() -> object:
    return identify(rate_table(2500, seed=3))


def test_identify_defaults_see_80_ms_of_rates_and_120_ms_of_commands(default_run) -> None:
    # docs/identify.md: 4 output and 6 input lags at the 50 Hz identification rate
    rate = default_run.metrics["sample_rate"]["rate_hz"]
    assert rate == pytest.approx(50.0)
    terms = RegressorSpec.from_dict(default_run.rules["regressors"]).terms
    window = {name: max(t.lag for t in terms if t.name == name) / rate
              for name in {t.name for t in terms}}
    assert {n: window[n] for n in ("p", "q", "r")} == pytest.approx(
        {"p": 0.08, "q": 0.08, "r": 0.08})
    assert all(w == pytest.approx(0.12) for n, w in window.items() if n.startswith("u_"))


def test_identify_ets_parameters_differ_from_ets_only_where_documented(default_run) -> None:
    used = default_run.rules["params"]
    changed = {k for k, v in DEFAULTS.to_dict().items() if used[k] != v}
    assert changed == {"radius", "max_rules", "history_every", "utility_threshold",
                       "adaptive_spread", "forgetting"}
    assert (used["radius"], used["max_rules"], used["history_every"]) == (2.0, 30, 250)
    # identify keeps the ETS defaults from before the defaults study (issue 11)
    assert (used["utility_threshold"], used["adaptive_spread"], used["forgetting"]) == (
        0.05, False, 1.0)


def test_identify_with_defaults_equals_the_documented_values_passed(default_run) -> None:
    explicit = IdentConfig(output_lags=4, input_lags=6, radius=2.0, omega=1000.0,
                           variant="ets+", max_rules=30, rls="local", forgetting=1.0,
                           validate=0.3, ident_rate=50.0, inputs="auto", normalise="learn")
    run = identify(rate_table(2500, seed=3), explicit)
    pd.testing.assert_frame_equal(run.predictions, default_run.predictions)
    assert run.rules == default_run.rules


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
