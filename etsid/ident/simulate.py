"""Free-run simulation: the model's own past outputs are fed back instead of measurements.

Lagged-output regressors of row ``i ≥ start`` take the simulated value of the row they
refer to when that row was simulated; otherwise (before ``start``, or after a gap where the
history had to be rebuilt from the log) they take the measured value — the simulation's
initial conditions. Each segment (airborne stretch, or stretch between gaps) is therefore
its own simulation.

**Attitude states.** A model of ``p q r`` with ``roll``/``pitch`` terms (the attitude loop
closes around the sticks, so the rate response depends on the angle) carries the angles as
states: in free run they are integrated from the simulated rates with the ZYX Euler
kinematics (trapezoid rule over each row's time step, from the measured angles at the start
of each simulation), never read from the log. The gyro bias the log's attitude estimator
removed is removed from the integrated rates too (:func:`kinematic_bias`, measured on the
rows before the simulation starts), else the angles would drift by bias × time.

**Divergence.** A simulation that leaves the measured envelope by far is stopped: with
``lo``/``hi`` the least and greatest measured value of an output over the usable rows and
``w = hi − lo``, the simulation of a segment *diverges* at the first row where any output
is outside ``[lo − K·w, hi + K·w]`` with K = :data:`DIVERGE_FACTOR` (or is not finite).
That row and the rest of its segment are NaN; the next segment starts afresh from measured
initial conditions. The times are returned so that metrics use only the rows before the
divergence and the report can say "diverged at t = … s".

**Unstable frozen model** (:func:`linear_stability`). A model can be unstable and still
stay inside the envelope over a short validation window. The frozen model is linearised
(central differences of its one-step prediction with respect to its lagged-output
regressors) at the learning part's mean regressor vector; the lagged outputs then obey
``s(k+1) = A s(k) + …`` with ``A`` the companion matrix of the output recursion (first
block row: the Jacobian per lag; below: the shift). Its spectral radius ρ is the growth
factor per sample of the free response: ρ > :data:`UNSTABLE_RADIUS` means the free run
grows without bound, by ρ^f per second at the identification rate f (doubling time
ln 2 / (f ln ρ)). For ARX (linear) this is exact; for eTS it holds near the operating point.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from etsid.ets import ETS
from etsid.ident.arx import ARX
from etsid.ident.column_bounds import column_bounds
from etsid.ident.fallback import Fallback
from etsid.ident.regressors import Regression, RegressorSpec, attitude_map, feedback_map
from etsid.ident.simulate_kernel import free_run_kernel, pack_linear

DIVERGE_FACTOR = 2.0
"""A free-run value more than this many measured ranges outside the measured envelope of
its output means the simulation diverged."""


ATTITUDE_AXES = ("p", "q")
"""The rate that drives each of ``roll``, ``pitch`` near level flight (linearisation)."""

UNSTABLE_RADIUS = 1.0 + 1e-6
"""Spectral radius of the linearised free-run recursion above which the frozen model is
unstable (1, plus a margin for the finite-difference Jacobian)."""


def linear_stability(predict_one: Callable[[np.ndarray], np.ndarray], spec: RegressorSpec,
                     x0: np.ndarray, rate_hz: float) -> dict[str, float | bool | None]:
    """Spectral radius of the model's output recursion linearised at ``x0`` (module doc).

    Returns
    -------
    dict
        ``spectral_radius``, ``growth_per_s`` (ρ^rate), ``doubling_time_s`` (s; None when
        ρ ≤ 1) and ``unstable`` (ρ > :data:`UNSTABLE_RADIUS`); all None without lagged
        outputs or with a non-finite operating point.
    """
    links = feedback_map(spec)
    angles = attitude_map(spec)
    m = len(spec.outputs)
    empty = {"spectral_radius": None, "growth_per_s": None, "doubling_time_s": None,
             "unstable": False}
    x0 = np.asarray(x0, dtype=float)
    if not links or not np.all(np.isfinite(x0)):
        return empty
    depth = max(lag for _, _, lag in links)
    n_ang = len(ATTITUDE_AXES)
    depth_a = max((lag for _, _, lag in angles), default=0)
    size = m * depth + n_ang * depth_a
    a = np.zeros((size, size))
    columns = [(j, (lag - 1) * m + o) for j, o, lag in links] + [
        (j, m * depth + (lag - 1) * n_ang + k) for j, k, lag in angles]
    for j, col in columns:
        h = 1e-4 * max(1.0, abs(x0[j]))
        up, down = x0.copy(), x0.copy()
        up[j] += h
        down[j] -= h
        deriv = (np.asarray(predict_one(up), float).reshape(m)
                 - np.asarray(predict_one(down), float).reshape(m)) / (2 * h)
        a[:m, col] += deriv
    for k in range(1, depth):
        a[k * m:(k + 1) * m, (k - 1) * m:k * m] = np.eye(m)
    if depth_a:  # angle(k+1) = angle(k) + dt·rate(k+1), small-angle kinematics
        base, dt = m * depth, 1.0 / rate_hz
        out = list(spec.outputs)
        for k, rate in enumerate(ATTITUDE_AXES):
            row = base + k
            a[row] = dt * a[out.index(rate)]
            a[row, row] += 1.0
        for k in range(1, depth_a):
            a[base + k * n_ang:base + (k + 1) * n_ang,
              base + (k - 1) * n_ang:base + k * n_ang] = np.eye(n_ang)
    if not np.all(np.isfinite(a)):
        return empty
    rho = float(np.max(np.abs(np.linalg.eigvals(a))))
    unstable = rho > UNSTABLE_RADIUS
    growth = float(np.exp(min(rate_hz * np.log(rho), 700.0))) if rho > 0 else 0.0
    doubling = float(np.log(2.0) / (rate_hz * np.log(rho))) if unstable else None
    return {"spectral_radius": rho, "growth_per_s": growth, "doubling_time_s": doubling,
            "unstable": bool(unstable)}


def envelope(Y: np.ndarray, factor: float = DIVERGE_FACTOR) -> np.ndarray:
    """Bounds (2, m) outside which a simulated output counts as diverged."""
    Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
    lo, hi, _ = column_bounds(Y) if len(Y) else (np.nanmin(Y, axis=0), np.nanmax(Y, axis=0),
                                                 True)
    width = np.where(hi > lo, hi - lo, np.maximum(np.abs(hi), 1e-6))
    return np.vstack([lo - factor * width, hi + factor * width])


_NO_KINEMATICS = np.zeros((1, 6))
_NO_KINEMATICS.flags.writeable = False  # read-only like build's: one kernel signature


def free_run(model: ETS | ARX | Callable[..., np.ndarray], reg: Regression,
             spec: RegressorSpec, start: int, n_table: int, bounds: np.ndarray | None = None,
             diverged: list[float] | None = None, fallback: Fallback | None = None
             ) -> np.ndarray:
    """Simulate rows ``start …`` of ``reg`` with the model fed its own past outputs.

    The numba kernel :func:`etsid.ident.simulate_kernel.free_run_kernel` does the work; the
    result equals :func:`free_run_reference` (the plain loop) to rounding.

    Parameters
    ----------
    model
        A frozen eTS model (scheduled on ``reg.S`` when it was learnt with antecedent
        inputs) or an ARX model (``reg.S`` ignored); any other model's ``predict_one``
        (or a callable taken as ``predict_one``) is run by :func:`free_run_reference`.
    reg, spec, start, n_table, bounds, diverged
        As :func:`free_run_reference`.
    fallback
        Outputs of an eTS model replaced by their linear fall-back (ARX or no-change,
        :mod:`etsid.ident.fallback`); each step feeds back the mixed prediction.

    Returns
    -------
    ndarray, shape (len(reg.X) - start, m)
        As :func:`free_run_reference`.
    """
    m = len(spec.outputs)
    N = len(reg.X)
    if fallback is not None and fallback.mask.any() and not isinstance(model, ETS):
        raise ValueError("a fall-back replaces outputs of an eTS model only")
    if isinstance(model, ARX):
        frozen, work = pack_linear(model.theta)
        scheduled = True  # on no antecedent input at all (S of width 0)
    elif not isinstance(model, ETS):  # another model (its predict_one) or the callable itself
        one = getattr(model, "predict_one", model)
        return free_run_reference(one, reg, spec, start, n_table, bounds, diverged)
    elif model.n_rules == 0:  # nothing to simulate with: the plain loop's NaN behaviour
        return free_run_reference(mixed_predict_one(model, fallback), reg, spec, start,
                                  n_table, bounds, diverged)
    else:
        frozen, work = model.frozen_predictor()
        scheduled = bool(model.scheduled_)
    links = np.array(feedback_map(spec), dtype=np.int64).reshape(-1, 3)
    angles = np.array(attitude_map(spec) if reg.kinematics is not None else [],
                      dtype=np.int64).reshape(-1, 3)
    rate_idx = np.array([list(spec.outputs).index(c) for c in ("p", "q", "r")]
                        if len(angles) else [0, 0, 0], dtype=np.int64)
    kin = (np.ascontiguousarray(reg.kinematics, dtype=np.float64) if len(angles)
           else _NO_KINEMATICS)
    bias = (kinematic_bias(reg.kinematics, int(reg.rows[start])) if len(angles) and start < N
            else np.zeros(2))
    seg = (np.ascontiguousarray(reg.segment, dtype=np.int64) if reg.segment is not None
           else np.zeros(N, dtype=np.int64))
    if isinstance(model, ARX) or not scheduled:
        S = np.zeros((N, 0))
    elif reg.S is None:
        raise ValueError("a scheduled model needs the regression's scheduling inputs S")
    else:
        S = np.ascontiguousarray(reg.S, dtype=np.float64)
    sim = np.full((n_table, m), np.nan)
    att = np.full((n_table, 2), np.nan)
    out = np.full((max(N - start, 0), m), np.nan)
    div_rows = np.empty(max(N - start, 0), dtype=np.int64)
    check = bounds is not None
    lims = np.asarray(bounds, dtype=np.float64) if check else np.zeros((2, m))
    fb_mask = (np.ascontiguousarray(fallback.mask, dtype=np.bool_) if fallback is not None
               else np.zeros(m, dtype=np.bool_))
    fb_theta = (np.ascontiguousarray(fallback.theta, dtype=np.float64)
                if fallback is not None else np.zeros((reg.X.shape[1] + 1, m)))
    n_div = free_run_kernel(np.ascontiguousarray(reg.X, dtype=np.float64), S, scheduled,
                            np.ascontiguousarray(reg.rows, dtype=np.int64), seg, links, angles,
                            rate_idx, kin, bias, lims, check, frozen, work, fb_mask, fb_theta,
                            int(start), sim, att, out, div_rows)
    if diverged is not None:
        diverged.extend(float(reg.t[i]) for i in div_rows[:n_div])
    return out


def mixed_predict_one(model: ETS, fallback: Fallback | None
                      ) -> Callable[..., np.ndarray]:
    """``predict_one(x[, s])`` of ``model`` with the outputs of ``fallback`` replaced by
    their linear fall-back (the plain-loop form of the kernel's mixed model)."""
    if fallback is None or not fallback.mask.any():
        return model.predict_one

    def one(x: np.ndarray, s: np.ndarray | None = None) -> np.ndarray:
        y = np.asarray(model.predict_one(x) if s is None else model.predict_one(x, s),
                       dtype=float).reshape(-1)
        return fallback.apply(np.asarray(x, dtype=float)[None, :], y[None, :])[0]

    return one


def free_run_reference(predict_one: Callable[..., np.ndarray], reg: Regression,
                       spec: RegressorSpec, start: int, n_table: int,
                       bounds: np.ndarray | None = None,
                       diverged: list[float] | None = None) -> np.ndarray:
    """Plain-loop free run (kept as the reference of :func:`free_run`): simulate rows
    ``start …`` of ``reg`` with the model fed its own past outputs.

    Parameters
    ----------
    predict_one
        Maps one regressor vector (n,) to the predicted outputs (m,), in output units;
        called as ``predict_one(x, s)`` with the measured scheduling inputs when ``reg.S``
        is set (they are exogenous: never outputs).
    reg
        Lag matrices of the table (:func:`etsid.ident.regressors.build`).
    spec
        The regressor spec ``reg`` was built with.
    start
        First row of ``reg`` to simulate.
    n_table
        Number of rows of the table (``reg.rows`` index into it).
    bounds
        (2, m) lower and upper bound of each output (:func:`envelope`); None: never stop.
    diverged
        When given, the time (s) of every divergence is appended to it.

    Returns
    -------
    ndarray, shape (len(reg.X) - start, m)
        Simulated outputs, NaN where the model returned a non-finite value and from a
        divergence to the end of its segment.
    """
    links = feedback_map(spec)
    angles = attitude_map(spec) if reg.kinematics is not None else []
    rate_idx = [list(spec.outputs).index(c) for c in ("p", "q", "r")] if angles else []
    m = len(spec.outputs)
    sim = np.full((n_table, m), np.nan)
    att = np.full((n_table, 2), np.nan)
    bias = (kinematic_bias(reg.kinematics, int(reg.rows[start])) if angles and start < len(reg.X)
            else np.zeros(2))
    out = np.full((len(reg.X) - start, m), np.nan)
    x = np.empty(reg.X.shape[1])
    seg = reg.segment if reg.segment is not None else np.zeros(len(reg.X), dtype=np.int64)
    stopped = None  # the segment whose simulation diverged
    for i in range(start, len(reg.X)):
        row = int(reg.rows[i])
        if stopped is not None:
            if seg[i] == stopped:
                continue
            stopped = None
        x[:] = reg.X[i]
        for j, o, lag in links:
            value = sim[row - lag, o]
            if np.isfinite(value):
                x[j] = value
        for j, k, lag in angles:
            value = att[row - lag, k]
            if np.isfinite(value):
                x[j] = value
        y = np.asarray(predict_one(x) if reg.S is None else predict_one(x, reg.S[i]),
                       dtype=float).reshape(m)
        if bounds is not None and (not np.all(np.isfinite(y)) or np.any(y < bounds[0])
                                   or np.any(y > bounds[1])):
            if diverged is not None:
                diverged.append(float(reg.t[i]))
            stopped = seg[i]
            continue
        y = np.where(np.isfinite(y), y, np.nan)
        sim[row] = y
        out[i - start] = y
        if angles and row >= 1:
            att[row] = _integrate_attitude(reg.kinematics, att, sim, row, y[rate_idx],
                                           rate_idx, bias)
    return out


MIN_BIAS_PAIRS = 50
"""Fewest consecutive row pairs :func:`kinematic_bias` needs; with fewer it returns 0."""


_BIAS_TERMS: list[tuple[np.ndarray, tuple[np.ndarray, ...]]] = []
"""Recent :func:`_bias_terms` of read-only kinematics arrays (identify simulates the same
regression from many starts: candidates, blocks, baselines)."""
BIAS_TERMS_KEPT = 4
"""How many kinematics arrays :data:`_BIAS_TERMS` keeps."""


def _bias_terms(kin: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per row pair of ``kin``: the time step (s) and, for roll and pitch, the kinematic
    rate from the gyro less the measured angle's rate of change (rad/s); elementwise, so
    that the terms of ``kin[:upto]`` are the first ``upto - 1`` of these. Kept for arrays
    that cannot change (read-only, owning their data)."""
    fixed = not kin.flags.writeable and kin.base is None
    if fixed:  # the same array, or the same values (each build of one table makes its own)
        for known, terms in _BIAS_TERMS:
            if known is kin:
                return terms
        for known, terms in _BIAS_TERMS:
            if known.shape == kin.shape and np.array_equal(known, kin, equal_nan=True):
                _BIAS_TERMS.insert(0, (kin, terms))  # found by identity next time
                del _BIAS_TERMS[BIAS_TERMS_KEPT:]
                return terms
    dt = np.diff(kin[:, 0])
    roll, pitch = kin[:, 1], kin[:, 2]
    p, q, r = kin[:, 3], kin[:, 4], kin[:, 5]
    d_roll = p + (q * np.sin(roll) + r * np.cos(roll)) * np.tan(pitch)
    d_pitch = q * np.cos(roll) - r * np.sin(roll)
    res = []
    for rate, angle in ((d_roll, roll), (d_pitch, pitch)):
        change = np.angle(np.exp(1j * np.diff(angle)))  # wrapped to ±π
        with np.errstate(invalid="ignore", divide="ignore"):
            res.append(0.5 * (rate[1:] + rate[:-1]) - change / dt)
    terms = (dt, *res)
    if fixed:
        _BIAS_TERMS.insert(0, (kin, terms))
        del _BIAS_TERMS[BIAS_TERMS_KEPT:]
    return terms


_BIASES: dict[tuple[int, int], tuple[tuple[np.ndarray, ...], np.ndarray]] = {}
"""Biases already computed from the kept terms of :data:`_BIAS_TERMS`, by (id of the
terms, rows): identify asks for the same start up to three times (eTS, ARX, candidates)."""


def kinematic_bias(kin: np.ndarray, upto: int) -> np.ndarray:
    """Mean (rad/s) of the Euler-kinematic angle rates computed from the gyro minus the
    measured angles' rate of change, for roll and pitch, over table rows before ``upto``.

    Pairs of rows further apart than 1.5 median steps (gaps) or with a NaN are skipped.
    This is the gyro bias as the log's attitude estimator saw it; zeros with fewer than
    :data:`MIN_BIAS_PAIRS` pairs (``etsid predict`` from the first row, for example).
    """
    n = min(max(int(upto), 0), len(kin))
    if n <= MIN_BIAS_PAIRS:
        return np.zeros(2)
    terms = _bias_terms(kin)
    kept = any(known is terms for _, known in _BIAS_TERMS)  # the terms cannot change
    if kept and (id(terms), n) in _BIASES:
        held, bias = _BIASES[(id(terms), n)]
        if held is terms:
            return bias.copy()
    out = _bias_of(terms, n)
    if kept:  # (biases of terms no longer kept are dropped)
        live = {id(known) for _, known in _BIAS_TERMS}
        for key in [key for key in _BIASES if key[0] not in live]:
            del _BIASES[key]
        _BIASES[(id(terms), n)] = (terms, out.copy())
    return out


def _bias_of(terms: tuple[np.ndarray, ...], n: int) -> np.ndarray:
    """:func:`kinematic_bias` of the first ``n`` rows from their :func:`_bias_terms`."""
    dt, *res = (a[:n - 1] for a in terms)
    out = np.zeros(2)
    step = np.nanmedian(dt) if np.any(np.isfinite(dt)) else np.nan
    for j, r in enumerate(res):
        ok = np.isfinite(r) & (dt > 0) & (dt <= 1.5 * step)
        if ok.sum() >= MIN_BIAS_PAIRS:
            out[j] = float(np.mean(r[ok]))
    return out


def _integrate_attitude(kin: np.ndarray, att: np.ndarray, sim: np.ndarray, row: int,
                        rates: np.ndarray, rate_idx: list[int], bias: np.ndarray
                        ) -> np.ndarray:
    """Roll and pitch (rad) at table row ``row`` from those at ``row − 1`` (simulated, else
    measured) and the body rates of both rows (simulated, else measured): trapezoid rule on
    the ZYX Euler kinematics, less the gyro ``bias`` (rad/s, :func:`kinematic_bias`)."""
    prev = att[row - 1] if np.all(np.isfinite(att[row - 1])) else kin[row - 1, 1:3]
    before = sim[row - 1, rate_idx]
    if not np.all(np.isfinite(before)):
        before = kin[row - 1, 3:6]
    p, q, r = 0.5 * (before + rates)
    roll, pitch = prev
    dt = kin[row, 0] - kin[row - 1, 0]
    d_roll = p + (q * np.sin(roll) + r * np.cos(roll)) * np.tan(pitch) - bias[0]
    d_pitch = q * np.cos(roll) - r * np.sin(roll) - bias[1]
    return np.array([roll + dt * d_roll, pitch + dt * d_pitch])

