"""Every parameter of an identification run (:class:`IdentConfig`, stored in config.json).

The eTS parameters start from :data:`IDENT_ETS`: the defaults of :class:`etsid.ets.ETS`
(:mod:`etsid.ets.params`, the single source of truth) with the few values identification
deliberately changes, named here and nowhere else. The module imports no numpy (``etsid
identify --help`` shows these defaults).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from etsid.errors import IdentError
from etsid.ets.params import DEFAULTS, PARAM_NAMES
from etsid.ident.choices import DEFAULT_RATE_HZ, INPUT_LAGS, OUTPUT_LAGS, SCHEDULE

IDENT_ETS = replace(DEFAULTS, radius=2.0, max_rules=30, history_every=250,
                    utility_threshold=0.05, adaptive_spread=False, forgetting=1.0)
"""eTS parameters of ``etsid identify``: the ``ETS`` defaults except

``radius`` 2.0 (``ETS``: 0.7)
    Identification normalises with fixed learning-part ranges (``--normalise learn``) and
    feeds ~36 regressors; radius 2 is the result of the radius study in docs/identify.md
    (the ``ETS`` default suits the low-dimensional benchmarks of docs/ets.md).
``max_rules`` 30 (``ETS``: 50)
    A tighter cap for flight logs: every rule carries an (n+1)² covariance over the ~36
    regressors.
``history_every`` 250 (``ETS``: 1000)
    A consequent snapshot every 5 s at the 50 Hz identification rate, for the
    consequent-history figure of ``etsid report``.
``utility_threshold`` 0.05, ``adaptive_spread`` False, ``forgetting`` 1 (``ETS``: 0.03, True, 0.9)
    identify keeps the ``ETS`` defaults it was tuned with before the defaults study of
    docs/ets.md (issue 11 study pending): its choices are made by identify's own study
    (docs/identify.md), on 36 regressors with fixed learning-part ranges.
"""

IDENT_SCHEDULED_ETS = replace(IDENT_ETS, radius=0.3, clustering="evq", blend="interpolate")
"""eTS parameters of a scheduled ``etsid identify`` model (rules firing on ``--antecedent``
terms, by default :data:`etsid.ident.defaults.SCHEDULE`): :data:`IDENT_ETS` except

``radius`` 0.3
    A fraction of the scheduling range (``inv_alt``: 0 … 5 m⁻¹, so the zone of a rule spans
    about 1.5 m⁻¹); chosen on an inner split of the learning part (scheduling study in
    docs/identify.md, second round, with the attitude states; 0.5 in the first round).
``clustering`` "evq"
    Rules are born where no rule covers the scheduling vector and their focal points follow
    the mean of the samples they win, so they sit at the regimes flown (the potential of
    eTS peaks at the global mean, between the regimes).
``blend`` "interpolate" (one antecedent input; several: ``firing``)
    Between two regimes the output is the linear interpolation of their rules' local
    models in the scheduling variable, not their firing-weighted blend: with radius 0.3
    the normalised firing is a steep sigmoid between two focal points, so on the second
    generator's hexacopter a dwell at 0.40 m between rules at 0.30 and 1.1 m was predicted
    ~90 % by the ground-effect rule and lost 1.4–2.6 points of free-run fit to ARX there
    (docs/identify.md, "Interpolating between regimes"). Learning is unchanged.
"""


@dataclass
class IdentConfig:
    """Every parameter of an identification run (stored in config.json).

    Parameters
    ----------
    outputs
        Columns to predict; ``None`` chooses the default rate model (p, q, r).
    regressors
        Regressor spec (``"co2[k-1],input_gas_rate[k-4]"``); ``None`` with default
        outputs uses the default lags; required when ``outputs`` is given.
    output_lags, input_lags
        Lags of the default rate model, samples.
    radius, omega, variant, max_rules, rls, forgetting, utility_threshold, min_support,
    prune_after, adaptive_spread, coverage, history_every, clustering, blend
        eTS parameters (see :class:`etsid.ets.ETS`); defaults :data:`IDENT_ETS`. ``radius``,
        ``clustering`` and ``blend`` None: :data:`IDENT_ETS`'s value when the rules fire on
        the regressors, :data:`IDENT_SCHEDULED_ETS`'s when they fire on an antecedent
        (``blend``: ``firing`` when it has more than one input).
    validate
        Fraction of the usable rows, at the end, held out for frozen validation (0 … 0.9).
    normalise
        eTS normalisation ranges: ``learn`` (fixed, min/max of the learning part widened
        by :data:`etsid.ident.ranges.RANGE_MARGIN`), ``running`` (the eTS running min/max,
        strictly causal) or ``apriori`` (fixed: :data:`etsid.ident.ranges.APRIORI_RANGES`
        for the loop commands, learning-part ranges for the rest). See
        :func:`etsid.ident.ranges.fixed_ranges`.
    ident_rate
        Identification rate, Hz: the table is block-mean decimated by the integer factor
        whose rate is nearest (:func:`etsid.ident.resample.decimate`). ``None``: 50 Hz for
        the default rate model, the table's own rate with ``outputs``; 0: the table's rate.
    inputs
        Input family of the default rate model: ``auto``, ``sticks``, ``torque`` or
        ``setpoints`` (:mod:`etsid.ident.inputs`).
    antecedent
        Scheduling terms the rules fire on (same syntax as ``regressors``, e.g.
        ``"inv_alt[k-1]"`` or ``"alt[k-1],u_thrust[k-1]"``); ``"none"`` or None: the rules
        fire on the regressors; ``"auto"`` (default): :data:`etsid.ident.defaults.SCHEDULE`
        for the default rate model of a table with altitude data, else none.
    attitude
        Attitude states of the default rate model (``roll[k-1],pitch[k-1]`` where the attitude
        loop closes around the inputs, :data:`etsid.ident.defaults.ATTITUDE_TERMS`): ``auto``
        (kept when an inner split of the learning part says they help,
        :mod:`etsid.ident.attitude_check`), ``on`` (always) or ``none``.
    unscheduled
        Outputs of a scheduled model whose consequent is one linear model shared by every
        rule (``ETS(shared_outputs=…)``: the antecedent does not act on them): ``none``
        (default; the study of docs/identify.md did not select ``r`` on the inner split) or
        output names such as ``"r"``.
    structure
        Model structure of the default rate model: ``auto`` (chosen on an inner split of
        the learning part between scheduled eTS, unscheduled eTS and one rule = ARX,
        :mod:`etsid.ident.structure`), ``scheduled``, ``unscheduled`` or ``arx``.
    merge
        Merge neighbouring rules whose consequents are statistically indistinguishable
        when the model is frozen and at the end of the pass (:mod:`etsid.ets.merge`).
        None (default): for the default rate model only, not for generic models
        (``outputs``): on the
        292-sample Box–Jenkins record the test cannot tell 3-parameter rules apart and
        merged the 5 rules of radius 0.5 into one (validation 0.701 → 0.731).
    segments
        Rows to identify on: ``auto`` (airborne samples), ``all`` or ``T0:T1[,T0:T1…]``
        (:mod:`etsid.ident.flight`).
    """

    outputs: list[str] | None = None
    regressors: str | None = None
    output_lags: int = OUTPUT_LAGS
    input_lags: int = INPUT_LAGS
    radius: float | None = None
    omega: float = IDENT_ETS.omega
    variant: str = IDENT_ETS.variant
    max_rules: int = IDENT_ETS.max_rules
    rls: str = IDENT_ETS.rls
    forgetting: float = IDENT_ETS.forgetting
    utility_threshold: float = IDENT_ETS.utility_threshold
    min_support: int = IDENT_ETS.min_support
    prune_after: int = IDENT_ETS.prune_after
    adaptive_spread: bool = IDENT_ETS.adaptive_spread
    coverage: bool = IDENT_ETS.coverage
    history_every: int = IDENT_ETS.history_every
    clustering: str | None = None
    blend: str | None = None
    validate: float = 0.3
    ident_rate: float | None = None
    inputs: str = "auto"
    normalise: str = "learn"
    segments: str = "auto"
    antecedent: str | None = "auto"
    attitude: str = "auto"
    unscheduled: str = "none"
    structure: str = "auto"
    merge: bool | None = None

    def rate_for(self, default_model: bool) -> float | None:
        """The identification rate to aim for, Hz (None: keep the table's rate)."""
        if self.ident_rate is None:
            return DEFAULT_RATE_HZ if default_model else None
        if not math.isfinite(self.ident_rate) or self.ident_rate < 0:
            raise IdentError(f"--ident-rate must be ≥ 0 Hz, got {self.ident_rate}")
        return float(self.ident_rate) or None

    def ets_params(self, scheduled: bool = False, antecedents: int = 1) -> dict[str, Any]:
        """Keyword arguments of :class:`etsid.ets.ETS` (every name of
        :data:`etsid.ets.params.PARAM_NAMES`); ``radius``, ``clustering`` and ``blend``
        left None take the default of a ``scheduled`` (with ``antecedents`` inputs) or
        unscheduled model."""
        base = IDENT_SCHEDULED_ETS if scheduled else IDENT_ETS
        out = {k: getattr(self, k) for k in PARAM_NAMES}
        for key in ("radius", "clustering", "blend"):
            if out[key] is None:
                out[key] = getattr(base, key)
        if self.blend is None and antecedents != 1:
            out["blend"] = IDENT_ETS.blend  # interpolation is along one antecedent only
        return out

    def shared_outputs(self, outputs: tuple[str, ...], scheduled: bool) -> list[int]:
        """Indices of the outputs left unscheduled (see ``unscheduled``).

        Raises
        ------
        IdentError
            A name that is not an output, or unscheduled outputs on a model whose rules fire
            on the regressors.
        """
        text = (self.unscheduled or "none").strip()
        if text.lower() == "none":
            return []
        if not scheduled:
            raise IdentError("--unscheduled needs rules that fire on --antecedent terms")
        names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
        bad = [n for n in names if n not in outputs]
        if bad or not names:
            raise IdentError(f"--unscheduled {text!r}: {', '.join(bad) or 'no name'} is not an "
                             f"output (outputs: {', '.join(outputs)})")
        return [list(outputs).index(n) for n in names]

    def antecedent_for(self, table: Any) -> str | None:
        """The antecedent spec for ``table``: ``"auto"`` resolved (module docstring of
        :mod:`etsid.ident.defaults`), ``"none"`` as None."""
        text = self.antecedent
        if text is None or text.strip().lower() == "none":
            return None
        if text.strip().lower() != "auto":
            return text
        if self.outputs or "alt" not in table.columns or not table["alt"].notna().any():
            return None
        return SCHEDULE
