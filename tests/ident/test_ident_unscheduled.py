"""``--unscheduled``: outputs of a scheduled rate model whose consequent is one linear model
shared by every rule (the yaw rate, whose physics does not change with height)."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify
from etsid.sim import simulate


@pytest.fixture(scope="module")
def flight():
    """ige-oge, seed 5 (used for no choice), 90 s: dwells in and out of ground effect."""
    return simulate("ige-oge", duration=90.0, seed=5).table


def test_unscheduled_yaw_is_one_model_equal_to_least_squares(flight) -> None:
    # rule merging off: its test on the outputs' consequents would differ with r shared
    run = identify(flight, IdentConfig(unscheduled="r", merge=False))
    rules = run.rules
    assert rules["params"]["shared_outputs"] == [2]
    assert len(rules["rules"]) >= 2  # p and q are still scheduled on altitude
    yaw = np.array([r["consequent_original_units"] for r in rules["rules"]])[:, :, 2]
    np.testing.assert_array_equal(np.ptp(yaw, axis=0), 0.0)
    pitch = np.array([r["consequent_original_units"] for r in rules["rules"]])[:, :, 1]
    assert np.ptp(pitch, axis=0).max() > 1e-3
    # one RLS over every learning sample is ARX's least squares (ridge prior aside)
    out = run.metrics["outputs"]["r"]
    ets, arx = out["validation"]["one_step"]["rmse"], out["arx"]["validation"]["one_step"]["rmse"]
    assert ets == pytest.approx(arx, rel=0.01)
    # --structure scheduled schedules every output (auto may leave some out: next test)
    default = identify(flight, IdentConfig(structure="scheduled", merge=False))
    assert default.rules["params"]["shared_outputs"] == []
    np.testing.assert_allclose(  # p and q one-step predictions do not depend on it
        run.predictions[["p_val", "q_val"]].to_numpy(),
        default.predictions[["p_val", "q_val"]].to_numpy(), rtol=1e-9, atol=1e-12)


def test_unscheduled_refusals(flight) -> None:
    with pytest.raises(IdentError, match="not an output"):
        identify(flight, IdentConfig(unscheduled="yaw"))
    with pytest.raises(IdentError, match="--antecedent"):
        identify(flight, IdentConfig(unscheduled="r", antecedent="none"))
