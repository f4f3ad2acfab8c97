"""The eTS learning parameters: one list, one default each (the single source of truth).

:class:`ETSParams` names every tuning parameter of :class:`etsid.ets.ETS` with its default.
``ETS.__init__``, the numpy reference (:class:`etsid.ets.reference.ReferenceETS`),
identification (:class:`etsid.ident.IdentConfig`, which starts from
:data:`etsid.ident.config.IDENT_ETS`) and the ``etsid identify`` options all take their
defaults from here. The meaning of each parameter is documented on :class:`etsid.ets.ETS`.

The defaults were chosen by one study over Box–Jenkins, Mackey–Glass, two simulated flights,
two static maps and a held-input safety check, each scored on an inner split of its
learning part (``benchmarks/ets_defaults.py``, docs/ets.md "Choosing the defaults"): eTS+
with radius 0.7, exTS adaptive spreads, utility threshold 0.03 and forgetting 0.9 (before:
radius 0.4, fixed spreads, 0.05, no forgetting). Forgetting is safe on a held input since
the RLS wind-up guard of the kernels (forget only while trace(C_i) <= Ω (n + 1)).

The per-data arguments of ``ETS`` (``x_range``, ``y_range``, ``s_range``, ``input_names``,
``output_names``) are not tuning parameters and are not listed.

>>> from etsid.ets.params import DEFAULTS, PARAM_NAMES
>>> DEFAULTS.radius, DEFAULTS.variant
(0.7, 'ets+')
>>> PARAM_NAMES[:3]
('radius', 'omega', 'variant')
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

VARIANTS = ("ets", "ets+")
"""Values of ``variant``: eTS (Angelov & Filev 2004) or eTS+ (Angelov 2010)."""

RLS_KINDS = ("local", "global")
"""Values of ``rls``: fuzzily weighted local RLS per rule, or one global RLS."""

BLENDS = ("firing", "interpolate")
"""Values of ``blend``: how the rules' outputs make the model's output. ``firing``: weighted
by the rules' normalised firing (eTS). ``interpolate`` (a scheduled model with one antecedent
only): linear interpolation between the two rules whose focal points enclose the scheduling
value, the outermost rule alone beyond them. Learning (firing, births, consequents) is the
same for both."""

CLUSTERINGS = ("potential", "evq")
"""Values of ``clustering``: births and moves driven by the potentials (eTS / eTS+), or
evolving vector quantisation (births where no rule covers the sample, the winner's focal
point follows the mean of the samples it wins)."""


@dataclass(frozen=True)
class ETSParams:
    """Tuning parameters of the eTS learner and their defaults (see :class:`etsid.ets.ETS`).

    Attributes
    ----------
    radius
        Zone of influence r, normalised units (fraction of the input range); a single
        value or one per input.
    omega
        Initial covariance ω I of a new rule's RLS (dimensionless, large = weak prior).
    variant
        ``ets`` or ``ets+`` (:data:`VARIANTS`).
    max_rules
        Cap on the number of rules.
    rls
        ``local`` or ``global`` (:data:`RLS_KINDS`).
    forgetting
        RLS forgetting factor in (0, 1]; 1 means no forgetting.
    utility_threshold
        eTS+: utility below which a rule is removed.
    min_support
        eTS+: least samples a rule must win after ``prune_after`` steps.
    prune_after
        eTS+: steps (samples) a rule lives before utility and support are checked.
    adaptive_spread
        exTS per-rule, per-input radii.
    coverage
        eTS+: also add a rule for any sample no rule covers (etsid extension).
    history_every
        Samples between two snapshots of all consequents.
    clustering
        ``potential`` or ``evq`` (:data:`CLUSTERINGS`).
    blend
        ``firing`` or ``interpolate`` (:data:`BLENDS`).
    """

    radius: float | tuple[float, ...] = 0.7
    omega: float = 1000.0
    variant: str = "ets+"
    max_rules: int = 50
    rls: str = "local"
    forgetting: float = 0.9
    utility_threshold: float = 0.03
    min_support: int = 3
    prune_after: int = 50
    adaptive_spread: bool = True
    coverage: bool = False
    history_every: int = 1000
    clustering: str = "potential"
    blend: str = "firing"

    def to_dict(self) -> dict[str, Any]:
        """The parameters as keyword arguments of :class:`etsid.ets.ETS`."""
        return asdict(self)


DEFAULTS = ETSParams()
"""The defaults of :class:`etsid.ets.ETS`."""

PARAM_NAMES: tuple[str, ...] = tuple(f.name for f in fields(ETSParams))
"""Names of the tuning parameters, in the order of the ``ETS`` signature."""
