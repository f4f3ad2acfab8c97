"""Regimes of a run: altitude bands, scores per band, rule → regime table, learnt sentence."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from etsid.ident import IdentConfig, identify, predict
from etsid.ident.regimes import bands_for, input_gains, rotor_radius

LOW, HIGH = 0.25, 2.0


def _table(n: int = 3000, seed: int = 0, radius: float | None = 0.165) -> pd.DataFrame:
    """y[k] = 0.6 y[k-1] + g u[k-1]: input gain 2 low (alt 0.25 m) and 1 high (alt 2 m),
    the altitude dwelling 6 s at each."""
    rng = np.random.default_rng(seed)
    alt = np.where((np.arange(n) // 300) % 2 == 0, LOW, HIGH) + 0.02 * rng.normal(size=n)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):
        g = 2.0 if alt[k - 1] < 1.0 else 1.0
        y[k] = 0.6 * y[k - 1] + g * u[k - 1] + 0.01 * rng.normal()
    table = pd.DataFrame({"y": y, "u": u, "alt": alt},
                         index=pd.Index(np.arange(n) * 0.02, name="t"))
    if radius is not None:
        table.attrs["rotor_radius_m"] = radius
    return table


BASE = dict(outputs=["y"], regressors="y[k-1],u[k-1]", segments="all", radius=0.3)


def test_bands_in_z_over_r_and_in_metres() -> None:
    zr = bands_for(0.165)
    assert zr.basis == "z/R" and zr.edges_m == pytest.approx((0.33, 0.66))
    np.testing.assert_array_equal(zr.of(np.array([0.2, 0.5, 1.0, np.nan])), [0, 1, 2, -1])
    assert zr.name_of(0.25) == "in ground effect" and zr.name_of(1.5) == "out of ground effect"
    metres = bands_for(None)
    assert metres.basis == "m" and metres.name_of(0.25) == "below 0.5 m"
    assert "ground effect" not in " ".join(metres.names)
    assert rotor_radius({"rotor_radius_m": 0.2}) == 0.2
    assert rotor_radius({"rotor_radius_m": -1.0}) is None and rotor_radius({}) is None


def test_scheduled_rules_map_to_regimes_and_the_sentence_finds_the_gain_ratio() -> None:
    table = _table()
    run = identify(table, IdentConfig(**BASE, antecedent="alt[k-1]"))
    block = run.metrics["regimes"]
    assert block["basis"] == "z/R" and block["rotor_radius_m"] == 0.165
    rules = block["rules"]
    assert len(rules) >= 2
    low = min(rules, key=lambda r: r["alt_m"])
    high = max(rules, key=lambda r: r["alt_m"])
    assert low["alt_m"] < 0.5 and low["regime"] == "in ground effect"
    assert high["alt_m"] > 1.5 and high["regime"] == "out of ground effect"
    assert all(r["alt_source"] == "focal" and set(r["focal"]) == {"alt[k-1]"} for r in rules)
    # birth and lifetime: born inside the learning part, alive until the freeze
    t_freeze = run.metrics["validation"]["t_start"]
    for r in rules:
        assert 0 <= r["born_t"] < t_freeze
        assert r["born_t"] + r["lifetime_s"] == pytest.approx(t_freeze, abs=0.03)
    assert sum(r["share"] for r in rules) == pytest.approx(1.0)
    # the consequents carry the known input gains (2 low, 1 high)
    gains = {(g["output"], g["input"]): g["per_rule"] for g in block["gains"]}
    assert gains[("y", "u")][low["rule"] - 1] == pytest.approx(2.0, abs=0.1)
    assert gains[("y", "u")][high["rule"] - 1] == pytest.approx(1.0, abs=0.1)
    sentence = block["sentence"]
    ratio = float(re.search(r"is ([0-9.]+)× larger", sentence).group(1))
    assert ratio == pytest.approx(2.0, rel=0.1)
    assert f"(in ground effect, rule {low['rule']})" in sentence
    assert f"rule {high['rule']})" in sentence


def test_scores_per_regime_cover_the_validation_rows() -> None:
    table = _table()
    run = identify(table, IdentConfig(**BASE, antecedent="alt[k-1]"))
    per = {r["name"]: r for r in run.metrics["regimes"]["per_regime"]}
    n_val = run.metrics["validation"]["n_validation"]
    assert sum(r["n_validation"] for r in per.values()) == n_val
    val = run.predictions[run.predictions["part"] == "validation"]
    alt = table["alt"].reindex(val["t"], method="nearest").to_numpy()
    assert per["in ground effect"]["n_validation"] == int(np.count_nonzero(alt < 0.33))
    assert per["transition"]["n_validation"] == 0 and not per["transition"]["outputs"]
    for name in ("in ground effect", "out of ground effect"):
        y = per[name]["outputs"]["y"]
        assert y["free_run"]["fit"] > 90.0
        assert y["one_step"]["n"] == per[name]["n_validation"]
    # the flat ARX, one gain for both regimes, is worse in each of them
    for name in ("in ground effect", "out of ground effect"):
        y = per[name]["outputs"]["y"]
        assert y["arx_free_run"]["rmse"] > 2 * y["free_run"]["rmse"]


def test_one_rule_is_one_regime_and_metres_without_a_rotor_radius() -> None:
    table = _table(1500, radius=None)
    run = identify(table, IdentConfig(**BASE, max_rules=1))
    block = run.metrics["regimes"]
    assert block["basis"] == "m" and "rotor radius unknown" in block["note"]
    assert [r["regime"] for r in block["rules"]] == ["whole flight"]
    assert block["rules"][0]["alt_source"] == "led rows"
    assert block["sentence"].startswith("One rule: the model found one regime")
    assert [b["name"] for b in block["per_regime"]] == ["below 0.5 m", "0.5–1 m",
                                                          "above 1 m"]


def test_no_altitude_no_bands_but_rules_and_gains() -> None:
    table = _table(1500).drop(columns="alt")
    table["h"] = _table(1500)["alt"]
    run = identify(table, IdentConfig(**BASE, antecedent="h[k-1]"))
    block = run.metrics["regimes"]
    assert block["basis"] is None and block["per_regime"] == []
    assert "no altitude" in block["note"]
    assert len(block["rules"]) >= 2 and all(r["regime"] is None for r in block["rules"])
    assert "at h[k-1]" in block["sentence"]
    one = identify(table, IdentConfig(**BASE, max_rules=1)).metrics["regimes"]
    assert [r["regime"] for r in one["rules"]] == ["whole record"]
    assert "over the whole record" in one["sentence"]


def test_input_gains_first_lag_and_sum_of_every_lag() -> None:
    table = _table(1500)
    run = identify(table, IdentConfig(outputs=["y"], regressors="y[k-1],u[k-3],u[k-1..k-2]",
                                      segments="all", max_rules=1))
    (gain,) = input_gains(run.rules)
    cons = run.rules["rules"][0]["consequent_original_units"]
    names = run.rules["inputs"]
    expect = sum(cons[j + 1][0] for j, name in enumerate(names) if name.startswith("u["))
    assert gain["output"] == "y" and gain["input"] == "u" and gain["term"] == "u[k-1]"
    assert gain["sum_per_rule"][0] == pytest.approx(expect)
    assert gain["per_rule"][0] == pytest.approx(cons[names.index("u[k-1]") + 1][0])
    # the known system: y[k] = 0.6 y[k-1] + g u[k-1], g = 2 low and 1 high (one rule: between)
    assert 1.0 < gain["per_rule"][0] < 2.0
    assert abs(gain["sum_per_rule"][0] - gain["per_rule"][0]) < 0.2


def test_predict_scores_regimes_of_another_flight(tmp_path) -> None:
    import json

    run = identify(_table(), IdentConfig(**BASE, antecedent="alt[k-1]"))
    path = tmp_path / "rules.json"
    path.write_text(json.dumps(run.rules))
    other = predict(_table(1200, seed=5), path, segments="all")
    block = other.metrics["regimes"]
    assert block["basis"] == "z/R"
    assert [r["id"] for r in block["rules"]] == [r["id"] for r in run.metrics["regimes"]["rules"]]
    assert all(r["born_t"] is None and r["lifetime_s"] is None for r in block["rules"])
    assert sum(r["share"] for r in block["rules"]) == pytest.approx(1.0)
    per = {r["name"]: r for r in block["per_regime"]}
    assert per["in ground effect"]["n_validation"] + per["out of ground effect"][
        "n_validation"] == other.metrics["validation"]["n_validation"]
    assert per["in ground effect"]["outputs"]["y"]["free_run"]["fit"] > 90.0


def test_the_rule_base_carries_the_rotor_radius_to_predict(tmp_path) -> None:
    """A log read from a file knows no rotor radius: predict takes the one the rules were
    learnt with (and says so), --vehicle's (the table's own) wins, a damaged one is refused."""
    import json

    from etsid.errors import IdentError

    run = identify(_table(radius=0.2), IdentConfig(**BASE, antecedent="alt[k-1]"))
    assert run.rules["regressors"]["rotor_radius_m"] == 0.2
    path = tmp_path / "rules.json"
    path.write_text(json.dumps(run.rules))
    # z/R bands of R = 0.2 m: in ground effect below 0.4 m, out above 0.8 m
    other = predict(_table(1200, seed=5, radius=None), path, segments="all", learn=True)
    block = other.metrics["regimes"]
    assert block["basis"] == "z/R" and block["rotor_radius_m"] == 0.2
    assert block["bands"][0]["alt_below_m"] == pytest.approx(0.4)
    assert other.config["model"]["notes"][0].startswith("rotor radius 0.2 m from the rule base")
    assert other.rules_final["regressors"]["rotor_radius_m"] == 0.2
    assert (other.rules_final["regressors"]["sample_rate_hz"]
            == run.rules["regressors"].get("sample_rate_hz"))
    own = predict(_table(1200, seed=5, radius=0.165), path, segments="all")
    assert own.metrics["regimes"]["rotor_radius_m"] == 0.165
    assert not any("rule base" in n for n in own.config["model"]["notes"])
    without = identify(_table(radius=None), IdentConfig(**BASE, antecedent="alt[k-1]"))
    assert "rotor_radius_m" not in without.rules["regressors"]
    for bad in (-0.1, "0.2", 0, True):
        damaged = dict(run.rules, regressors={**run.rules["regressors"], "rotor_radius_m": bad})
        path.write_text(json.dumps(damaged))
        with pytest.raises(IdentError, match="regressors/rotor_radius_m must be a rotor radius"):
            predict(_table(1200, seed=5, radius=None), path, segments="all")


def test_rule_table_gives_each_rules_thrust_command() -> None:
    # thrust 0.45 on the low dwells and 0.55 on the high ones: each rule's median is its own
    table = _table()
    table["u_thrust"] = np.where(table["alt"] < 1.0, 0.45, 0.55)
    run = identify(table, IdentConfig(**BASE, antecedent="alt[k-1]"))
    rules = run.metrics["regimes"]["rules"]
    low = min(rules, key=lambda r: r["alt_m"])
    high = max(rules, key=lambda r: r["alt_m"])
    assert (low["thrust"], high["thrust"]) == (pytest.approx(0.45), pytest.approx(0.55))
    assert low["thrust_source"] == "led rows"
    scheduled = identify(table, IdentConfig(**BASE, antecedent="alt[k-1],u_thrust[k-1]"))
    assert all(r["thrust_source"] == "focal" for r in scheduled.metrics["regimes"]["rules"])
    plain = identify(_table(), IdentConfig(**BASE, antecedent="alt[k-1]"))
    assert all(r["thrust"] is None for r in plain.metrics["regimes"]["rules"])


def test_a_rule_on_inv_alt_has_its_focal_altitude_in_every_table() -> None:
    """The rule → regime table gave the median altitude of the rows a rule leads (1.66 m)
    where `etsid rules` gave its focal point's (1.18 m) for the same rule: now both give
    the focal point's, 1 / inv_alt, under the same rule number."""
    from etsid.report.regimes import regimes_markdown
    from etsid.report.rulebook import readable, summarize

    run = identify(_table(), IdentConfig(**BASE, antecedent="inv_alt[k-1]"))
    table = run.metrics["regimes"]["rules"]
    assert len(table) >= 2 and all(r["alt_source"] == "focal" for r in table)
    book = summarize(run.rules)
    text = readable(run.rules)
    for row, rule in zip(table, book, strict=True):
        assert row["rule"] == rule.number
        assert row["alt_m"] == pytest.approx(1.0 / rule.focal["inv_alt[k-1]"], rel=1e-12)
        assert f"Rule {rule.number} " in text and f"(alt {row['alt_m']:.3g} m)" in text
    low = min(table, key=lambda r: r["alt_m"])
    assert low["alt_m"] < 0.5 and low["regime"] == "in ground effect"
    assert f"| {low['alt_m']:.2f} |" in "\n".join(regimes_markdown(run))
