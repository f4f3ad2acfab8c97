"""A third-party simulator pair (benchmarks/gap_thirdparty.py) is an ingestible log pair
whose hidden effect is physically present in the raw data.

PyFlyt (PyBullet) flies its Crazyflie quadrotor twice, the "recording" with 15 % less
thrust per rotor; both flights go through etsid's MCAP writer and back through its reader.
A thrust-scaled vehicle needs more rotor speed for the same weight: PyFlyt's thrust is
k (throttle · max rpm)², so its hover motor output must rise by 1/√0.85 ≈ 1.085.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("PyFlyt", reason="third-party simulator PyFlyt not installed "
                                     "(pip install -e '.[bench]')")

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from thirdparty import pyflyt_pairs as pf
from thirdparty.common import to_table

from etsid.gap.signals import prepare
from etsid.ingest import read_log
from etsid.sim.writers import write_log

SCALE = 0.85


def _hover_command(path: Path) -> tuple[float, float, int]:
    """(median mean motor output while airborne, airborne s, motor count) of a log."""
    flight = prepare(read_log(path), path.name)
    assert flight.inputs == "motors"
    motors = flight.motors[flight.airborne]
    return float(np.median(motors.mean(axis=1))), flight.airborne_s, motors.shape[1]


def test_thrust_scaled_recording_hovers_at_a_higher_command(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    vehicle = pf.random_vehicle(rng)
    commands = []
    for name, fx, seed in (("sim", {}, 11), ("real", {"thrust_scale": SCALE}, 12)):
        sensors = pf.sensors(rng, name == "real", {})
        rec = pf.fly("hover", 24.0, seed, vehicle, fx, sensors)
        table = to_table(rec, sensors, rng, f"pyflyt {name}")
        path = write_log(table, tmp_path / f"{name}{pf.LOG_SUFFIX}", rates=pf.LOG_RATES)
        command, airborne_s, n_motors = _hover_command(path)
        assert n_motors == 4
        assert airborne_s > 8.0, f"{name}: only {airborne_s:.1f} s airborne"
        commands.append(command)
    ratio = commands[1] / commands[0]
    assert ratio == pytest.approx(1.0 / np.sqrt(SCALE), abs=0.025), commands
