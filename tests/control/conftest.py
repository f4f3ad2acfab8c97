"""Fixtures of the control tests: closed-loop flights on the real simulator, flown once."""

from __future__ import annotations

import pytest

from etsid.control.run import ControlResult, run_control
from etsid.control.scenarios import SCENARIOS


@pytest.fixture(scope="session")
def flights() -> dict[tuple[str, str], ControlResult]:
    """Every scenario flown with both controllers on the simulated Tarot 680 (seed 0)."""
    return {(sc, ctrl): run_control(sc, ctrl, seed=0)
            for sc in sorted(SCENARIOS) for ctrl in ("ets", "pid")}
