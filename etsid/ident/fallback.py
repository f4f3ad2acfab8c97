"""The per-axis fall-back saved with a rule base: ARX or no-change where eTS was behind.

identify judges each output on its validation (:func:`etsid.ident.structure.fallbacks`,
:func:`etsid.ident.blocks.still_tail_lines`); where eTS is behind a baseline the run's
model for that axis is the baseline. rules.json then carries the optional block
``fallback`` (``rules.schema.json``)::

    "fallback": {"r": {"model": "ARX", "theta": [θ₀, θ₁, …, θₙ],
                       "reason": "eTS was behind on its validation"},
                 "q": {"model": "no-change", "reason": "…"}}

``theta`` is the ARX column of that output fitted on the learning part (the validation
baseline, :meth:`etsid.ident.arx.ARX.fit`): intercept first, then one coefficient per
regressor term in the order of ``regressors.terms``. ``no-change`` predicts the output's
own ``y[k-1]`` term, so it needs that term. Both are linear in the regressors, so the mixed
model is the frozen eTS plus a (n + 1, m) coefficient matrix and a mask of the outputs it
replaces (:class:`Fallback`) — what the free-run kernel takes
(:func:`etsid.ident.simulate.free_run`), with no per-sample Python call. In a free run the
fall-back output is fed back to the eTS outputs and the eTS outputs to it; a no-change
fall-back is one-step only (:meth:`Fallback.for_free_run`): fed back, it would hold the
output at its first value, which is no simulation (on the real ArduCopter 4.0.3 hexa that
took r's free-run fit from −16 % to −60 %), so the free run keeps eTS on that output.

A rule base without the block is applied as eTS on every output, as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit

from etsid.errors import IdentError
from etsid.ident.arx import ARX
from etsid.ident.regressors import Regression, RegressorSpec

MODELS = ("ARX", "no-change")
"""The fall-back models a rules.json may name."""

REASONS = {"tail": "eTS was behind on its validation",
           "blocks": "eTS was behind on its validation blocks (the held-out tail was still)"}
"""Why identify chose a fall-back: judged on the held-out tail or on the blocks."""


@dataclass
class Fallback:
    """Outputs replaced by a linear fall-back, as arrays the kernels take.

    Attributes
    ----------
    mask : ndarray of bool, shape (m,)
        True for the outputs the fall-back replaces.
    theta : ndarray, shape (n + 1, m)
        Their linear model ``y = θ₀ + xᵀ θ₁…`` (zero columns elsewhere).
    models, reasons : dict
        Per replaced output: ``ARX`` or ``no-change``, and why identify chose it.
    outputs : tuple of str
        The model's outputs in column order.
    """

    mask: np.ndarray
    theta: np.ndarray
    models: dict[str, str] = field(default_factory=dict)
    reasons: dict[str, str] = field(default_factory=dict)
    outputs: tuple[str, ...] = ()

    def apply(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """``Y`` (N, m) with the replaced outputs predicted from ``X`` (N, n) instead; each
        row summed in the free-run kernel's order, so that a row's value does not depend on
        which rows are predicted with it."""
        out = np.array(Y, dtype=np.float64, copy=True).reshape(len(X), -1)
        if self.mask.any():
            _linear_rows(np.ascontiguousarray(X, dtype=np.float64),
                         np.ascontiguousarray(self.theta, dtype=np.float64),
                         np.ascontiguousarray(self.mask, dtype=np.bool_), out)
        return out

    def for_free_run(self) -> Fallback | None:
        """The fall-back a free run applies: the ARX outputs only (no-change, fed back,
        holds a value; the module's text). None when nothing is left."""
        keep = {y: m for y, m in self.models.items() if m == "ARX"}
        if keep == self.models:
            return self
        if not keep:
            return None
        drop = [o for o, y in enumerate(self.outputs) if y in self.models and y not in keep]
        mask, theta = self.mask.copy(), self.theta.copy()
        mask[drop], theta[:, drop] = False, 0.0
        return Fallback(mask, theta, keep, {y: self.reasons[y] for y in keep if y in
                                            self.reasons}, self.outputs)

    def used(self, outputs: tuple[str, ...] | list[str]) -> dict[str, str]:
        """The model applied to each output (``eTS`` where not replaced)."""
        return {y: self.models.get(y, "eTS") for y in outputs}

    def lines(self) -> list[str]:
        """One line per replaced output, e.g. ``q: ARX, as identify chose (…)``."""
        return [f"{y}: {m}, as identify chose ({self.reasons.get(y) or 'eTS was behind'})"
                + ("; one-step only, the free run keeps eTS" if m == "no-change" else "")
                for y, m in self.models.items()]


@njit(cache=True, boundscheck=False)
def _linear_rows(X, theta, mask, out) -> None:  # pragma: no cover  (numba)
    """``out[i, o] = θ₀ₒ + Σⱼ X[i, j] θⱼ₊₁,ₒ`` for the outputs ``o`` in ``mask``, summed in
    the order of :func:`etsid.ident.simulate_kernel.free_run_kernel`."""
    n = X.shape[1]
    for i in range(X.shape[0]):
        for o in range(out.shape[1]):
            if mask[o]:
                acc = theta[0, o]
                for j in range(n):
                    acc += X[i, j] * theta[j + 1, o]
                out[i, o] = acc


def _hold_column(spec: RegressorSpec, y: str) -> int | None:
    names = spec.input_names
    return names.index(f"{y}[k-1]") if f"{y}[k-1]" in names else None


def fallback_block(used: dict[str, str], reasons: dict[str, str], reg: Regression,
                   spec: RegressorSpec, split: int) -> tuple[dict[str, Any] | None, list[str]]:
    """rules.json's ``fallback`` block for identify's choice ``used`` (output → model),
    with ARX fitted on the learning rows ``[:split]``; and a note per fall-back that cannot
    be saved (no-change without the output's ``y[k-1]`` term). None when every output is
    eTS."""
    block: dict[str, Any] = {}
    notes: list[str] = []
    arx = None
    for o, y in enumerate(spec.outputs):
        model = used.get(y, "eTS")
        if model == "ARX":
            arx = arx or ARX.fit(reg.X[:split], reg.Y[:split])
            block[y] = {"model": "ARX", "theta": [float(v) for v in arx.theta[:, o]],
                        "reason": reasons.get(y, REASONS["tail"])}
        elif model == "no-change":
            if _hold_column(spec, y) is None:
                notes.append(f"warning: {y}: no-change is not saved in rules.json (the model "
                             f"has no {y}[k-1] term); etsid predict applies eTS there")
                continue
            block[y] = {"model": "no-change", "reason": reasons.get(y, REASONS["tail"])}
    return (block or None), notes


def read_fallback(data: dict[str, Any], spec: RegressorSpec, source: str
                  ) -> Fallback | None:
    """The :class:`Fallback` of a loaded rules.json (None without the block); the schema
    has checked the block's shape, this checks it against the regressor spec.

    Raises
    ------
    IdentError
        An output the model does not have, a ``theta`` of the wrong length or not finite,
        or no-change for an output without its ``y[k-1]`` term.
    """
    block = data.get("fallback")
    if block is None:
        return None
    m, n = len(spec.outputs), len(spec.terms)
    mask = np.zeros(m, dtype=bool)
    theta = np.zeros((n + 1, m))
    models: dict[str, str] = {}
    reasons: dict[str, str] = {}
    for y, entry in block.items():
        if y not in spec.outputs:
            raise IdentError(f"{source}: fallback/{y}: not an output of the model "
                             f"({', '.join(spec.outputs)})")
        o = spec.outputs.index(y)
        if entry["model"] == "ARX":
            coef = entry.get("theta")
            if not isinstance(coef, list) or len(coef) != n + 1 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool)
                    and math.isfinite(v) for v in coef):
                raise IdentError(f"{source}: fallback/{y}/theta must be {n + 1} finite "
                                 "numbers (intercept, then one per regressor term)")
            theta[:, o] = coef
        else:
            j = _hold_column(spec, y)
            if j is None:
                raise IdentError(f"{source}: fallback/{y}: no-change needs the term "
                                 f"{y}[k-1], which the model does not have")
            theta[j + 1, o] = 1.0
        mask[o] = True
        models[y] = entry["model"]
        reasons[y] = str(entry.get("reason") or "")
    return Fallback(mask, theta, models, reasons, tuple(spec.outputs))


def applied_line(outputs: dict[str, Any], models: dict[str, str]) -> str:
    """One line: the fall-back saved in rules.json and the free-run fit % of the mixed model
    it makes (``outputs.Y.applied``) beside eTS alone (``outputs.Y.validation``)."""
    def fit(block: dict[str, Any] | None) -> str:
        value = ((block or {}).get("free_run") or {}).get("fit")
        return f"{value:.1f}" if value is not None else "–"

    names = list(outputs)
    saved = ", ".join(f"{y} {m}" for y, m in models.items())
    mixed = " / ".join(fit(outputs[y]["applied"]["validation"]) for y in names)
    alone = " / ".join(fit(outputs[y]["validation"]) for y in names)
    return (f"rules.json saves the fall-back ({saved}; etsid predict applies it, "
            f"--no-fallback not): validation free-run fit % {' / '.join(names)} "
            f"{mixed} with it, {alone} eTS alone")
