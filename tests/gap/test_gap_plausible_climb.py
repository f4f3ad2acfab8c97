"""The climb check of a velocity estimate reads the earth-frame down velocity: in forward
flight the body z velocity carries the forward speed through the pitch, which is not a
climb (it dropped every velocity of etsid's forward-flight pairs, and rotor drag with it)."""

from __future__ import annotations

import numpy as np

from etsid.gap.plausible import down_velocity, velocity_problem
from etsid.gap.signals import Flight, _body_velocity


def _level_forward_flight(speed: float, pitch: float, n: int = 3000, fs: float = 100.0
                          ) -> Flight:
    """Level flight north at ``speed`` m/s, nose down by ``pitch`` rad, height constant."""
    t = np.arange(n) / fs
    att = np.column_stack([np.zeros(n), np.full(n, -pitch), np.zeros(n)])
    vned = np.column_stack([np.full(n, speed), np.zeros(n), np.zeros(n)])
    return Flight(name="f", t=t, fs=fs, motors=np.full((n, 4), 0.5), inputs="motors",
                  rates=np.zeros((n, 3)), acc=np.zeros((n, 3)), att=att,
                  v_body=_body_velocity(vned, att), alt=np.full(n, 5.0),
                  vbat=np.full(n, np.nan), airborne=np.ones(n, dtype=bool),
                  have={"vel", "att", "alt"})


def test_forward_speed_through_the_pitch_is_not_a_climb():
    flight = _level_forward_flight(3.0, 0.15)
    assert abs(np.mean(flight.v_body[:, 2])) > 0.4  # body z reads 0.45 m/s
    assert np.max(np.abs(down_velocity(flight))) < 1e-12
    assert velocity_problem(flight) is None


def test_a_down_velocity_the_height_does_not_follow_still_drifts():
    flight = _level_forward_flight(3.0, 0.15)
    att = flight.att
    vned = np.column_stack([np.full(att.shape[0], 3.0), np.zeros(att.shape[0]),
                            np.full(att.shape[0], 0.5)])  # says descending 0.5 m/s
    flight.v_body = _body_velocity(vned, att)
    problem = velocity_problem(flight)
    assert problem is not None and "climb" in problem


def test_rotor_drag_in_forward_flight_is_named_by_the_default_method():
    """A held-out concealed pair (forward flight at 4–7 m/s, rotor drag added): with the
    body-z climb check the velocity was dropped and a torque offset was named (0/6
    of the held-out seeds); with the earth-frame one, rotor drag."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from gap_concealed import make_pair

    from etsid.gap.run import analyse

    sim, real, truth = make_pair("rotor_drag", 20202)
    data = analyse(sim, real, "SIM", "REAL").data
    assert truth["effects"] == ["rotor_drag"]
    assert [e["name"] for e in data["effects"]] == ["rotor_drag"]
    assert not any("integrates to a climb" in n for n in data["notes"])
