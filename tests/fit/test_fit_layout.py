"""Active outputs and rotor geometry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.errors import FitError
from etsid.fit.layout import STANDARD_LAYOUTS, active_motors, rotor_layout
from etsid.ingest import read_log
from etsid.ingest.ardupilot_frames import frame_layout


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


SHARED = Path(__file__).parents[2].parent / "shared" / "data" / "logs"


def test_ardupilot_x_frames_match_the_standard_layouts_and_h_reverses_the_spins() -> None:
    for cls, n in ((1, 4), (2, 6)):
        lay = frame_layout({"FRAME_CLASS": cls, "FRAME_TYPE": 1})
        angles, spins = STANDARD_LAYOUTS[n]
        assert lay is not None
        assert np.allclose(lay["angles_deg"], angles)
        assert [("ccw" if s > 0 else "cw") for s in lay["spin"]] == spins
    x = frame_layout({"FRAME_CLASS": 1, "FRAME_TYPE": 1})
    h = frame_layout({"FRAME_CLASS": 1, "FRAME_TYPE": 3})
    assert x is not None and h is not None
    assert np.allclose(h["angles_deg"], x["angles_deg"])
    assert np.allclose(h["spin"], -np.asarray(x["spin"]))
    # every table frame: as many of each spin, moment rows that cancel (a hover is possible)
    for key in [(c, t) for c in (1, 2, 3, 4) for t in (0, 1, 3)]:
        lay = frame_layout({"FRAME_CLASS": key[0], "FRAME_TYPE": key[1]})
        if lay is None:
            continue
        assert sum(lay["spin"]) == 0
        assert abs(sum(lay["x"])) < 1e-9 and abs(sum(lay["y"])) < 1e-9


def test_unread_frames_fall_back_to_the_count() -> None:
    assert frame_layout({"FRAME_CLASS": 5, "FRAME_TYPE": 10}) is None   # Y6B: not on a circle
    assert frame_layout({"FRAME": 1}) is None                           # 3.x: no class


@pytest.mark.skipif(not (SHARED / "ardupilot_copter403_hexa_loiter_real.bin").exists(),
                    reason="shared real logs not present")
def test_a_real_dataflash_log_gives_its_frame_parameters_to_the_fit() -> None:
    table = read_log(SHARED / "ardupilot_copter403_hexa_loiter_real.bin")
    motors, _ = active_motors(table)
    lay = rotor_layout(table, motors)
    assert "FRAME_CLASS 2 / FRAME_TYPE 1" in lay["source"]
    assert lay["n"] == 6 and not lay["arm_known"]


def test_px4_airframe_number_confirms_a_standard_layout_or_says_it_is_not_laid_out() -> None:
    t = _table(4)
    t.attrs["log"] = {"sys_autostart": 4001}
    assert "SYS_AUTOSTART 4001 (quad X family) confirms it" in rotor_layout(
        t, ["m1", "m2", "m3", "m4"])["source"]
    t.attrs["log"] = {"sys_autostart": 5001}
    assert "(quad + family) is not laid out: declared" in rotor_layout(
        t, ["m1", "m2", "m3", "m4"])["source"]
    t.attrs["log"] = {"sys_autostart": 13014}
    with pytest.raises(FitError, match="SYS_AUTOSTART 13014 is a PX4 VTOL airframe"):
        rotor_layout(t, ["m1", "m2", "m3", "m4"])


@pytest.mark.skipif(not (SHARED / "px4_coaxocto_manual_real.ulg").exists(),
                    reason="shared real logs not present")
def test_a_real_ulog_gives_its_airframe_number_to_the_fit() -> None:
    table = read_log(SHARED / "px4_coaxocto_manual_real.ulg")
    motors, _ = active_motors(table)
    assert "SYS_AUTOSTART 12001 (octo coax family) confirms it" in rotor_layout(
        table, motors)["source"]
