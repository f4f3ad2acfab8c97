"""Active outputs and rotor geometry."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.errors import FitError
from etsid.fit.layout import active_motors, rotor_layout


def _table(n_active: int, parked: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    cols = {f"m{i + 1}": 0.5 + 0.05 * rng.normal(size=200) for i in range(n_active)}
    for j in range(parked):
        cols[f"m{n_active + j + 1}"] = np.full(200, 0.3)
    t = pd.DataFrame(cols, index=pd.Index(np.arange(200) * 0.01, name="t"))
    t.attrs["source"] = "x.ulg"
    return t


def test_parked_outputs_are_left_out_and_named() -> None:
    used, parked = active_motors(_table(4, parked=2))
    assert used == ["m1", "m2", "m3", "m4"]
    assert parked == ["m5", "m6"]


def test_standard_layout_is_declared_when_the_log_has_no_geometry() -> None:
    lay = rotor_layout(_table(6), [f"m{i}" for i in range(1, 7)])
    assert lay["n"] == 6 and not lay["arm_known"]
    assert "declared" in lay["source"]


def test_log_geometry_in_metres_gives_the_arm_and_nominal_units_do_not() -> None:
    t = _table(4)
    t.attrs["motor_layout"] = {"x": [0.1, -0.1, 0.1, -0.1], "y": [0.1, -0.1, -0.1, 0.1],
                               "spin": [1, 1, -1, -1]}
    lay = rotor_layout(t, ["m1", "m2", "m3", "m4"])
    assert lay["arm_known"] and lay["arm"] == pytest.approx(0.1414, rel=1e-3)
    assert lay["angles_deg"][0] == pytest.approx(45.0)
    t.attrs["motor_layout"] = {"x": [1, -1, 1, -1], "y": [1, -1, -1, 1], "spin": [1, 1, -1, -1]}
    lay = rotor_layout(t, ["m1", "m2", "m3", "m4"])
    assert not lay["arm_known"] and lay["angles_deg"][1] == pytest.approx(225.0)


def test_too_few_motors_is_a_one_line_error_naming_the_file() -> None:
    with pytest.raises(FitError, match=r"x\.ulg: 2 active motor output"):
        rotor_layout(_table(2), ["m1", "m2"])


def test_a_fixed_wing_log_is_refused_not_taken_for_an_octocopter() -> None:
    t = _table(8)
    t.attrs["vehicle"] = "fixed wing"
    with pytest.raises(FitError, match="multirotors only"):
        rotor_layout(t, [f"m{i}" for i in range(1, 9)])
