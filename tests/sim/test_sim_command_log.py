"""What a log row's motor outputs hold: the control step's snapshot or the period's mean.

The simulator's rate loop runs at the physics rate (1 kHz) on the raw gyro, so its motor
commands carry white gyro-noise jitter; a 250 Hz snapshot holds one command in four and
presents it as held for the whole 4 ms period. ``command_log="mean"`` logs what the motors
received over the period instead (docs/sim.md, "What the motor outputs of a log hold").
"""

from __future__ import annotations

import numpy as np
import pytest

from etsid.errors import SimError
from etsid.sim import simulate
from etsid.sim.params import LOG_MEAN
from etsid.sim.stepper import Simulator

N_STEPS = 400
EVERY = 4


def _fly(every: int, log_mean: bool):
    sim = Simulator("quad250", seed=3)
    sim.plant.P[LOG_MEAN] = 1.0 if log_mean else 0.0
    state = sim.hover(2.0)
    sticks = np.column_stack([0.2 * np.sin(np.arange(N_STEPS) * 0.01), np.zeros(N_STEPS),
                              np.zeros(N_STEPS)])
    _, rec = sim.step(state, N_STEPS, sticks=sticks, record_every=every)
    return rec


def test_mean_log_is_the_mean_of_each_periods_commands() -> None:
    every_step = _fly(1, False)
    mean = _fly(EVERY, True)
    sample = _fly(EVERY, False)
    motors = [f"m{i}" for i in range(1, 5)]
    per_step = np.column_stack([every_step[m] for m in motors])
    blocks = per_step.reshape(-1, EVERY, 4)
    got = np.column_stack([mean[m] for m in motors])
    np.testing.assert_allclose(got, blocks.mean(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.column_stack([sample[m] for m in motors]), blocks[:, 0])
    # the flight is the same: only the logged motor outputs differ
    np.testing.assert_array_equal(mean["p"], every_step["p"][::EVERY])
    np.testing.assert_array_equal(mean["true_w1"], sample["true_w1"])
    # the within-period jitter is not small: the snapshot is not the mean
    assert np.max(np.abs(blocks[:, 0] - blocks.mean(axis=1))) > 1e-3


def test_simulate_command_log_changes_only_the_motor_columns() -> None:
    kw = {"duration": 4.0, "seed": 5}
    a = simulate("hover-oge", "quad250", command_log="sample", **kw)
    b = simulate("hover-oge", "quad250", command_log="mean", **kw)
    motors = [c for c in a.table.columns if c.startswith("m") and c[1:].isdigit()]
    others = [c for c in a.table.columns if c not in motors]
    np.testing.assert_array_equal(a.table[others].to_numpy(), b.table[others].to_numpy())
    np.testing.assert_array_equal(a.truth.to_numpy(), b.truth.to_numpy())
    assert not np.array_equal(a.table[motors].to_numpy(), b.table[motors].to_numpy())
    assert (a.table.attrs["command_log"], b.table.attrs["command_log"]) == ("sample", "mean")


def test_unknown_command_log_is_refused() -> None:
    with pytest.raises(SimError, match="command_log"):
        simulate("hover-oge", "quad250", duration=1.0, command_log="average")
