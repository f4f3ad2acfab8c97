"""Markup and terminal escapes through every string-carrying field of the files etsid reads
(a table's file name, its sidecar attrs: source, warnings, mapping; a run folder's
metrics.json unit and warnings) reach no terminal raw, no report.md as live markup, and no
page as a running handler: the DOM is checked in headless Chromium after hovering every
plot (the hover boxes are where Bokeh renders a template as HTML).

Chromium and chromedriver as for tests/report/test_browser.py (skipped without them unless
``ETSID_REQUIRE_BROWSER=1``).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from etsid.cli import cli

ROOT = Path(__file__).resolve().parents[2]
GAS = ROOT / "tests" / "data" / "gas_furnace.csv"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
REQUIRED = os.environ.get("ETSID_REQUIRE_BROWSER") == "1"

PWN = "window.__pwned=1"
PAYLOAD = (f'<img src=x onerror="{PWN}"><svg onload="{PWN}"></svg><script>{PWN}</script>'
           f'<a href="javascript:{PWN}">x</a>')
ESCAPES = "\x1b]52;c;QUFBQQ==\x07\x1b[2J\x9b31m"
RLO = "\u202e"
RAW = ("\x1b", "\x07", "\x9b", RLO)
NAME = f"g<img src=x onerror={PWN}>{RLO}txt.csv"
"""A table's file name: markup (no slash, no quote) and a right-to-left override."""

DEEP_DOM = """
const found = {pwned: window.__pwned || 0, bad: [], tips: ""};
function walk(root) {
  for (const el of root.querySelectorAll("*")) {
    const tag = el.tagName.toLowerCase();
    if ((tag === "img" && el.getAttribute("src") === "x") || el.hasAttribute("onerror") ||
        el.hasAttribute("onload") || (tag === "script" && el.type !== "application/json" &&
                              el.textContent.includes("__pwned"))
        || (tag === "a" && (el.getAttribute("href") || "").startsWith("javascript:")))
      found.bad.push(el.outerHTML.slice(0, 120));
    if (el.className && String(el.className).includes("tooltip")) found.tips += el.textContent;
    if (el.shadowRoot) walk(el.shadowRoot);
  }
}
walk(document);
found.title = document.title;
found.h1 = [...document.querySelectorAll("h1")].map(e => e.textContent).join(" ");
found.text = document.body.innerText;
return JSON.stringify(found);
"""

CANVASES = """
const rects = [];
function walk(root) {
  for (const el of root.querySelectorAll("*")) {
    if (el.tagName === "CANVAS") {
      const r = el.getBoundingClientRect();
      if (r.width > 200 && r.height > 80) rects.push([r.left, r.top, r.width, r.height]);
    }
    if (el.shadowRoot) walk(el.shadowRoot);
  }
}
walk(document);
return JSON.stringify(rects);
"""

IDLE = ("return document.readyState === 'complete' && typeof Bokeh !== 'undefined' && "
        "Bokeh.documents.length > 0 && Bokeh.documents.every(d => d.is_idle)")

if not (CHROMIUM and DRIVER):
    if REQUIRED:
        raise RuntimeError("ETSID_REQUIRE_BROWSER=1 but chromium/chromedriver are missing")
    pytest.skip("needs chromium and chromedriver (apt-get install chromium chromium-driver)",
                allow_module_level=True)

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium (the test extra)")


@pytest.fixture(scope="module")
def browser() -> Any:
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,900"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    yield driver
    driver.quit()


def hover_everything(driver: Any, page: Path) -> dict[str, Any]:
    """Load ``page``, draw every plot, move the mouse across each one (hover boxes open),
    and return what the DOM holds: handlers that ran, live markup, hover-box text."""
    driver.set_window_size(1280, 900)
    driver.get(page.resolve().as_uri())
    deadline = time.monotonic() + 60
    while driver.execute_script("return document.readyState") != "complete":
        assert time.monotonic() < deadline, f"{page}: never finished loading"
        time.sleep(0.05)
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(1280, min(int(height) + 40, 16000))
    while not driver.execute_script(IDLE):
        assert time.monotonic() < deadline, f"{page}: the plots were never drawn"
        time.sleep(0.05)
    time.sleep(0.3)
    rects = json.loads(driver.execute_script(CANVASES))
    assert rects, f"{page}: no plot drawn"
    tips = ""
    for left, top, width, h in rects:
        for frac in (0.2, 0.4, 0.6, 0.8):
            x, y = left + frac * width, top + 0.5 * h
            driver.execute_cdp_cmd("Input.dispatchMouseEvent",
                                   {"type": "mouseMoved", "x": x, "y": y})
            time.sleep(0.05)
            tips += json.loads(driver.execute_script(DEEP_DOM))["tips"]
    state = json.loads(driver.execute_script(DEEP_DOM))
    state["tips"] = tips
    return state


def run(*args: object) -> str:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


def live_markup(markdown: str) -> list[str]:
    """Tags outside code in ``markdown`` (a Markdown viewer renders them as HTML)."""
    text = re.sub(r"```.*?```", "", markdown, flags=re.S)
    text = re.sub(r"`[^`]*`", "", text)
    return re.findall(r"<(?:img|svg|script|a)\b[^>]*>", text)


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
