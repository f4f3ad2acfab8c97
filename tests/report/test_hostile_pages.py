"""Markup and terminal escapes through the string-carrying fields of a table and a run
(a table's file name, its sidecar attrs: source, warnings, mapping; a run folder's
metrics.json unit and warnings; logs, vehicle files, rule bases and gap.json are in
test_hostile_files.py) reach no terminal raw, no report.md as live markup, and no
page as a running handler: the DOM is checked in headless Chromium after hovering every
plot (the hover boxes are where Bokeh renders a template as HTML).

Chromium and chromedriver as for tests/report/test_browser.py (skipped without them unless
``ETSID_REQUIRE_BROWSER=1``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from hostile import (
    ESCAPES,
    PAYLOAD,
    PWN,
    RAW,
    RLO,
    ROOT,
    chromium,
    hover_everything,
    live_markup,
    require_browser,
    run,
)

require_browser()

GAS = ROOT / "tests" / "data" / "gas_furnace.csv"
NAME = f"g<img src=x onerror={PWN}>{RLO}txt.csv"
"""A table's file name: markup (no slash, no quote) and a right-to-left override."""


@pytest.fixture(scope="module")
def browser() -> Any:
    yield from chromium()


@pytest.fixture(scope="module")
def hostile(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A table whose file name and sidecar attrs carry markup and escapes; identify, batch
    identify and their reports; the run's metrics.json then edited as a sender would."""
    root = tmp_path_factory.mktemp("hostile")
    table = root / NAME
    shutil.copy(GAS, table)
    (root / f"{NAME}.attrs.json").write_text(json.dumps({
        "source": f"src {PAYLOAD}{ESCAPES}{RLO}", "format": "table",
        "warnings": [f"warning {ESCAPES} {PAYLOAD} {RLO}"],
        "mapping": {"co2": f"co2 {PAYLOAD}"}}))
    printed = {"ingest": run("ingest", table, "-o", root / "t.parquet")}
    regressors = ("--output", "co2", "--regressors", "co2[k-1],input_gas_rate[k-4]")
    runs = root / f"runs {RLO}<b>"
    printed["identify"] = run("identify", table, *regressors, "--out", runs / "RUN", "--quiet")
    metrics = runs / "RUN" / "metrics.json"
    data = json.loads(metrics.read_text())
    data["outputs"]["co2"]["unit"] = f"{PAYLOAD}{ESCAPES}{RLO}"
    data.setdefault("warnings", []).append(f"metrics {PAYLOAD}{ESCAPES}")
    metrics.write_text(json.dumps(data))
    printed["report"] = run("report", runs / "RUN")
    batch = root / "BATCH"
    printed["batch"] = run("batch", "identify", table, *regressors, "-o", batch, "-j", "1",
                           "-q")
    printed["fleet"] = run("report", batch)
    return {"printed": printed, "run": runs / "RUN", "batch": batch}


def test_terminal_output_holds_no_raw_escape(hostile: dict[str, Any]) -> None:
    for command, text in hostile["printed"].items():
        raw = [repr(c) for c in RAW if c in text]
        assert raw == [], f"etsid {command} printed {raw} raw"
    assert "\\x1b]52" in hostile["printed"]["ingest"]  # the warning is shown, escaped


@pytest.mark.parametrize("folder", ["run", "batch"])
def test_report_md_holds_no_live_markup(hostile: dict[str, Any], folder: str) -> None:
    text = (hostile[folder] / "report" / "report.md").read_text(encoding="utf-8")
    assert [repr(c) for c in RAW if c in text] == []
    assert live_markup(text) == []


@pytest.mark.parametrize("folder", ["run", "batch"])
def test_no_handler_runs_on_hover(browser: Any, hostile: dict[str, Any], folder: str) -> None:
    state = hover_everything(browser, hostile[folder] / "report" / "index.html")
    assert state["pwned"] == 0, "a handler from a file ran"
    assert state["bad"] == [], f"live markup from a file in the DOM: {state['bad']}"
    assert RLO not in state["title"] + state["h1"] + state["text"]
    assert "\x1b" not in state["text"]
    if folder == "run":  # the hover boxes opened and show the unit as text
        assert "onerror" in state["tips"], "no hover box opened: the test saw nothing"


def test_the_judge_sees_a_handler_in_a_tooltip_template(browser: Any, tmp_path: Path) -> None:
    # the check can fail: a unit inside a Bokeh tooltip template (the old add_lines) runs
    from bokeh.embed import file_html
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.plotting import figure
    from bokeh.resources import INLINE

    src = ColumnDataSource({"t": list(range(50)), "y": [float(i % 7) for i in range(50)]})
    fig = figure(width=800, height=300)
    fig.line("t", "y", source=src)
    fig.add_tools(HoverTool(tooltips=[("y", f"@y{{0.0}} {PAYLOAD}")], mode="vline"))
    page = tmp_path / "old.html"
    page.write_text(file_html(fig, INLINE, "old"), encoding="utf-8")
    state = hover_everything(browser, page)
    assert state["pwned"] == 1 or state["bad"], "the judge did not see the old template's markup"
