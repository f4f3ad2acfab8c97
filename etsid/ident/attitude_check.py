"""Does this log's rate model gain from the attitude states? Decided on the learning part.

The default rate model carries ``roll[k-1]``, ``pitch[k-1]`` as states when the attitude
loop closes around its inputs (:data:`etsid.ident.defaults.ATTITUDE_TERMS`); in free run
they are integrated from the simulated rates (:mod:`etsid.ident.simulate`). On the
simulated flights that lifts every model; on the one real flight where it could be tried
(PX4 attitude setpoints) the integrated angles drift from the flown ones and the free-run
fit drops (docs/identify.md, "Attitude states"). So with ``--attitude-states auto`` the
learning part decides: its last ``validate`` share of excited rows is an inner validation,
ARX is fitted on the rows before it with and without the angles, and each is simulated
over the inner validation. The angles stay when the mean free-run fit of ``p`` and ``q``
(the rates they feed back into) is higher with them. The validation part is never looked at.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from etsid.ident.arx import ARX
from etsid.ident.checks import split_excited
from etsid.ident.metrics import fit_percent
from etsid.ident.regressors import Regression, RegressorSpec, attitude_map
from etsid.ident.simulate import envelope, free_run

CHECKED_OUTPUTS = ("p", "q")
"""The rates the attitude states feed back into; their mean free-run fit decides."""

INNER_SHARE = 0.3
"""Share of the learning part's excited rows in the inner validation when the run itself
holds out nothing (``validate`` 0)."""

MIN_INNER_ROWS = 50
"""Fewest inner-validation rows for a decision; fewer keep the angles, unchecked."""


@dataclass
class AttitudeCheck:
    """Outcome of :func:`check_attitude_states`.

    Attributes
    ----------
    keep
        Keep the attitude states.
    spec
        The spec to learn: the input spec, or it without the attitude terms.
    note
        One line for people (replaces the model choice's attitude note).
    fits
        Inner-validation free-run fit %, ``{"with": {...}, "without": {...}}`` per checked
        output (empty when not checked).
    """

    keep: bool
    spec: RegressorSpec
    note: str
    fits: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (config.json ``model.attitude_states``)."""
        return {"kept": self.keep, "inner_free_run_fit": self.fits, "note": self.note}


def _without_angles(spec: RegressorSpec) -> tuple[RegressorSpec, np.ndarray]:
    """The spec without its attitude-state terms, and the columns of ``X`` it keeps."""
    drop = {j for j, _, _ in attitude_map(spec)}
    keep = np.array([j for j in range(len(spec.terms)) if j not in drop], dtype=int)
    return replace(spec, terms=tuple(spec.terms[j] for j in keep)), keep


def _inner_fits(reg: Regression, spec: RegressorSpec, inner: int, end: int, n_table: int
                ) -> dict[str, float]:
    """ARX fitted on rows ``[0, inner)``, free-run fit % over ``[inner, end)`` per checked
    output (NaN where the simulation diverged)."""
    sub = Regression(reg.X[:end], reg.Y[:end], reg.rows[:end], reg.t[:end], {},
                     None if reg.segment is None else reg.segment[:end], None,
                     reg.kinematics)
    arx = ARX.fit(sub.X[:inner], sub.Y[:inner])
    sim = free_run(arx, sub, spec, inner, n_table, envelope(sub.Y))
    out = list(spec.outputs)
    return {y: fit_percent(sub.Y[inner:, out.index(y)], sim[:, out.index(y)])
            for y in CHECKED_OUTPUTS}


def _mean(fits: dict[str, float]) -> float:
    values = list(fits.values())
    return float(np.mean(values)) if all(np.isfinite(values)) else -np.inf


def check_attitude_states(reg: Regression, spec: RegressorSpec, split: int,
                          excited: np.ndarray, n_table: int, validate: float
                          ) -> AttitudeCheck:
    """Keep or drop the attitude states of ``spec`` by the inner split of the learning part
    (module docstring).

    Parameters
    ----------
    reg
        Lag matrices of ``spec`` (with ``kinematics``).
    spec
        The default rate model with attitude terms.
    split
        First row of the (outer) validation part.
    excited
        Excitation flag of every row of ``reg``.
    n_table
        Rows of the table ``reg`` was built from.
    validate
        Share of the excited rows held out (also used for the inner split).
    """
    terms = ",".join(str(spec.terms[j]) for j, _, _ in attitude_map(spec))
    base = f"attitude states {terms}: the attitude loop closes around the inputs"
    lean, columns = _without_angles(spec)
    n_params = reg.X.shape[1] + 1
    inner = split_excited(excited[:split], validate or INNER_SHARE) if split > 0 else 0
    if split - inner < MIN_INNER_ROWS or inner < 2 * n_params:
        return AttitudeCheck(True, spec, f"{base}; kept unchecked (learning part too short "
                                         "for an inner split); --attitude-states none to "
                                         "leave them out")
    with_angles = _inner_fits(reg, spec, inner, split, n_table)
    lean_reg = Regression(reg.X[:, columns], reg.Y, reg.rows, reg.t, reg.skipped,
                          reg.segment, reg.S, None)
    without = _inner_fits(lean_reg, lean, inner, split, n_table)
    keep = _mean(with_angles) > _mean(without)

    def text(f: dict[str, float]) -> str:
        return " / ".join(f"{v:.1f}" for v in f.values())

    verdict = "kept" if keep else "left out"
    note = (f"{base}; {verdict}: on an inner split of the learning part ARX free-run fit "
            f"{'/'.join(CHECKED_OUTPUTS)} {text(with_angles)} % with them, {text(without)} % "
            "without (integrated from the simulated rates in free run; --attitude-states "
            "on|none to force)")
    return AttitudeCheck(keep, spec if keep else lean, note,
                         {"with": with_angles, "without": without})
