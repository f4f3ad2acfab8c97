"""Actuator outputs that never move while airborne are not rotors (issue 39)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.gap.signals import prepare
from etsid.ingest import read_log
from etsid.ingest.outputs import drop_unused_outputs, unused_outputs

SHARED = next((p / "shared" / "data" / "logs" for p in Path(__file__).resolve().parents
               if (p / "shared" / "data" / "logs").is_dir()), Path("shared/data/logs"))
DATA = Path(__file__).resolve().parents[1] / "data"


def _real(name: str) -> pd.DataFrame:
    for folder in (DATA, SHARED):
        if (folder / name).exists():
            return read_log(folder / name)
    pytest.skip(f"{name} not here (the shared real logs are not shipped)")


def _with_spare_outputs(table: pd.DataFrame) -> pd.DataFrame:
    """A real quad's table with the four spare outputs PX4 logs for a quad on an 8-output
    group: two at a disarmed 0.512, two at zero, with a flicker of quantisation."""
    out = table.copy()
    n = len(out)
    rng = np.random.default_rng(3)
    out["m5"] = 0.512 + 0.001 * rng.integers(0, 2, n)
    out["m6"] = 0.512
    out["m7"] = 0.0
    out["m8"] = 0.0
    out.attrs = dict(table.attrs)
    return out


def test_a_quad_logging_eight_outputs_is_a_quad() -> None:
    table = _with_spare_outputs(_real("px4_v6c_quad_lowhover_real.ulg"))
    assert sorted(unused_outputs(table)) == ["m5", "m6", "m7", "m8"]
    out = drop_unused_outputs(table)
    assert [c for c in out.columns if c[0] == "m" and c[1:].isdigit()] == \
        ["m1", "m2", "m3", "m4"]
    assert set(out.attrs["unused_outputs"]) == {"m5", "m6", "m7", "m8"}
    assert "constant 0.512" in out.attrs["unused_outputs"]["m6"]
    assert any("left out of the rotor count (4 rotors)" in w for w in out.attrs["warnings"])
    assert prepare(out, "quad").motors.shape[1] == 4


def test_a_replay_of_that_quad_accepts_a_quad_vehicle() -> None:
    from etsid.sim.replay import replay

    table = drop_unused_outputs(_with_spare_outputs(_real("px4_v6c_quad_lowhover_real.ulg")))
    short = table.loc[:8.0]
    short.attrs = dict(table.attrs)
    assert replay(short, "quad250", mode="motors").table is not None


def test_every_output_of_a_real_octocopter_moves() -> None:
    table = _real("px4_coaxocto_manual_real.ulg")
    assert unused_outputs(table) == {}
    assert [c for c in table.columns if c[0] == "m" and c[1:].isdigit()] == \
        [f"m{i}" for i in range(1, 9)]


def test_a_still_output_between_moving_ones_is_kept_and_named() -> None:
    """The CubeOrange log's output 3 reads 0 throughout while 1, 2 and 4-8 move: its place in
    the mixer matters (a stopped motor is a fault), so it stays, with a warning."""
    table = _real("px4_cubeorange_real.ulg")
    assert "m3" in table.columns and "unused_outputs" not in table.attrs
    assert any("m3 never moves" in w for w in table.attrs["warnings"])
