"""Every numeric module-level constant of ``etsid/gap`` is accounted for.

Each is in one class below; the hand-set *decision* constants (a statistic is compared
with them to decide a verdict, a name or a confidence) are the ones the method must keep
few, and each must say its reason in its docstring. A constant added to the package without
a class fails here, so the count in docs/gap.md ("Constants") cannot drift.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

GAP = Path(__file__).resolve().parents[2] / "etsid" / "gap"
DOCS = Path(__file__).resolve().parents[2] / "docs" / "gap.md"

DECISION = {
    "floors.GYRO_FLOOR", "floors.KINEMATIC_FLOOR", "likelihood.AIRFRAME_SCALES",
    "detectable.BELOW_CONFIDENCE", "verdict.WORSEN_Z", "loop.LOOP_TILT",
    "vehicle_check.PLAUSIBLE", "signals.MIN_AIRBORNE_S", "nominal.STRUCTURE_Z",
    "nominal.MIN_VOLTAGE_COVER",
}
"""Thresholds that decide a verdict, a name or a confidence, set by hand (the calibrated
ones live in calibration.json, written by benchmarks/gap_calibrate.py)."""
EVIDENCE = {
    "plausible.MAX_TILT_DEG", "plausible.UPSET_PAD_S", "plausible.DRAG_CHECK_SPEED",
    "plausible.MIN_DRAG", "plausible.CLIMB_WINDOW_S", "plausible.MAX_CLIMB_DISAGREE",
    "nominal.ENVELOPE_FACTOR", "nominal.SPEED_MARGIN", "run.CLIMB_MARGIN", "signals.EDGE_S",
    "signals.MAX_EVIDENCE_S", "signals.WINDOW_S", "signals.LEAD_S",
}
"""Which samples are evidence at all (implausible states, outside SIM's envelope, edges)."""
ESTIMATOR = {
    "criterion.N_FOLDS", "criterion.BLOCK_S", "criterion.GAP_S", "criterion.BOOTSTRAP",
    "criterion.PAIR_POOL", "criterion.SCREEN_SHARE", "criterion.BOOTSTRAP_SEED",
    "noise.MAX_ORDER", "noise.SAMPLES_PER_CUTOFF", "fitting.GRID_POINTS",
    "fitting.SCALAR_GRID", "fitting.REFINED_STARTS",
    "fitting.GRID_POINTS_3", "floors.NOISE_BAND_HZ", "floors.SEGMENT_S",
    "floors._SYNTH_SAMPLES", "floors._SYNTH_SEED", "loop.LOOP_BANDS_HZ", "loop.SEGMENT_S",
    "loop.MIN_SEGMENTS", "nominal.CUTOFF_HZ", "nominal.K_DEFAULT", "nominal.TAU_BOUNDS",
    "nominal.NOMINAL_DELAYS_S", "nominal.VOLTAGE_CUTOFF_HZ", "nominal.QUADRATIC_SPEED",
    "nominal.RIDGE", "nominal.K_SEARCH", "whiten.AR_ORDER", "whiten.CUTOFF_HZ",
    "whiten.GLS_ITERATIONS", "whiten.SIM_DELAYS_S", "whiten.SIM_TAUS_S", "signals.MODEL_HZ",
    "signals.ANTIALIAS_SHARE", "signals.ANALYSIS_CUTOFF_HZ", "run.SIM_FIT_SHARE",
    "run.FIT_SHARE", "detectable.FRACTIONS", "detectable.LEAST_POWER",
    "vehicle_check.MAX_DELAY_S",
    "vehicle_check.DELAY_STEP_S", "vehicle_check.EFFECTIVENESS_HIGHPASS_HZ",
    "residual_model.MAX_TRAINING",
    "candidates.MAX_ESTIMATOR_TIME_S", "candidates.GE_MAX_RATIO",
}
"""Settings of an estimator (folds, orders, grids, bands, search ranges): they change how
precisely a statistic is estimated, and no statistic is compared with them."""
REPORT = {
    "locate.N_BINS", "locate.LOWEST_FLOWN_QUANTILE", "locate.MIN_ETA2",
    "locate.SEGMENT_WINDOW_S", "locate.MAX_SEGMENTS", "residual_model.MIN_GAIN",
}
"""What is said about a mismatch (its regime, its segments, the eTS residual model), not
whether there is one or what is named."""
STRUCTURE = {
    "nominal.GRAVITY", "candidates.MAX_MOTORS", "nominal.MOTOR_TERMS_CACHED",
    "nominal.FEATURES_KEYS", "nominal.DRAG_TERMS", "nominal.OFFSET_TERM",
    "nominal.QUADRATIC_TERMS", "nominal.RATE_TERMS",
}
"""Physical constants, indices into the model's terms, cache sizes."""
VOCABULARY = {"candidates.LIBRARY", "candidates.WIND_PARAMS", "candidates.TORQUE_PER_THRUST"}
"""The effects' laws: each parameter's search bounds and no-effect value (a fit at a bound
gets no weight, verdict rule 3; the priors are declared with each effect in the registry)."""


def _numeric_constants() -> set[str]:
    """``module.NAME`` of every module-level upper-case constant holding a number."""
    found = set()
    for path in sorted(GAP.glob("*.py")) + sorted((GAP / "effects").glob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if not isinstance(node, (ast.Assign, ast.AnnAssign)):
                continue
            target = node.targets[0] if isinstance(node, ast.Assign) else node.target
            if not (isinstance(target, ast.Name) and target.id.upper() == target.id):
                continue
            if any(isinstance(c, ast.Constant) and isinstance(c.value, (int, float))
                   and not isinstance(c.value, bool) for c in ast.walk(node.value)):
                found.add(f"{path.stem}.{target.id}")
    return found


def _docstring(qualified: str) -> str:
    """The docstring after a constant, or after the group of constants declared on
    consecutive lines with it (a group of constants may share one)."""
    module, name = qualified.split(".")
    body = ast.parse((GAP / f"{module}.py").read_text(encoding="utf-8")).body
    for i, node in enumerate(body):
        target = getattr(node, "target", None) or (getattr(node, "targets", None) or [None])[0]
        if isinstance(target, ast.Name) and target.id == name:
            for nxt in body[i + 1:i + 4]:
                if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant):
                    return str(nxt.value.value)
    return ""


def test_every_numeric_constant_is_in_exactly_one_class() -> None:
    classes = [DECISION, EVIDENCE, ESTIMATOR, REPORT, STRUCTURE, VOCABULARY]
    listed = set().union(*classes)
    assert sum(len(c) for c in classes) == len(listed), "a constant is in two classes"
    found = _numeric_constants()
    assert found - listed == set(), "classify these constants"
    assert listed - found == set(), "these constants are gone: drop them from the classes"


def test_every_decision_constant_says_why_and_docs_count_them() -> None:
    """A decision constant carries its reason in a docstring (physics, statistics or the
    numerics of a rule), and docs/gap.md lists each and states their number."""
    docs = DOCS.read_text(encoding="utf-8")
    for name in DECISION:
        doc = _docstring(name)
        assert len(doc) > 40, f"{name}: no reason in its docstring"
        assert f"`{name.split('.')[1]}`" in docs, f"{name} missing from docs/gap.md"
    stated = re.search(r"(\d+) hand-set decision constants", docs)
    assert stated and int(stated.group(1)) == len(DECISION), "docs/gap.md's count is stale"
