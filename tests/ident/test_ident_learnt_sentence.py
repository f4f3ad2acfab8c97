"""The learnt sentence is defensible: enough support on both sides, a difference beyond its
95 % interval (given), sign changes flagged as implausible, none from ``predict``; scores per
regime from too few or too still samples are flagged, not printed as a fit %."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
from regime_flight import two_regime_table

from etsid.ident import IdentConfig, identify, predict
from etsid.ident.regimes import bands_for, learnt_sentence, regime_metrics
from etsid.ident.rundir import write_run

BASE = dict(outputs=["y"], regressors="y[k-1],u[k-1]", segments="all", radius=0.3,
            antecedent="alt[k-1]")


def _table(gain_low: float, gain_high: float, n: int = 3000, seed: int = 0) -> pd.DataFrame:
    return two_regime_table(gain_low, gain_high, n, seed, rotor_radius_m=0.165)


def test_a_real_difference_is_claimed_with_an_interval_that_holds_the_truth() -> None:
    block = identify(_table(2.0, 1.0), IdentConfig(**BASE)).metrics["regimes"]
    facts = block["sentence_facts"]
    assert facts["learnt"] is True
    lo, hi = facts["ratio_ci"]
    assert lo < 2.0 < hi and lo > 1.0
    assert re.search(r"is [12]\.\d\d× larger at 0\.\d\d m .* than at [12]\.\d\d m",
                     block["sentence"])
    assert "95 % interval" in block["sentence"]


def test_no_difference_is_not_claimed() -> None:
    block = identify(_table(1.5, 1.5), IdentConfig(**BASE)).metrics["regimes"]
    facts = block["sentence_facts"]
    assert facts["learnt"] is False
    if len(block["rules"]) > 1 and facts["ratio_ci"] is not None:
        lo, hi = facts["ratio_ci"]
        assert lo <= 1.0 <= hi
        assert block["sentence"].startswith("No regime difference learnt")


def _rules(share_low: float) -> list[dict]:
    return [{"rule": 1, "alt_m": 0.3, "regime": "below 0.5 m", "share": share_low,
             "focal": {}}, {"rule": 2, "alt_m": 2.0, "regime": "above 1 m",
                            "share": 1 - share_low, "focal": {}}]


def test_a_sign_change_is_flagged_not_reported() -> None:
    gains = [{"output": "p", "input": "sp_p", "term": "sp_p[k-1]", "per_rule": [-0.2, 0.5]}]
    se = {("p", "sp_p"): [0.02, 0.02]}
    text, facts = learnt_sentence(_rules(0.5), gains, None, se, 100, 1000)
    assert text.startswith("Not learnt") and "implausible" in text
    assert "between at" not in text and facts["learnt"] is False


def test_rules_without_support_are_not_compared() -> None:
    gains = [{"output": "p", "input": "sp_p", "term": "sp_p[k-1]", "per_rule": [0.9, 0.5]}]
    se = {("p", "sp_p"): [0.01, 0.01]}
    text, facts = learnt_sentence(_rules(0.05), gains, None, se, 100, 1000)  # 50 rows < 100
    assert "only rule 2 leads enough learning samples" in text and facts["learnt"] is False
    text, facts = learnt_sentence(_rules(0.2), gains, None, se, 100, 1000)
    assert facts["learnt"] is True and "1.80× larger" in text


def test_predict_prints_no_sentence_and_still_regimes_are_flagged(tmp_path) -> None:
    run = identify(_table(2.0, 1.0), IdentConfig(**BASE))
    write_run(run, tmp_path / "run")
    other = predict(_table(2.0, 1.0, n=1200, seed=5), tmp_path / "run" / "rules.json",
                    segments="all")
    assert other.metrics["regimes"]["sentence"] is None


def test_scores_per_regime_from_few_or_still_samples_are_flagged() -> None:
    rng = np.random.default_rng(1)
    n = 1000  # 20 s at 50 Hz, all validation
    alt = np.r_[np.full(100, 0.25), np.full(600, 0.5), np.full(300, 2.0)]  # 2 s / 12 s / 6 s
    p = np.r_[0.3 * rng.normal(size=700), 0.01 * rng.normal(size=300)]  # still up high
    Y = p[:, None]
    pred = {k: Y + 0.05 * rng.normal(size=Y.shape) for k in
            ("y_val", "y_sim", "y_arx_val", "y_arx_sim")}
    out = regime_metrics(alt, bands_for(0.165), Y, ["p"], pred, 0, np.arange(n) * 0.02)
    low, mid, high = (r["outputs"]["p"] for r in out)
    assert not low["informative"] and "too few samples (2.0 s" in low["reason"]
    assert low["free_run"]["fit"] is None and low["free_run"]["fit_raw"] is not None
    assert mid["informative"] and mid["free_run"]["fit"] is not None
    assert not high["informative"] and "too still" in high["reason"]
