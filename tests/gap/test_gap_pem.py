"""Roll and pitch as one-step prediction errors (etsid.gap.pem): innovations that are white
under SIM's own noise, a no-effect flight at SIM's innovation level, and a known command
delay found where the objective is least."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.candidates import Context
from etsid.gap.fitting import Scorer
from etsid.gap.nominal import Mods, fit_nominal, measured
from etsid.gap.pem import PredictionErrorScorer, prediction_error_scorer
from etsid.gap.signals import prepare
from etsid.sim import simulate

FLY = dict(duration=40.0, alt_wander=0.3, amplitude=0.4)


def _scorer(sim_seed: int, real_seed: int, **settings: float
            ) -> tuple[PredictionErrorScorer, object]:
    sim = prepare(simulate("hover-oge", "quad250", seed=sim_seed, **FLY).table, "SIM")
    real = prepare(simulate("hover-oge", "quad250", seed=real_seed,
                            settings={f"vehicle.{k}": v for k, v in settings.items()},
                            **FLY).table, "REAL")
    nominal = fit_nominal(sim)
    ys = measured(real)
    base = Scorer(Context(real, nominal, None, None), ys,
                  {c: float(np.std(ys[c])) or 1.0 for c in ys})
    return prediction_error_scorer(sim, base), real


@pytest.fixture(scope="module")
def same():
    return _scorer(3, 4)


def test_roll_and_pitch_are_innovations_the_rest_the_base_residuals(same):
    pem, real = same
    res = pem.residuals()
    base = pem.base.residuals()
    for c in ("az", "r"):
        np.testing.assert_array_equal(res[c], base[c])
    for c in ("p", "q"):
        e = res[c][real.airborne][50:]
        rho = float(np.corrcoef(e[:-1], e[1:])[0, 1])
        raw = base[c][real.airborne][50:]
        rho_raw = float(np.corrcoef(raw[:-1], raw[1:])[0, 1])
        assert abs(rho) < 0.5 < rho_raw, (c, rho, rho_raw)


def test_a_flight_of_the_same_vehicle_sits_at_sims_innovation_level(same):
    pem, real = same
    z = pem.zscores(None, real.airborne, ("p", "q"))
    assert all(0.4 < v < 2.5 for v in z.values()), z


def test_an_offset_moves_only_its_channel_through_the_whitening_filter(same):
    pem, _ = same
    a = pem.prediction(None, ("p", "q"))
    b = pem.prediction(Mods(offset={"p": 2.0}), ("p", "q"))
    np.testing.assert_array_equal(a["q"], b["q"])
    gain = float(np.sum(pem.model.filters["p"]))  # the filter's gain at zero frequency
    np.testing.assert_allclose((b["p"] - a["p"])[100:], 2.0 * gain, rtol=1e-9)


def test_a_command_delay_is_least_where_it_was_flown():
    pem, real = _scorer(3, 4, time_delay=0.03)
    grid = np.array([0.0, 0.01, 0.02, 0.03, 0.04, 0.05])
    obj = [sum(pem.zscores(Mods(delay=d), real.airborne, ("p", "q")).values()) for d in grid]
    assert abs(grid[int(np.argmin(obj))] - 0.03) <= 0.0101, dict(zip(grid, obj, strict=True))
