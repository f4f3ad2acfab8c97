"""Numba kernel of the free-run simulation (:func:`etsid.ident.simulate.free_run`).

The model is a frozen rule base packed for :func:`etsid.ets.kernels.predict_row` (its
output blended by the firing, or interpolated between rules: ``ETS(blend="interpolate")``);
a linear ARX model is packed as one rule with no antecedent (:func:`pack_linear`), whose
firing is exactly 1. A per-output fall-back (:mod:`etsid.ident.fallback`: ARX or no-change, both
linear in the regressors) replaces the chosen outputs of the rule base's prediction by
``θ₀ + xᵀ θ₁…`` of the same fed-back regressors (``fb_mask``, ``fb_theta``). The kernel
does, row by row and in the same order, what the plain loop
:func:`etsid.ident.simulate.free_run_reference` does (the equivalence tests compare the
two): feed back the simulated lagged outputs and integrated attitude angles, predict, stop
a segment at a divergence, integrate roll and pitch from the simulated rates.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from etsid.ets.kernels import predict_row


def pack_linear(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A linear model ``y = θ₀ + xᵀ θ₁…`` (``theta`` (n + 1, m)) as the frozen rule base
    of :func:`~etsid.ets.kernels.predict_row`: zero offsets, unit widths and one rule with
    no antecedent inputs. Returns the packed array and its work array."""
    theta = np.asarray(theta, dtype=np.float64)
    n = theta.shape[0] - 1
    frozen = np.concatenate([np.zeros(n), np.ones(n), theta.ravel()])
    return frozen, np.empty(2 + n + 1)


@njit(cache=True, boundscheck=False)
def free_run_kernel(X, S, scheduled, rows, seg, links, angles, rate_idx, kin, bias, bounds,
                    check, frozen, work, fb_mask, fb_theta, start, sim, att, out,
                    div_rows) -> int:
    """Simulate rows ``start …`` of ``X`` (N, n) with the model fed its own past outputs.

    Parameters
    ----------
    X, S, scheduled
        Regressors (N, n) and, when ``scheduled``, the measured antecedent inputs (N, na;
        na = 0 for a linear model); otherwise the antecedents are the regressors after the
        feedback (``S`` unused).
    rows, seg
        Table row and segment of each regressor row (int64, N).
    links, angles
        (k, 3) int64: ``(term, output or angle index, lag)`` of the fed-back lagged outputs
        and of the integrated attitude terms (0 rows: none).
    rate_idx
        (3,) int64: the outputs ``p q r`` (used only with attitude terms).
    kin, bias
        Table kinematics (n_table, 6): t (s), roll, pitch (rad), p, q, r (rad/s); gyro bias
        (2,) rad/s removed from the integrated rates.
    bounds, check
        (2, m) envelope; with ``check`` a row outside it (or not finite) stops its segment.
    frozen, work
        The packed model and its work array (:func:`~etsid.ets.kernels.predict_row`).
    fb_mask, fb_theta
        (m,) bool: outputs replaced by the linear fall-back; (n + 1, m): its coefficients,
        intercept first (:class:`etsid.ident.fallback.Fallback`). All False: none.
    start
        First row to simulate.
    sim, att
        (n_table, m) and (n_table, 2), all NaN on entry: simulated outputs and angles by
        table row.
    out
        (N − start, m), all NaN on entry: the simulated outputs.
    div_rows
        (N − start,) int64: receives the regressor row of each divergence.

    Returns
    -------
    int
        Number of divergences written to ``div_rows``.
    """
    N, n = X.shape
    m = out.shape[1]
    x = np.empty(n)
    y = np.empty(m)
    rates = np.empty(3)
    n_div = 0
    stopped = -1
    is_stopped = False
    n_links = links.shape[0]
    n_angles = angles.shape[0]
    for i in range(start, N):
        row = rows[i]
        if is_stopped:
            if seg[i] == stopped:
                continue
            is_stopped = False
        for j in range(n):
            x[j] = X[i, j]
        for k in range(n_links):
            v = sim[row - links[k, 2], links[k, 1]]
            if np.isfinite(v):
                x[links[k, 0]] = v
        for k in range(n_angles):
            v = att[row - angles[k, 2], angles[k, 1]]
            if np.isfinite(v):
                x[angles[k, 0]] = v
        if scheduled:
            ok = predict_row(x, S[i], y, frozen, work)
        else:
            ok = predict_row(x, x, y, frozen, work)
        if not ok:
            for o in range(m):
                y[o] = np.nan
        for o in range(m):
            if fb_mask[o]:
                acc = fb_theta[0, o]
                for j in range(n):
                    acc += x[j] * fb_theta[j + 1, o]
                y[o] = acc
        if check:
            bad = False
            for o in range(m):
                if not np.isfinite(y[o]) or y[o] < bounds[0, o] or y[o] > bounds[1, o]:
                    bad = True
            if bad:
                div_rows[n_div] = i
                n_div += 1
                stopped = seg[i]
                is_stopped = True
                continue
        for o in range(m):
            if not np.isfinite(y[o]):
                y[o] = np.nan
            sim[row, o] = y[o]
            out[i - start, o] = y[o]
        if n_angles > 0 and row >= 1:
            _integrate(kin, att, sim, row, y, rate_idx, bias, rates)
    return n_div


@njit(cache=True, boundscheck=False)
def _integrate(kin, att, sim, row, y, rate_idx, bias, rates) -> None:
    """att[row] from att[row − 1] (else the measured angles) and the mean of the rates of
    both rows (simulated, else measured): the trapezoid step of
    :func:`etsid.ident.simulate._integrate_attitude`."""
    if np.isfinite(att[row - 1, 0]) and np.isfinite(att[row - 1, 1]):
        roll = att[row - 1, 0]
        pitch = att[row - 1, 1]
    else:
        roll = kin[row - 1, 1]
        pitch = kin[row - 1, 2]
    fed = True
    for k in range(3):
        if not np.isfinite(sim[row - 1, rate_idx[k]]):
            fed = False
    for k in range(3):
        before = sim[row - 1, rate_idx[k]] if fed else kin[row - 1, 3 + k]
        rates[k] = 0.5 * (before + y[rate_idx[k]])
    p, q, r = rates[0], rates[1], rates[2]
    dt = kin[row, 0] - kin[row - 1, 0]
    d_roll = p + (q * np.sin(roll) + r * np.cos(roll)) * np.tan(pitch) - bias[0]
    d_pitch = q * np.cos(roll) - r * np.sin(roll) - bias[1]
    att[row, 0] = roll + dt * d_roll
    att[row, 1] = pitch + dt * d_pitch
