"""The eTS learner's state layout and the index constants the kernels share.

:mod:`etsid.ets.kernels` (learn and predict) and :mod:`etsid.ets.normalisation` work on
these arrays; :class:`etsid.ets.ETS` allocates them and exposes them through
:meth:`~etsid.ets.ETS.export_state` / :meth:`~etsid.ets.ETS.restore_state`.

State layout (all preallocated for ``max_rules`` rules, rules ``0 .. R-1`` are live and
kept in birth order; removing a rule shifts the later ones down):

``si``      int64[3]: samples learned ``k``, live rules ``R``, next rule id
``lo, hi``  float64[d]: normalisation range of z = [x; y] (raw units), ``d = n + m``;
            a scheduled model (antecedents on s, na inputs) uses z = [s; y; x],
            ``d = na + m + n``, and its potentials on s alone
``fixed``   int8[d]: 1 where the range was given by the caller and is never widened
``mean, m2`` float64[d]: Welford running mean and sum of squared deviations of z (raw units)
``ids``     int64[Rmax]: stable rule ids (never reused)
``cz``      float64[Rmax, d]: focal points z*_i in raw units
``rad``     float64[Rmax, na]: per-rule, per-antecedent radius in normalised units
``scat``    float64[Rmax, na]: local scatter (variance, raw units squared) for exTS spreads
``pot``     float64[Rmax]: focal potentials P_k(z*_i)
``birth``   int64[Rmax]: step t*_i at which the rule was born
``support`` int64[Rmax]: samples for which the rule fired strongest (including its birth)
``lamsum``  float64[Rmax]: sum of normalised firing since birth (utility numerator)
``tsum``    float64[Rmax]: sum of the time indices of the supporting samples (age)
``Pi``      float64[Rmax, n+1, m]: consequents on x_e = [1, (x - lo) / s]
``Cl``      float64[Rmax, n+1, n+1]: local RLS covariances (unused shape for global RLS)
``Cg``      float64[Rmax(n+1), Rmax(n+1)]: global RLS covariance (unused shape for local)
``sh``      int8[m]: 1 for a shared output, whose consequent is one linear model common to
            every rule, learnt by plain RLS (the rules' antecedents do not act on it)
``Cs``      float64[n+1, n+1]: covariance of the shared outputs' RLS (unused without them)
"""

from __future__ import annotations

import numpy as np

# integer parameters ``ip``
IP_VARIANT = 0  # 0: eTS (2004), 1: eTS+ (2010)
IP_GLOBAL = 1  # 0: local RLS, 1: global RLS
IP_MAX_RULES = 2
IP_MIN_SUPPORT = 3
IP_PRUNE_AFTER = 4
IP_ADAPTIVE = 5
IP_COVERAGE = 6  # eTS+: also grow wherever no rule covers the sample
IP_SCHEDULED = 7  # 1: antecedents on a separate scheduling vector s, z = [s; y; x]
IP_CLUSTERING = 8  # 0: potential-driven structure (eTS / eTS+), 1: evolving vector quantisation
IP_BLEND = 9  # 0: output blended by the normalised firing, 1: interpolated (one antecedent)
N_IP = 10
# float parameters ``fp``
FP_OMEGA = 0
FP_FORGET = 1
FP_UTILITY = 2
FP_SPREAD_RHO = 3
N_FP = 4
# event kinds
EV_BIRTH = 0
EV_REPLACE = 1
EV_REMOVAL = 2
EVENT_KINDS = ("birth", "replace", "removal")
#: history columns written per learned sample
HIST_COLUMNS = ("n_rules", "potential", "focal_max", "focal_min")
#: exTS Gaussian exp(-d^2 / (2 sigma^2)) equals exp(-4 d^2 / r^2) when r = sqrt(8) sigma
SQRT8 = np.sqrt(8.0)
#: relative margin for potential comparisons: equal potentials (e.g. the two samples at
#: k = 2) must compare equal whatever the rounding
TIE = 1e-10
#: adaptive radii never shrink below this fraction of the initial radius
RADIUS_FLOOR = 0.01
#: extended-regressor length (n + 1) from which the local RLS gain C x_e is summed by columns
#: (vectorised axpy along the rows of the symmetric C) instead of by row dot products; the
#: two give the same bits. A speed choice only: two covariances at a time, the row form is
#: faster at n + 1 = 5 … 11 (24 vs 35 ns at 5), the column form from 13 (163 vs 183 ns; at
#: 39: 611 vs 1304 ns), docs/performance.md
COLUMN_SUMS = 12

#: names of the state arrays, in the order the learning kernel takes them
STATE_ARRAYS = (
    "si", "lo", "hi", "fixed", "mean", "m2", "ids", "cz", "rad", "scat", "pot",
    "birth", "support", "lamsum", "tsum", "Pi", "Cl", "Cg", "sh", "Cs",
)  # fmt: skip
