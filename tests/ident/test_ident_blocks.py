"""Blocked validation (etsid/ident/blocks.py): where the blocks sit, that each is scored by
a model that never saw it, and a flight whose held-out tail is a near-still hover is judged
on the blocks (or said to be not validated) instead of on noise."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ident import IdentConfig, identify
from etsid.ident.blocks import (
    STILL_SHARE,
    block_bounds,
    blocked_validation,
    not_validated_line,
)
from etsid.ident.defaults import default_model
from etsid.ident.evaluate import persistence
from etsid.ident.flight import EXCITE_STD
from etsid.ident.regressors import build
from etsid.ident.resample import decimate
from etsid.ident.synthetic import rate_table


def test_blocks_spread_over_the_excited_rows() -> None:
    excited = np.zeros(2000, dtype=bool)
    excited[1000:] = True  # the first half is still: quantiles count excited rows only
    bounds = block_bounds(excited, 0.3)
    assert bounds == [(1400, 1500), (1600, 1700), (1800, 1900)]
    assert block_bounds(excited, 0.0) == [] and block_bounds(np.zeros(50, bool), 0.3) == []


def _still_tail_table(seed: int = 3, tail_scale: float = 0.08):
    table = rate_table(15000, seed=seed, sigma=0.01, segments=1)
    t = table.index.to_numpy()
    tail = t >= 0.55 * t[-1]  # the validation part (last 30 % of excited rows) is inside
    for c in ("u_roll", "u_pitch", "u_yaw"):
        table.loc[tail, c] *= tail_scale
    fresh = rate_table(15000, seed=seed, sigma=0.01, segments=1)  # same noise, new commands
    fresh[["u_roll", "u_pitch", "u_yaw"]] = table[["u_roll", "u_pitch", "u_yaw"]].to_numpy()
    return _simulate(fresh)


def _simulate(table):
    """Re-run rate_table's loops on the table's (edited) commands."""
    from etsid.ident.synthetic import GAIN, TAU

    u = table[["u_roll", "u_pitch", "u_yaw"]].to_numpy()
    dt = float(table.index[1] - table.index[0])
    x = np.zeros((len(u), 3))
    for k in range(1, len(u)):
        cmd = u[k - 1]
        x[k] = x[k - 1] + dt * (GAIN * cmd * (1.0 + 0.5 * np.abs(cmd)) - x[k - 1]) / TAU
    noise = np.random.default_rng(9).normal(scale=0.01, size=x.shape)
    table[["p", "q", "r"]] = x + noise
    return table


def test_each_block_is_scored_by_a_model_that_never_saw_it() -> None:
    table = decimate(rate_table(12000, seed=5, sigma=0.01, segments=1), 50.0)
    spec = default_model(table).spec
    reg = build(table, spec)
    excited = np.ones(len(reg.X), dtype=bool)
    persist = persistence(reg, spec, table)
    config = IdentConfig(structure="arx")
    first = blocked_validation(reg, spec, config, excited, 0.3, len(table), persist,
                               EXCITE_STD)
    end0 = int(np.searchsorted(reg.t, first["blocks"][0]["t_end"], side="right"))
    spoilt = build(table, spec)
    spoilt.Y[end0:] = spoilt.Y[end0:] * -3.0 + 1.0  # everything after block 0 is garbage
    second = blocked_validation(spoilt, spec, config, excited, 0.3, len(table),
                                persistence(spoilt, spec, table), EXCITE_STD)
    assert second["blocks"][0] == first["blocks"][0]  # block 0 knew nothing after itself
    assert second["blocks"][2] != first["blocks"][2]


@pytest.fixture(scope="module")
def still_tail_run():
    return identify(_still_tail_table(), IdentConfig(segments="all"))


def test_a_still_tail_is_judged_on_the_blocks(still_tail_run) -> None:
    metrics = still_tail_run.metrics
    tail = metrics["validation"]["tail_motion"]
    notes = still_tail_run.config["model"]["notes"]
    for y in ("p", "q"):
        assert not tail[y]["informs"]
        assert tail[y]["std_tail"] < STILL_SHARE * tail[y]["std_flight"]
        assert tail[y]["std_tail"] >= EXCITE_STD  # moves, but is a near-still hover
        one = metrics["outputs"][y]["validation"]["one_step"]
        assert one["informative"] is False and "still against the flight" in one["reason"]
        line = next(n for n in notes if n.startswith(f"warning: {y}: the validation part is "
                                                     "still against the flight"))
        assert "judged on the blocks" in line
        blocked = metrics["validation_blocks"]["outputs"][y]
        assert blocked["informative"]
        # one rule on a near-linear system: eTS at ARX's level on the blocks, far ahead
        # of no-change
        r = blocked["one_step_rmse"]
        assert r["ets"] <= 1.02 * r["arx"] and r["ets"] < r["no-change"]
    assert any(n.startswith("blocked validation (3 blocks") for n in notes)
    assert not any(n.startswith("not validated") for n in notes)


def test_not_validated_when_nothing_moves_after_the_learning_part() -> None:
    tail = {y: {"std_tail": 0.004, "std_flight": 0.3, "informs": False} for y in "pqr"}
    still_blocks = {"outputs": {y: {"informative": False} for y in "pqr"}}
    line = not_validated_line(tail, still_blocks)
    assert line.startswith("not validated: the flight has no excited segment after the "
                           "learning part")
    moving = {"outputs": {**still_blocks["outputs"], "q": {"informative": True}}}
    assert not_validated_line(tail, moving) is None
    assert not_validated_line({**tail, "p": {**tail["p"], "informs": True}}, None) is None
