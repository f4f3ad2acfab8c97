"""Free-run simulation: the model's own past outputs are fed back instead of measurements.

Lagged-output regressors of row ``i ≥ start`` take the simulated value of the row they
refer to when that row was simulated; otherwise (before ``start``, or after a gap where the
history had to be rebuilt from the log) they take the measured value — the simulation's
initial conditions.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from etsid.ident.regressors import Regression, RegressorSpec, feedback_map


def free_run(predict_one: Callable[[np.ndarray], np.ndarray], reg: Regression,
             spec: RegressorSpec, start: int, n_table: int) -> np.ndarray:
    """Simulate rows ``start …`` of ``reg`` with the model fed its own past outputs.

    Parameters
    ----------
    predict_one
        Maps one regressor vector (n,) to the predicted outputs (m,), in output units.
    reg
        Lag matrices of the table (:func:`etsid.ident.regressors.build`).
    spec
        The regressor spec ``reg`` was built with.
    start
        First row of ``reg`` to simulate.
    n_table
        Number of rows of the table (``reg.rows`` index into it).

    Returns
    -------
    ndarray, shape (len(reg.X) - start, m)
        Simulated outputs, NaN where the model returned a non-finite value.
    """
    links = feedback_map(spec)
    m = len(spec.outputs)
    sim = np.full((n_table, m), np.nan)
    out = np.full((len(reg.X) - start, m), np.nan)
    x = np.empty(reg.X.shape[1])
    for i in range(start, len(reg.X)):
        row = int(reg.rows[i])
        x[:] = reg.X[i]
        for j, o, lag in links:
            value = sim[row - lag, o]
            if np.isfinite(value):
                x[j] = value
        y = np.asarray(predict_one(x), dtype=float).reshape(m)
        y = np.where(np.isfinite(y), y, np.nan)
        sim[row] = y
        out[i - start] = y
    return out
