"""The choices and defaults of the identification settings, in a module that imports
nothing (no numpy or pandas): :class:`etsid.ident.IdentConfig` takes its defaults from here,
and ``etsid identify --help`` lists them without loading the science stack.

The modules that act on a setting re-export its constants (e.g.
:data:`etsid.ident.inputs.MODES`), so either name may be used.
"""

from __future__ import annotations

OUTPUT_LAGS = 4
"""Autoregressive lags of each rate, samples at the identification rate."""

INPUT_LAGS = 6
"""Lags of each loop command, samples at the identification rate."""

SCHEDULE = "inv_alt[k-1]"
"""Default antecedent of the rate model when the table has altitude (``--antecedent
auto``): the rules fire on 1/altitude (:data:`etsid.ident.regressors.DERIVED`, the
ground-effect coordinate) and every rule keeps a full local ARX consequent on the
regressors. Chosen by the scheduling study of docs/identify.md (altitude, 1/altitude,
1/altitude², with and without ``u_thrust``, on an inner split of the learning part)."""

ATTITUDE_MODES = ("auto", "on", "none")
"""``attitude`` settings of :func:`etsid.ident.defaults.default_model`
(``--attitude-states``): ``auto`` and ``on`` add
:data:`etsid.ident.defaults.ATTITUDE_TERMS` where the attitude loop closes around the inputs
(``auto`` then lets identify's inner split of the learning part keep or drop them,
:mod:`etsid.ident.attitude_check`), ``none`` never does."""

MODES = ("auto", "sticks", "torque", "setpoints", "attitude", "motors")
"""Values of ``--inputs`` (:mod:`etsid.ident.inputs`)."""

STICK_STD_MIN = 0.02
"""Least standard deviation of each roll/pitch/yaw stick for ``auto`` to use the sticks,
normalised units (−1…1): 1 % of the full throw."""

STICK_RATE_MIN = 10.0
"""Least native rate of the stick signals for ``auto`` to use them, Hz (a 2–5 Hz RC
stream holds one value for several identification samples)."""

NORMALISE_MODES = ("learn", "running", "apriori")
"""How eTS normalises its inputs and outputs (``--normalise``, docs/identify.md,
:mod:`etsid.ident.ranges`)."""

DEFAULT_RATE_HZ = 50.0
"""Default identification rate of the rate model, Hz (see docs/identify.md,
:mod:`etsid.ident.resample`)."""
