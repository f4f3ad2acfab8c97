"""A gyro bias moves SIM's rate terms too: the rotor damping and gyroscopic products of the
angular-acceleration laws act on the true rate, the logged rate less the bias. Checked
against the laws evaluated on unbiased rates (end to end: the gap benchmarks' gyro-bias
pairs, ``benchmarks/gap_calibrate.py``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from etsid.gap.candidates import LIBRARY, Context
from etsid.gap.nominal import Mods, fit_nominal
from etsid.gap.signals import prepare
from etsid.sim import simulate

VEHICLE = "quad250"
BIAS = (0.04, -0.03, 0.02)


@pytest.fixture(scope="module")
def sim_flight():
    return prepare(simulate("hover-oge", VEHICLE, duration=20.0, seed=5, amplitude=0.4,
                            alt_wander=0.3).table, "SIM")


@pytest.mark.parametrize("extra", [Mods(), Mods(damping=2.0, yaw_damping=1.0),
                                   Mods(inertia=1.3)])
def test_a_rate_bias_predicts_what_the_laws_give_on_the_unbiased_rates(sim_flight, extra):
    """Known answer: the model fed the logged rates under ``rate_bias = b`` is the model fed
    the rates less ``b`` (its damping, gyroscopic and any added damping terms alike; the
    rate terms divided by an inertia scale as every other torque of the law is)."""
    nominal = fit_nominal(sim_flight)
    biased = replace(extra, rate_bias=BIAS)
    got = nominal.predict_unfiltered(sim_flight, biased, ("p", "q", "r"))
    shifted = replace(sim_flight, rates=sim_flight.rates - np.array(BIAS))
    want = nominal.predict_unfiltered(shifted, extra, ("p", "q", "r"))
    for c in ("p", "q", "r"):
        assert np.allclose(got[c], want[c], rtol=1e-9, atol=1e-12), c
    # and the bias moves the prediction at all: SIM's roll law has a rate term
    plain = nominal.predict_unfiltered(sim_flight, extra, ("p",))["p"]
    assert np.max(np.abs(got["p"] - plain)) > 1e-4


def test_both_gyro_bias_laws_carry_the_bias_into_the_rate_terms(sim_flight):
    nominal = fit_nominal(sim_flight)
    ctx = Context(sim_flight, nominal, None, None, None)
    laws = [c for c in LIBRARY if c.name == "gyro_bias"]
    assert len(laws) == 2  # with and without the estimator's lean
    for law in laws:
        theta = np.zeros(len(law.params))
        theta[:3] = BIAS
        mods = law.build(theta, ctx)
        assert mods.rate_bias == pytest.approx(BIAS)
        assert {"p", "q", "r"} <= set(law.channels)
        assert [mods.offset[c] for c in ("gyro_p", "gyro_q", "gyro_r")] == pytest.approx(BIAS)
