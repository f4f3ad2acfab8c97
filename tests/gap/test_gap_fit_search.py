"""The ground-effect fit reaches the objective's minimum, not a bound of its radius."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.candidates import BY_NAME, LIBRARY, ground_search
from etsid.gap.fitting import SCALAR_GRID, _mods, _scalar_search, channels_of, fit_candidates
from etsid.gap.run import analyse
from etsid.sim import simulate


def test_ground_search_coordinates_are_log_excess_at_median_height() -> None:
    sim = simulate(scenario="hover-ige", vehicle="quad250", duration=20.0, altitude=0.17,
                   alt_wander=0.09, seed=3, ground_effect=False)
    ctx = analyse(sim.table, sim.table).series["scorer"].ctx
    m = ground_search(ctx)
    z_ref = float(np.median(ctx.flight.alt[ctx.flight.airborne]))
    for theta in ([0.06, 2.0], [0.02, 0.78], [0.4, 1.4]):
        s = m.to_search(np.array(theta))
        np.testing.assert_allclose(m.to_theta(s), theta, rtol=1e-12)
        # s[0] is the log of the law's term (R/4z)^n at the median flown height
        assert s[0] == pytest.approx(np.log((theta[0] / (4.0 * z_ref)) ** theta[1]), rel=1e-12)


def _low_hover_fit(cand, seed: int):
    """(fit, objective) of ground-effect law ``cand`` on a quad250 hovering at 0.17 m on the
    multirotor law (REAL, seed ``seed + 1``) against the same flight without ground effect
    (SIM, ``seed``): the objective is the fit's, on its own samples."""
    low = dict(scenario="hover-ige", vehicle="quad250", duration=30.0, altitude=0.17,
               alt_wander=0.09)
    sim = simulate(**low, seed=seed, ground_effect=False)
    real = simulate(**low, seed=seed + 1, ground_effect=True,
                    settings={"vehicle.ground.model": "sanchez-cuevas"})
    result = analyse(sim.table, real.table)
    scorer, mask = result.series["scorer"], result.series["fit"]
    chans = channels_of((cand,), scorer)

    def f(theta: list[float]) -> float:
        return scorer.objective(_mods((cand,), np.array(theta), scorer.ctx), mask, chans)

    return fit_candidates((cand,), scorer, mask), f


def test_ground_effect_fit_is_the_grid_minimum_on_small_quad() -> None:
    """quad250 on the multirotor law: the fitted (R, n) does at least as well on the fit
    data as the best point of a dense grid. In (R, n) the data fix only a curved valley of
    equal excess; the bounded search in those coordinates stalled in it (on a benchmark pair
    at the lower bound R = 0.02 m with a law flatter than the data's best)."""
    cand = BY_NAME["ground_effect"]
    fit, f = _low_hover_fit(cand, 21)
    grid = min(f([r, n]) for r in np.geomspace(0.02, 1.5, 30)
               for n in np.geomspace(0.6, 3.0, 30))
    assert f(list(fit.theta)) <= grid + 1e-6
    assert fit.theta[0] > 0.021  # not on the radius bound


def test_a_one_parameter_search_refines_every_basin_not_the_lowest_grid_point() -> None:
    """Known answer: a delay's objective in a loop ringing with period 110 ms repeats every
    110 ms, rising slowly away from the true 31 ms. On the 25 ms grid over 0-0.3 s the
    point nearest an alias (0.25 s) is lower than the one nearest the truth (0.025 s); the
    search must still return 31 ms."""
    true, period = 0.031, 0.11

    def objective(v: float) -> float:
        return float(1.0 - np.cos(2 * np.pi * (v - true) / period) + 0.2 * abs(v - true))

    grid = np.linspace(0.0, 0.3, SCALAR_GRID)
    assert grid[int(np.argmin([objective(v) for v in grid]))] == pytest.approx(0.25)
    assert _scalar_search(objective, 0.0, 0.3)[0] == pytest.approx(true, abs=1e-3)


def test_the_exponential_ground_law_fit_beats_a_dense_grid_on_small_quad() -> None:
    """quad250 on the multirotor law, the exponential law per hub (excess, decay, arm): the
    fit does at least as well on the fit data as the best point of a dense grid. Its three
    parameters trade off along a valley; a local search from the coarse grid's best point
    alone stalled there (benchmark pairs: objective 7.7 where a start from another grid
    point reaches 3.8, and the located band 0.04 m too high)."""
    cand = next(c for c in LIBRARY if c.name == "ground_effect" and len(c.params) == 3)
    fit, f = _low_hover_fit(cand, 31)
    grid = min(f([e, d, a]) for e in np.linspace(0.05, 1.0, 12)
               for d in np.geomspace(0.02, 0.5, 12) for a in np.linspace(0.0, 0.3, 12))
    assert f(list(fit.theta)) <= grid + 1e-6


def test_a_pair_fits_at_least_as_well_as_its_lead_alone() -> None:
    """A pair's search starts from the lower of its two single fits together and its lead's
    fit with the other at no effect. Two look-alikes' fits together count the change twice
    (a thrust ×0.85 and a mass ×1.17 at once: ×0.73); the lead's alone is where the pair
    search must not end above. Known answer: REAL's thrust is ×0.85, its mass unchanged."""
    kw = dict(scenario="hover-oge", vehicle="quad250", duration=30.0, alt_wander=0.3)
    sim = simulate(**kw, seed=4).table
    real = simulate(**kw, seed=5, settings={"vehicle.thrust_scale": 0.85}).table
    result = analyse(sim, real)
    scorer, mask = result.series["scorer"], result.series["fit"]
    lead, other = BY_NAME["thrust_scale"], BY_NAME["mass"]
    chans = channels_of((lead, other), scorer)

    def f(theta: np.ndarray) -> float:
        return scorer.objective(_mods((lead, other), theta, scorer.ctx), mask, chans)

    lead_fit = fit_candidates((lead,), scorer, mask)
    other_fit = fit_candidates((other,), scorer, mask)
    together = np.concatenate([lead_fit.theta, other_fit.theta])
    alone = np.concatenate([lead_fit.theta, other.null_theta()])
    assert f(together) > 10 * f(alone)  # the change counted twice
    pair = fit_candidates((lead, other), scorer, mask, x0=[together, alone])
    assert f(pair.theta) <= f(alone) + 1e-9
    assert pair.theta[0] == pytest.approx(0.85, abs=0.02)
    assert pair.theta[1] == pytest.approx(1.0, abs=0.03)
