"""What an effect is: its forms (parametric laws on SIM's nominal prediction), a prior per
parameter, its words, the look-alikes the logs may not tell it from and its sentence."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from etsid.gap.candidates import Candidate


@dataclass(frozen=True)
class Prior:
    """Prior of one parameter.

    ``kind``: ``"lognormal"`` (a scale around 1: ``ln x ~ N(0, width²)``), ``"halfnormal"``
    (a non-negative size: ``x ~ |N(0, width²)|``) or ``"normal"`` (a signed offset:
    ``x ~ N(0, width²)``), ``width`` in the parameter's unit (log units for a scale).
    """

    kind: str
    width: float

    def logpdf(self, x: float) -> float:
        """Log density at ``x`` (−inf outside the support)."""
        w = self.width
        if self.kind == "lognormal":
            if x <= 0:
                return -np.inf
            z = np.log(x) / w
            return float(-0.5 * z * z - np.log(x * w * np.sqrt(2 * np.pi)))
        if self.kind == "halfnormal":
            if x < 0:
                return -np.inf
            return float(-0.5 * (x / w) ** 2 + np.log(np.sqrt(2 / np.pi) / w))
        return float(-0.5 * (x / w) ** 2 - np.log(w * np.sqrt(2 * np.pi)))


Sentence = Callable[[dict[str, float], str, str], str]
"""A fitted instance in the effect's own terms: (parameters by name, SIM's name, REAL's
name) → words ("REAL responds 77 ms later than SIM (time delay)")."""


@dataclass(frozen=True)
class Effect:
    """One named physical effect.

    Attributes
    ----------
    name : str
        Vocabulary name.
    words : str
        How a flight engineer calls it (summary and docs).
    forms : tuple of Candidate
        Its parametric laws (bounded parameters, forward model ``mods(θ, ctx)`` on SIM's
        nominal prediction); the criterion scores each and keeps the best.
    priors : dict
        Parameter name → :class:`Prior` (every parameter of every form).
    family : tuple of str
        Effects the logs may not tell it from (reported with their weights, never decided
        by a rule).
    said : Sentence
        The summary's sentence for a fitted instance.
    """

    name: str
    words: str
    forms: tuple[Candidate, ...]
    priors: dict[str, Prior]
    family: tuple[str, ...]
    said: Sentence

    def __post_init__(self) -> None:
        missing = {p.name for c in self.forms for p in c.params} - set(self.priors)
        if missing:
            raise ValueError(f"effect {self.name}: no prior for {sorted(missing)}")
        if any(c.name != self.name for c in self.forms):
            raise ValueError(f"effect {self.name}: a form of another name")

    @property
    def channels(self) -> tuple[str, ...]:
        """Channels any of its forms acts on."""
        return tuple(dict.fromkeys(ch for c in self.forms for ch in c.channels))

    def log_prior(self, form: Candidate, theta: np.ndarray) -> float:
        """Log prior density of ``theta`` under ``form``."""
        return float(sum(self.priors[p.name].logpdf(float(v))
                         for p, v in zip(form.params, theta, strict=True)))
