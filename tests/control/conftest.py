"""Fixtures of the control tests: closed-loop flights on the real simulator, flown once."""

from __future__ import annotations

import pytest

from etsid.control.run import ControlResult, run_control

DURATIONS = {"sine-altitude": 30.0, "altitude-steps": 25.0, "hover-ige": 20.0,
             "ige-sine": 30.0, "mass-change": 45.0}
"""Shortened flights (s) for the tests: 20 s scored after the 10 s of learning, 15 s after
the payload; docs/control.md's table uses the full scenarios."""


@pytest.fixture(scope="session")
def durations() -> dict[str, float]:
    """The shortened flight time of every scenario in :func:`flights`, s."""
    return dict(DURATIONS)


@pytest.fixture(scope="session")
def flights() -> dict[tuple[str, str], ControlResult]:
    """Every scenario flown with both controllers on the simulated Tarot 680 (seed 0)."""
    return {(sc, ctrl): run_control(sc, ctrl, seed=0, duration=d)
            for sc, d in DURATIONS.items() for ctrl in ("ets", "pid")}
