"""A tiny simulated fleet, written once per test session with the real log writers."""

from __future__ import annotations

from pathlib import Path

import pytest

FORMATS = ("a.tlog", "sub/b.bag", "sub/c.db3", "d.mcap")
"""One simulated flight per format; ``c.db3`` becomes the ROS 2 bag directory ``sub/c/``."""


@pytest.fixture(scope="session")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``fleet/``: four logs in four formats (one a ROS 2 bag directory) and a broken tlog."""
    from etsid.sim import simulate
    from etsid.sim.writers import write_log

    root = tmp_path_factory.mktemp("fleet")
    (root / "sub").mkdir()
    for seed, name in enumerate(FORMATS):
        flight = simulate("steps", duration=8.0, seed=seed, rate_hz=250.0)
        write_log(flight.table, root / name)
    (root / "broken.tlog").write_bytes(b"\xfe\x00 this is not a telemetry log")
    (root / "notes.txt.bak").write_text("not a log")
    return root


@pytest.fixture(scope="session")
def fleet_logs(fleet: Path) -> list[str]:
    """The five inputs of :func:`fleet` as directory discovery finds them."""
    from etsid.batch import find_inputs

    return find_inputs([fleet])
