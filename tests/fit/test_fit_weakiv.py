"""Anderson–Rubin test (etsid.fit.weakiv): its size with weak instruments and coloured
noise, its power with strong ones, and the projection of the non-rejected set."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

from etsid.fit.regress import instrument_basis
from etsid.fit.rotation import set_extremes
from etsid.fit.weakiv import ar_statistic, confidence_set, distance_set, joint_pvalue

SOS = butter(2, 0.1, output="sos")


def _flight(rng: np.random.Generator, n: int, strength: float, lag: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(y, regressor at the candidate lag, instruments): y = 2 x(true lag 3) + 1 + u, the
    regressor's noise v correlated with u (endogenous), both low-passed (coloured)."""
    z = sosfiltfilt(SOS, rng.normal(size=(n + 10, 4)), axis=0)
    e = sosfiltfilt(SOS, rng.normal(size=(n + 10, 2)), axis=0)
    u = e[:, 0]
    v = 0.8 * e[:, 0] + 0.6 * e[:, 1]
    x = strength * z @ np.array([1.0, -0.5, 0.3, 0.2]) + v
    y = 2.0 * x[7:n + 7] + 1.0 + u[10:n + 10]
    inst = np.column_stack([z[10 - k:n + 10 - k] for k in range(0, 5, 2)])
    return y, x[10 - lag:n + 10 - lag], instrument_basis(inst)


def _pvalue(rng: np.random.Generator, strength: float, lag: int) -> float:
    y, x, q = _flight(rng, 3000, strength, lag)
    st = ar_statistic([(np.column_stack([y, x, np.ones_like(y)]), q)])
    assert st is not None
    return joint_pvalue([st])


def test_the_true_candidate_is_rejected_at_most_at_the_level_with_weak_instruments() -> None:
    rng = np.random.default_rng(3)
    p = np.array([_pvalue(rng, 0.02, 3) for _ in range(150)])
    assert np.mean(p < 0.05) < 0.15    # 9 %: β itself weak here, profiled by 2SLS


def test_a_wrong_candidate_is_rejected_with_strong_instruments() -> None:
    rng = np.random.default_rng(4)
    p = np.array([_pvalue(rng, 1.0, 0) for _ in range(20)])
    assert np.mean(p < 0.05) > 0.9


def test_the_set_is_the_projection_of_the_accepted_points_and_flags_the_edge() -> None:
    taus, delays = np.array([0.01, 0.02, 0.04]), np.array([-0.01, 0.0, 0.01])
    dof = np.full((3, 3), 10.0)
    st = np.full((3, 3), 100.0)
    st[1, 1] = st[1, 2] = 5.0
    coarse = (np.array([0.005, 0.02, 0.08]), np.array([-0.02, 0.0, 0.04]),
              np.full((3, 3), 100.0), dof)
    bounds = ((0.005, 0.08), (-0.02, 0.04))
    cs = confidence_set([coarse, (taus, delays, st, dof)], bounds)
    # bounded by the accepted points' neighbours on the finest grid (the last)
    assert cs.lo == (0.01, -0.01) and cs.hi == (0.04, 0.01) and not cs.at_edge
    assert len(cs.points) == 9 and cs.misfit == 1.0
    # on a coarser grid (not the last) accepted points are not grown
    st_c = coarse[2].copy()
    st_c[1, 1] = 5.0
    cs = confidence_set([(coarse[0], coarse[1], st_c, dof), (taus, delays, st, dof)], bounds)
    assert cs.lo == (0.01, -0.01) and cs.hi == (0.04, 0.01)
    # the edge is the accepted points' (0.01 is the last d), not their neighbours'
    assert confidence_set([(taus, delays, st, dof)], ((0.005, 0.08), (-0.02, 0.01))).at_edge
    assert not confidence_set([(taus, delays, st, dof)], ((0.01, 0.08), (-0.01, 0.02))).at_edge


def test_a_model_rejected_everywhere_gives_an_empty_set_and_its_misfit() -> None:
    taus, delays = np.array([0.01, 0.02, 0.04]), np.array([-0.01, 0.0, 0.01])
    dof = np.full((3, 3), 10.0)
    st = np.full((3, 3), 1000.0)
    st[1, 1] = 50.0          # the best point too is far beyond χ²₉₅(10) = 18.3
    cs = confidence_set([(taus, delays, st, dof)], ((0.005, 0.08), (-0.02, 0.04)))
    assert cs.empty and cs.misfit == 5.0 and np.isnan(cs.lo[0])


def test_the_distance_set_scales_the_excess_by_the_misfit_and_keeps_the_best_point() -> None:
    taus, delays = np.array([0.01, 0.02, 0.04]), np.array([-0.01, 0.0, 0.01])
    dof = np.full((3, 3), 10.0)
    st = np.full((3, 3), 200.0)
    st[1, 1] = 50.0          # misfit φ = 5: the excess over 50 is divided by 5
    st[1, 2] = 79.0          # (79 − 50) / 5 = 5.8 ≤ χ²₉₅(2) = 5.99: in
    st[2, 1] = 81.0          # 6.2: out
    grids = [(taus, delays, st, dof)]
    bounds = ((0.005, 0.08), (-0.02, 0.04))
    assert confidence_set(grids, bounds).empty
    ds = distance_set(grids, bounds)
    assert not ds.empty and ds.kind == "distance" and ds.misfit == 5.0
    big = (np.array([0.01, 0.02, 0.04, 0.08, 0.16]), np.array([-0.02, -0.01, 0.0, 0.01, 0.02]))
    st5 = np.full((5, 5), 200.0)
    st5[2, 2], st5[2, 3], st5[3, 2] = 50.0, 79.0, 81.0
    ds = distance_set([(*big, st5, np.full((5, 5), 10.0))], ((0.005, 0.2), (-0.03, 0.03)))
    # accepted (0.04, 0) and (0.04, 0.01); bounded by their neighbours
    assert ds.lo == (0.02, -0.01) and ds.hi == (0.08, 0.02) and len(ds.points) == 12
    st5[3, 2] = 79.0
    ds = distance_set([(*big, st5, np.full((5, 5), 10.0))], ((0.005, 0.2), (-0.03, 0.03)))
    assert ds.hi == (0.16, 0.02)


def test_set_extremes_are_the_ends_along_tau_delay_and_the_valley() -> None:
    pts = np.array([[0.02, 0.0], [0.03, -0.004], [0.025, 0.002], [0.04, -0.01],
                    [0.032, 0.0]])
    ext = {tuple(p) for p in set_extremes(pts)}
    # τ: 0.02 / 0.04; d: −0.01 / 0.002; τ + d: 0.02 / 0.032; τ − d: 0.02 / 0.05 — never the
    # inner point (0.03, −0.004)
    assert ext == {(0.02, 0.0), (0.04, -0.01), (0.025, 0.002), (0.032, 0.0)}
    assert set_extremes(np.zeros((0, 2))).shape == (0, 2)
