"""The report's regime section: the sentence, the rule → regime table, scores per regime."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.ident import IdentConfig, identify, read_run, write_run
from etsid.report import make_report
from etsid.report.regimes import regime_rows, regime_text, rule_rows


def _regime_table(n: int = 2400) -> pd.DataFrame:
    """Input gain 2 at 0.25 m, 1 at 2 m (rotor radius 0.165 m: in / out of ground effect)."""
    rng = np.random.default_rng(3)
    alt = np.where((np.arange(n) // 300) % 2 == 0, 0.25, 2.0) + 0.02 * rng.normal(size=n)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.6 * y[k - 1] + (2.0 if alt[k - 1] < 1.0 else 1.0) * u[k - 1]
        y[k] += 0.01 * rng.normal()
    table = pd.DataFrame({"y": y, "u": u, "alt": alt},
                         index=pd.Index(np.arange(n) * 0.02, name="t"))
    table.attrs["rotor_radius_m"] = 0.165
    return table


@pytest.fixture(scope="module")
def regime_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = identify(_regime_table(), IdentConfig(outputs=["y"], regressors="y[k-1],u[k-1]",
                                                segments="all", radius=0.3,
                                                antecedent="alt[k-1]"))
    return write_run(run, tmp_path_factory.mktemp("r") / "RUN")


def test_report_shows_sentence_rule_table_and_regime_scores(
        regime_run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.report.build as build

    monkeypatch.setattr(build, "FIGURES", {k: build.FIGURES[k] for k in ("rates",)})
    run = read_run(regime_run)
    block = run.metrics["regimes"]
    report = make_report(regime_run)
    md = report.markdown.read_text()
    html = report.html.read_text()
    assert block["sentence"] in md and "× larger at 0.2" in md
    assert "## What the model learnt" in md and "What the model learnt" in html
    _head, rows = rule_rows(run)
    assert len(rows) == len(block["rules"]) >= 2
    regimes = {r[-1] for r in rows}
    assert {"in ground effect", "out of ground effect"} <= regimes
    for row in rows:
        assert "| " + " | ".join(row) + " |" in md
    # z/R column = alt / R
    for row in rows:
        assert float(row[3]) == pytest.approx(float(row[2]) / 0.165, rel=0.05)
    _head, rows = regime_rows(run)
    names = [r[0] for r in rows]
    assert names.count("in ground effect") == 1 and names.count("out of ground effect") == 1
    transition = rows[names.index("transition")]
    assert transition[3] == "–"  # the flight never passes the band: no scores invented
    ige = rows[names.index("in ground effect")]
    per = {r["name"]: r for r in block["per_regime"]}["in ground effect"]
    assert ige[2] == f"{per['n_learn']} / {per['n_validation']}"
    assert float(ige[8]) == pytest.approx(per["outputs"]["y"]["free_run"]["fit"], abs=0.1)
    assert "bands by altitude over rotor radius z/R" in html


def test_regime_text_is_the_cli_block(regime_run: Path) -> None:
    run = read_run(regime_run)
    text = regime_text(run)
    assert text.startswith("rule → regime (bands by altitude over rotor radius z/R")
    assert text.splitlines()[-1] == f"learnt: {run.metrics['regimes']['sentence']}"
    run.metrics.pop("regimes")
    assert regime_text(run) == ""  # runs written before regimes existed
