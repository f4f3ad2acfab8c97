"""Rotor drag's moment and yaw damping, against the simulator's own physics.

etsid's simulator puts each rotor's in-plane H-force ``−c Ω v_hub`` at its hub, above the
CG and out on its arm: a forward speed makes a pitching moment ``c ΣΩ h v / I_yy`` and a yaw
rate a yaw damping ``c ΣΩ ℓ² / I_zz``. SIM's regression carries the moment (it lacked it,
and a Tarot 680 flown faster than its simulation was named rotor drag), and the rotor-drag
effect carries both, so that a REAL with more rotor drag is that one effect (its yaw
damping was left to a second, wrong name).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from gap_concealed import make_pair, random_vehicle

from etsid.gap.nominal import fit_nominal
from etsid.gap.run import analyse
from etsid.gap.signals import prepare


def test_sims_motor_time_constant_is_recovered_in_forward_flight() -> None:
    """A Tarot 680 (τ = 50 ms) flown forward at 4–7 m/s: without the moment in the
    regression the pitch trim's drag moment bent the lag search to 37 ms behind a 10 ms
    command delay (5 ms, one log step, is the log's own)."""
    sim, _, truth = make_pair("rotor_drag", 20202)
    assert truth["vehicle"] == "tarot680"
    model = fit_nominal(prepare(sim, "SIM"))
    assert 0.045 < model.tau < 0.058
    assert model.delay <= 0.005


def test_a_vehicle_flown_faster_than_its_simulation_is_consistent() -> None:
    """A no-effect pair (one Tarot 680 build, REAL flown 1.7× faster): the moment SIM's
    physics has is in SIM's regression, so no rotor drag is named."""
    sim, real, truth = make_pair("none", 20500)
    assert truth["vehicle"] == "tarot680" and not truth["effects"]
    data = analyse(sim, real, "SIM", "REAL").data
    assert data["verdict"] == "consistent", data["summary"]


@pytest.mark.parametrize("seed", [20202, 20302])
def test_rotor_drags_moment_and_yaw_damping_follow_the_airframe(seed: int) -> None:
    """REAL's rotor drag 3–5× SIM's in forward flight, one name; its moment per m/s and its
    yaw damping within 10 % of ``d m h / I_yy`` and ``d m ℓ² / I_zz`` (``d`` the added
    drag per unit mass the truth gives, ``h`` the hub height, ``ℓ`` the arm)."""
    vehicle = random_vehicle(np.random.default_rng(seed))
    sim, real, truth = make_pair("rotor_drag", seed)
    data = analyse(sim, real, "SIM", "REAL").data
    assert [e["name"] for e in data["effects"]] == ["rotor_drag"]
    fitted = {k: v["value"] for k, v in data["effects"][0]["parameters"].items()}
    inertia = vehicle.inertia
    moment = truth["drag"] * vehicle.mass * -vehicle["frame"]["hub_z"] / inertia[1, 1]
    yaw = truth["drag"] * vehicle.mass * vehicle["frame"]["arm_length"] ** 2 / inertia[2, 2]
    assert fitted["moment"] == pytest.approx(moment, rel=0.1)
    assert fitted["yaw"] == pytest.approx(yaw, rel=0.1)
