"""Parts of the reports that are not plots: rule summaries, gap parameters, folder modes,
progress lines, the reduction of long series."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from test_report import fake_run

from etsid.ets import ETS
from etsid.ident.rundir import write_run
from etsid.report import make_report
from etsid.report.gap import parameters_text
from etsid.report.interactive import keep_rows
from etsid.report.rulebook import physical, readable, summarize


def two_regime_rules() -> dict:
    """A rule base learnt where the input gain is +3 at inv_alt ≈ 4 and −1 at inv_alt ≈ 1."""
    rng = np.random.default_rng(7)
    inv_alt = np.r_[rng.normal(4.0, 0.05, 400), rng.normal(1.0, 0.05, 400)]
    u = rng.normal(size=800)
    y = np.where(inv_alt > 2, 3.0, -1.0) * u + 0.01 * rng.normal(size=800)
    model = ETS(radius=0.3, input_names=["inv_alt[k-1]", "u_roll[k-1]"],
                output_names=["p"])
    model.run(np.c_[inv_alt, u], y[:, None])
    return model.to_dict()


def test_rule_summary_finds_the_dominant_input_and_its_sign_per_regime() -> None:
    rules = summarize(two_regime_rules())
    assert [r.number for r in rules] == list(range(1, len(rules) + 1)) and len(rules) >= 2
    for rule in rules:
        shares = [t.share for t in rule.terms["p"]]
        assert sum(shares) == pytest.approx(1.0) and shares == sorted(shares, reverse=True)
        top = rule.terms["p"][0]
        assert top.name == "u_roll[k-1]"
        expected = 3.0 if rule.focal["inv_alt[k-1]"] > 2 else -1.0
        assert top.coefficient == pytest.approx(expected, abs=0.3)


def test_readable_rules_are_short_lines_with_physical_units() -> None:
    text = readable(two_regime_rules(), top=1)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 100
    assert lines[0].startswith("Rule 1 (support ") and " 1/m (alt " in lines[0]
    assert "… 1 more terms" in text and "u_roll[k-1] (" in text
    assert physical("inv_alt[k-1]", 4.0) == "inv_alt[k-1] ≈ 4 1/m (alt 0.25 m)"
    assert physical("alt[k-1]", 0.3) == "alt[k-1] ≈ 0.3 m"
    assert physical("u_roll[k-1]", 0.1) == "u_roll[k-1] ≈ 0.1"  # dimensionless: no unit


def test_gap_parameters_print_no_unit_for_dimensionless_values() -> None:
    effect = {"parameters": {"R": {"value": 0.2498, "unit": "m", "stderr": 0.0084},
                             "exponent": {"value": 1.2356, "unit": "1", "stderr": 0.0259}}}
    assert parameters_text(effect) == "R = 0.2498 ± 0.0084 m, exponent = 1.236 ± 0.026"


def test_report_folder_follows_the_umask_and_says_what_it_does(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.report.build as build

    monkeypatch.setattr(build, "FIGURES", {"rates": build.FIGURES["rates"]})  # fast
    run_dir = write_run(fake_run(300), tmp_path / "run")
    said: list[str] = []
    old = os.umask(0o022)
    try:
        report = make_report(run_dir, say=said.append)
    finally:
        os.umask(old)
    assert report.directory.stat().st_mode & 0o777 == 0o755
    assert said[0] == "report: drawing static figure 1/1, rates.png …"
    assert any("flight overview" in s for s in said)


def test_reduction_keeps_every_extreme_and_the_gaps() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(100_000) * 0.004
    y = rng.normal(size=t.size)
    y[54_321] = 50.0
    y[77_777] = -50.0
    rows = keep_rows(t, [y], buckets=500)
    assert rows.size <= 1002 and {54_321, 77_777} <= set(rows.tolist())
    assert rows[0] == 0 and rows[-1] == t.size - 1
    assert keep_rows(t[:800], [y[:800]], buckets=500).size == 800  # short: every row


def test_overview_finds_a_relative_input_beside_the_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.report.build as build
    from etsid.sim import simulate
    from etsid.table import save_table

    monkeypatch.setattr(build, "FIGURES", {"rates": build.FIGURES["rates"]})  # fast
    save_table(simulate("hover-ige", duration=3.0, seed=1).table, tmp_path / "flight.parquet")
    run = fake_run(300)
    run.config["input"] = {"path": "flight.parquet"}  # relative to where identify ran
    run_dir = write_run(run, tmp_path / "run")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    page = make_report(run_dir).html.read_text()
    assert '<h2 id="overview">' in page and "No flight overview" not in page
    assert "Thrust command" in page and "Altitude, shaded by the rule" in page
    (tmp_path / "flight.parquet").unlink()
    page = make_report(run_dir).html.read_text()
    assert "No flight overview: flight.parquet (the run&#x27;s input) is not there" in page


def test_report_markdown_makes_raw_html_from_log_names_inert() -> None:
    """Names from a log (topics, files) can hold ``<script>``; report.md escapes raw HTML
    outside code, and code keeps its characters."""
    from etsid.report.page import markdown_safe

    text = "topic </mavros/imu><script>alert(1)</script> `a<b>` done\n```\n<kept>\n```"
    out = markdown_safe(text)
    assert "<script>" not in out and "&lt;script&gt;" in out
    assert "`a<b>`" in out and "\n<kept>\n" in out
