"""Fit one candidate (or two jointly) on the first part of REAL; score any model on a mask.

The objective is the noise-normalised mean squared residual, summed over the channels the
effect(s) act on: ``J = Σ_c mean((y_c − ŷ_c)²) / σ_c²``, with ``σ_c`` the nominal model's
held-out error on SIM itself. Parameter uncertainty is the Gauss–Newton standard error
from the curvature of ``J`` with the effective sample count of low-passed residuals.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from etsid.gap.candidates import Candidate, Context, merge
from etsid.gap.nominal import CUTOFF_HZ, Mods


@dataclass
class Fit:
    """A fitted candidate set.

    Attributes
    ----------
    candidates : tuple of Candidate
        One or two candidates.
    theta : ndarray
        Fitted parameters, concatenated in candidate order.
    stderr : ndarray
        Standard errors of ``theta``.
    mods : Mods
        The model change at ``theta``.
    bound_cost : ndarray
        (n_params, 2): the fitting objective with one parameter moved to its lower (upper)
        search bound, the others held, minus its value at ``theta``; NaN at a bound that is
        the law's no-effect value (verdict rule 3, :func:`etsid.gap.verdict.at_bound`).
    """

    candidates: tuple[Candidate, ...]
    theta: np.ndarray
    stderr: np.ndarray
    mods: Mods
    bound_cost: np.ndarray | None = None

    @property
    def name(self) -> str:
        """``a`` or ``a+b``."""
        return "+".join(c.name for c in self.candidates)

    @property
    def n_params(self) -> int:
        """Number of fitted parameters."""
        return int(self.theta.size)

    def _per_candidate(self, rows: np.ndarray) -> list[tuple[Candidate, np.ndarray, np.ndarray]]:
        """(candidate, its theta, its rows of ``rows``) per candidate."""
        out, i = [], 0
        for c in self.candidates:
            k = len(c.params)
            out.append((c, self.theta[i:i + k], rows[i:i + k]))
            i += k
        return out

    def split(self) -> list[tuple[Candidate, np.ndarray, np.ndarray]]:
        """(candidate, its theta, its stderr) per candidate."""
        return self._per_candidate(self.stderr)

    def split_bounds(self) -> list[tuple[Candidate, np.ndarray, np.ndarray]]:
        """(candidate, its theta, its rows of :attr:`bound_cost`) per candidate."""
        return self._per_candidate(self.bound_cost if self.bound_cost is not None
                                   else np.full((self.theta.size, 2), np.nan))


class Scorer:
    """Residuals of the nominal model (changed by candidates) on REAL, per channel.

    Parameters
    ----------
    ctx : Context
        REAL flight, nominal model and geometry.
    measured : dict
        Filtered measured channels of REAL.
    sigma : dict
        Channel → nominal held-out RMSE on SIM (noise and model error).
    """

    def __init__(self, ctx: Context, measured: dict[str, np.ndarray],
                 sigma: dict[str, float]) -> None:
        self.ctx = ctx
        self.measured = measured
        self.sigma = sigma

    def prediction(self, mods: Mods | None = None,
                   channels: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """The model's prediction per channel (full length), in the space the residuals
        are taken in."""
        return self.ctx.nominal.predict(self.ctx.flight, mods, channels)

    def residuals(self, mods: Mods | None = None,
                  channels: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Measured minus predicted, per channel (full length)."""
        pred = self.prediction(mods, channels)
        return {c: self.measured[c] - pred[c] for c in pred if c in self.measured}

    def zscores(self, mods: Mods | None, mask: np.ndarray,
                channels: tuple[str, ...] | None = None) -> dict[str, float]:
        """Channel → mean squared residual over ``mask`` divided by ``σ_c²``."""
        res = self.residuals(mods, channels)
        chans = channels or tuple(res)
        return {c: float(np.mean(res[c][mask] ** 2) / self.sigma[c] ** 2)
                for c in chans if c in res}

    def objective(self, mods: Mods, mask: np.ndarray, channels: tuple[str, ...]) -> float:
        """Sum of the normalised mean squared residuals of ``channels`` over ``mask``."""
        return float(sum(self.zscores(mods, mask, channels).values()))

    def objectives(self, mods: Mods, masks: list[np.ndarray], channels: tuple[str, ...]
                   ) -> list[float]:
        """:meth:`objective` over each of ``masks``, from one prediction."""
        res = self.residuals(mods, channels)
        chans = channels or tuple(res)
        return [float(sum({c: float(np.mean(res[c][mask] ** 2) / self.sigma[c] ** 2)
                           for c in chans if c in res}.values())) for mask in masks]

    def stderr(self, objective: float, curvature: float, mask: np.ndarray) -> float:
        """Gauss–Newton standard error of a parameter from the objective at the optimum and
        its curvature there (effective samples: the low-passed residuals over ``mask``)."""
        fs = self.ctx.flight.fs
        n_eff = max(float(np.sum(mask)) * 2.0 * min(CUTOFF_HZ.values()) / fs, 1.0)
        return float(np.sqrt(2.0 * max(objective, 1e-12) / (n_eff * curvature)))


@dataclass
class SharedMasks:
    """Objective values of one candidate set at every point evaluated, over several masks
    at once (the folds of one model): the folds differ only in the samples they score, so
    one prediction serves them all, and a fold's search that visits a point another fold's
    visited (the coarse grids) reuses its value."""

    masks: list[np.ndarray]
    values: dict[bytes, list[float]] = field(default_factory=dict)


def _mods(cands: tuple[Candidate, ...], theta: np.ndarray, ctx: Context) -> Mods:
    out: Mods | None = None
    i = 0
    for c in cands:
        k = len(c.params)
        m = c.mods(theta[i:i + k], ctx)
        out = m if out is None else merge(out, m)
        i += k
    assert out is not None
    return out


def channels_of(cands: tuple[Candidate, ...], scorer: Scorer) -> tuple[str, ...]:
    """Union of the channels the candidates act on that REAL and SIM both have."""
    seen: list[str] = []
    for c in cands:
        seen += [ch for ch in c.channels if ch in scorer.measured and ch in scorer.sigma
                 and ch not in seen]
    return tuple(seen)


def _start(cands: tuple[Candidate, ...], scorer: Scorer, mask: np.ndarray) -> np.ndarray:
    res = None
    x0 = []
    for c in cands:
        for i, p in enumerate(c.params):
            if p.name.endswith("_offset") or c.name in ("gyro_bias", "accel_bias"):
                if res is None:
                    res = scorer.residuals()
                ch = c.channels[i]
                x0.append(float(np.mean(res[ch][mask])) if ch in res else 0.0)
            else:
                x0.append(p.x0)
    return np.array(x0)


GRID_POINTS = 7
"""Points per parameter of the coarse grid that starts a single candidate's local search
(a law such as ground effect saturates far from its optimum, where the objective is flat)."""
GRID_POINTS_3 = 5
"""The same for a three-parameter law (5³ points)."""


def _grid_starts(cands: tuple[Candidate, ...], f, x0: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray) -> list[np.ndarray]:
    """Starts of the local search over a single two-parameter law, or over the
    three-parameter ground-effect law (offsets and biases excluded: their start is the mean
    residual): ``x0`` and the local minima of a coarse grid (points no higher than their
    neighbours along each axis), the :data:`REFINED_STARTS` lowest; else ``[x0]``. A
    bounded local search from the grid's lowest point alone can stall in a valley of
    trading parameters (a ground effect's excess, decay and arm) far from a better basin;
    one start per basin finds it, and a law with one basin costs one search."""
    if len(cands) != 1 or not (x0.size == 2 or (x0.size == 3
                                                 and cands[0].name == "ground_effect")):
        return [x0]
    points = GRID_POINTS if x0.size == 2 else GRID_POINTS_3
    axes = [np.geomspace(a, b, points) if a > 0 else np.linspace(a, b, points)
            for a, b in zip(lo, hi, strict=True)]
    vals = np.array([f(np.array(p)) for p in itertools.product(*axes)]).reshape(
        (points,) * x0.size)
    scored = [(f(x0), -1, x0)] + [
        (float(vals[idx]), int(np.ravel_multi_index(idx, vals.shape)),
         np.array([axes[a][i] for a, i in enumerate(idx)]))
        for idx in zip(*np.nonzero(_local_minima(vals)), strict=True)]
    scored.sort(key=lambda t: (t[0], t[1]))
    return [x for _, _, x in scored[:REFINED_STARTS]]


def _local_minima(vals: np.ndarray) -> np.ndarray:
    """Mask of the grid points no higher than their neighbours along each axis (a grid's
    edge counts as higher)."""
    padded = np.pad(vals, 1, constant_values=np.inf)
    out = np.ones(vals.shape, dtype=bool)
    for axis in range(vals.ndim):
        for shift in (0, 2):
            neighbour = [slice(1, -1)] * vals.ndim
            neighbour[axis] = slice(shift, shift + vals.shape[axis])
            out &= vals <= padded[tuple(neighbour)]
    return out


def _search_coordinates(cands: tuple[Candidate, ...], ctx: Context, lo: np.ndarray,
                        hi: np.ndarray):
    """(to_theta, to_search, step, bounds) of the local search over the concatenated
    parameters: a candidate's own :class:`~etsid.gap.candidates.SearchMap` where it has
    one (unbounded there; the objective clips θ to its bounds), else each parameter scaled
    to its bounds (unit interval, step 0.05)."""
    maps, steps, bounds = [], [], []
    i = 0
    for c in cands:
        k = len(c.params)
        sl = slice(i, i + k)
        if c.search is not None:
            m = c.search(ctx)
            maps.append((sl, m.to_theta, m.to_search))
            steps.append(m.step)
            bounds += [(None, None)] * k
        else:
            a, span = lo[sl], hi[sl] - lo[sl]
            maps.append((sl, lambda u, a=a, span=span: a + u * span,
                         lambda t, a=a, span=span: (t - a) / span))
            steps.append(np.full(k, 0.05))
            bounds += [(0.0, 1.0)] * k
        i += k

    def to_theta(s: np.ndarray) -> np.ndarray:
        return np.concatenate([fwd(s[sl]) for sl, fwd, _ in maps])

    def to_search(theta: np.ndarray) -> np.ndarray:
        return np.concatenate([inv(theta[sl]) for sl, _, inv in maps])
    return to_theta, to_search, np.concatenate(steps), bounds


def fit_candidates(cands: tuple[Candidate, ...], scorer: Scorer, mask: np.ndarray,
                   x0: np.ndarray | list[np.ndarray] | None = None, base: Fit | None = None,
                   shared: SharedMasks | None = None) -> Fit:
    """Fit the parameters of ``cands`` jointly on the samples in ``mask`` (``x0``: a start,
    or alternative starts of which the search begins at the lowest, e.g. a pair's two single
    fits together and its lead's fit alone; default the candidates' own starts). With ``base``, on
    top of that fitted effect, whose parameters stay fixed (the returned fit holds only
    ``cands``; its ``mods`` include the base's). With ``shared`` (``mask`` one of its masks,
    the same ``cands`` and ``base`` for all), every evaluation scores all its masks."""
    chans = channels_of(cands + (base.candidates if base else ()), scorer)
    params = [p for c in cands for p in c.params]
    lo = np.array([p.lo for p in params])
    hi = np.array([p.hi for p in params])

    def mods_at(theta: np.ndarray) -> Mods:
        own = _mods(cands, theta, scorer.ctx)
        return merge(base.mods, own) if base is not None else own

    # the search revisits points (its start, the optimum for the standard errors)
    memo = shared or SharedMasks([mask])
    k = next(i for i, m in enumerate(memo.masks) if m is mask)

    def f(theta: np.ndarray) -> float:
        key = np.asarray(theta, dtype=float).tobytes()
        if key not in memo.values:
            memo.values[key] = scorer.objectives(mods_at(theta), memo.masks, chans)
        return memo.values[key][k]

    if len(params) == 1:
        theta = _scalar_search(lambda v: f(np.array([v])), lo[0], hi[0])
    else:
        if x0 is None:
            starts = _grid_starts(cands, f, _start(cands, scorer, mask), lo, hi)
        else:
            options = [x0] if isinstance(x0, np.ndarray) else x0
            starts = [min(options, key=lambda s: f(np.clip(s, lo, hi)))]
        to_theta, to_search, step, bounds = _search_coordinates(cands, scorer.ctx, lo, hi)
        theta, best = None, np.inf
        for start in starts:
            start = np.clip(start, lo, hi)
            r = minimize(lambda s: f(np.clip(to_theta(s), lo, hi)), to_search(start),
                         method="Powell", bounds=bounds,
                         options={"xtol": 1e-3, "ftol": 1e-6, "maxfev": 200,
                                  "direc": np.diag(step)})
            found = np.clip(to_theta(r.x), lo, hi)
            if f(start) < f(found):  # never worse than the start (a pair's single fits)
                found = start
            if f(found) < best:
                theta, best = found, f(found)
        assert theta is not None
    stderr = _stderr(f, theta, lo, hi, scorer, mask)
    return Fit(cands, theta, stderr, mods_at(theta), _bound_cost(f, theta, params))


SCALAR_GRID = 13
"""Points of the coarse grid over a one-parameter law's bounds."""
REFINED_STARTS = 3
"""Local minima of a coarse grid a local search starts from, the lowest first: a delay's
objective is periodic in a loop that oscillates (a yaw loop ringing at 9 Hz repeats it every
110 ms), and a ground law's excess, decay and arm trade along a valley, so the grid's lowest
point can lead to a worse optimum than another basin's."""


def _scalar_search(g, lo: float, hi: float) -> np.ndarray:
    """The minimum of ``g(v)`` on [lo, hi]: a coarse grid, then a bounded search between the
    neighbours of each of its :data:`REFINED_STARTS` lowest local minima; the best."""
    grid = np.linspace(lo, hi, SCALAR_GRID)
    vals = np.array([g(v) for v in grid])
    minima = np.flatnonzero(_local_minima(vals))
    best, best_val = float(grid[int(np.argmin(vals))]), float(vals.min())
    for j in sorted(minima, key=lambda i: vals[i])[:REFINED_STARTS]:
        a, b = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
        r = minimize_scalar(g, bounds=(a, b), method="bounded",
                            options={"xatol": 1e-4 * (hi - lo)})
        if r.fun < best_val:
            best, best_val = float(r.x), float(r.fun)
    return np.array([best])


def _bound_cost(f, theta: np.ndarray, params: list) -> np.ndarray:
    """The objective with each parameter moved to each of its bounds, minus the fit's
    (NaN at a bound that is the law's no-effect value)."""
    j0 = f(theta)
    out = np.full((theta.size, 2), np.nan)
    for i, p in enumerate(params):
        for side, b in enumerate((p.lo, p.hi)):
            if b != p.null:
                moved = theta.copy()
                moved[i] = b
                out[i, side] = f(moved) - j0
    return out


def _stderr(f, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray, scorer: Scorer,
            mask: np.ndarray) -> np.ndarray:
    j0 = f(theta)
    out = np.empty(theta.size)
    for i in range(theta.size):
        h = 1e-3 * (hi[i] - lo[i])
        tp, tm = theta.copy(), theta.copy()
        tp[i] = min(theta[i] + h, hi[i])
        tm[i] = max(theta[i] - h, lo[i])
        d = (tp[i] - tm[i]) / 2.0
        curv = (f(tp) - 2 * j0 + f(tm)) / max(d * d, 1e-18)
        out[i] = scorer.stderr(j0, curv, mask) if curv > 0 else np.inf
    return out
