"""identify --antecedent: rules fire on scheduling terms, consequents on all regressors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ets import ETS
from etsid.ident import IdentConfig, identify
from etsid.ident.regressors import RegressorSpec, build


def _table(n: int = 3000, seed: int = 0) -> pd.DataFrame:
    """y[k] = g(h) (0.6 y[k-1] + u[k-1]) with a gain 1 below h = 1 and 2 above, h dwelling."""
    rng = np.random.default_rng(seed)
    h = np.where((np.arange(n) // 300) % 2 == 0, 0.3, 2.0) + 0.02 * rng.normal(size=n)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):
        g = 1.0 if h[k - 1] < 1.0 else 2.0
        y[k] = 0.6 * y[k - 1] + g * u[k - 1] + 0.01 * rng.normal()
    return pd.DataFrame({"y": y, "u": u, "h": h}, index=pd.Index(np.arange(n) * 0.02, name="t"))


def test_build_makes_s_and_spec_round_trips() -> None:
    spec = RegressorSpec.parse("y[k-1],u[k-1]", ["y"], "h[k-1]")
    assert spec.antecedent_names == ["h[k-1]"] and spec.columns == ["y", "u", "h"]
    assert RegressorSpec.from_dict(spec.to_dict()) == spec
    table = _table(50)
    reg = build(table, spec)
    np.testing.assert_array_equal(reg.S[:, 0], table["h"].to_numpy()[reg.rows - 1])
    with pytest.raises(IdentError, match="antecedent y\\[k-1\\] is an output"):
        RegressorSpec.parse("y[k-1]", ["y"], "y[k-1]")


def test_scheduled_identify_learns_regimes_and_beats_flat_rules(tmp_path) -> None:
    table = _table()
    base = dict(outputs=["y"], regressors="y[k-1],u[k-1]", segments="all", radius=0.3)
    flat = identify(table, IdentConfig(**base, max_rules=1))
    sched = identify(table, IdentConfig(**base, antecedent="h[k-1]"))
    fit_flat = flat.metrics["outputs"]["y"]["validation"]["free_run"]["fit"]
    fit_sched = sched.metrics["outputs"]["y"]["validation"]["free_run"]["fit"]
    assert fit_sched > fit_flat + 20.0 and fit_sched > 90.0
    rules = sched.rules
    assert rules["antecedents"] == {"scheduled": True, "names": ["h[k-1]"], "dimension": 1}
    assert rules["regressors"]["antecedent"] == "h[k-1]"
    path = tmp_path / "rules.json"
    path.write_text(json.dumps(rules))
    model = ETS.load(path)
    assert model.n_rules >= 2
