"""Every kind of report opened in a real browser (headless Chromium driven by chromedriver).

Each page is loaded from disk with the network unused, Bokeh is waited for until its
document is idle, and the test fails on a JavaScript console error, a request for any
resource (the page must work offline), a plot without data, a static figure that does not
decode, or a section that is missing. A full-page screenshot of each lands in
``test-artifacts/browser/`` (gitignored; CI keeps it as an artefact).

Chromium and chromedriver come from Debian (``apt-get install chromium chromium-driver``;
``.ci/run`` installs them). Without them the tests skip, unless ``ETSID_REQUIRE_BROWSER=1``
(set by ``.ci/run``): then they fail.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from etsid.cli import cli

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts" / "browser"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
REQUIRED = os.environ.get("ETSID_REQUIRE_BROWSER") == "1"

if not (CHROMIUM and DRIVER):
    if REQUIRED:
        raise RuntimeError("ETSID_REQUIRE_BROWSER=1 but chromium/chromedriver are not "
                           "installed (apt-get install chromium chromium-driver)")
    pytest.skip("headless browser tests need chromium and chromedriver "
                "(apt-get install chromium chromium-driver)", allow_module_level=True)

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium (the test extra)")

PAGE_STATE = """
const out = {bokeh: typeof Bokeh !== "undefined", plots: [], roots: [], images: [],
             resources: performance.getEntriesByType("resource").map(e => e.name),
             sections: [...document.querySelectorAll("h2[id], section[id]")].map(e => e.id)};
for (const img of document.images) {
  out.images.push({alt: img.alt, ok: img.complete && img.naturalWidth > 0});
}
if (out.bokeh) {
  for (const view of Object.values(Bokeh.index)) {
    if (!["Column", "Row", "Figure"].includes(view.model.type)) continue;  // not a plot
    const box = view.el.getBoundingClientRect();
    out.roots.push({type: view.model.type, w: box.width, h: box.height});
  }
  for (const doc of Bokeh.documents) {
    for (const m of doc.all_models) {
      if (m.type !== "Figure") continue;
      const series = [];
      for (const r of m.renderers) {
        if (r.type !== "GlyphRenderer" || !r.glyph.y || !r.glyph.y.field) continue;
        const column = r.data_source.data[r.glyph.y.field] || [];
        let finite = 0;
        for (const v of column) if (Number.isFinite(v)) finite += 1;
        series.push({field: r.glyph.y.field, finite: finite});
      }
      const legend = [];
      for (const a of m.above) {
        if (a.type !== "Legend") continue;
        for (const item of a.items) legend.push(item.label ? item.label.value : "");
      }
      out.plots.push({title: m.title ? m.title.text : "", series: series, legend: legend});
    }
  }
}
return JSON.stringify(out);
"""

IDLE = ("return document.readyState === 'complete' && typeof Bokeh !== 'undefined' && "
        "Bokeh.documents.length === document.querySelectorAll('div.bk-lazy').length && "
        "Bokeh.documents.every(d => d.is_idle)")
"""Every plot section drawn (each is drawn when it nears the viewport) and idle."""


@pytest.fixture(scope="module")
def browser() -> Any:
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,900", "--hide-scrollbars"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    yield driver
    driver.quit()


def open_report(driver: Any, page: Path, shot: str) -> dict[str, Any]:
    """Load ``page``, wait for Bokeh to be idle, screenshot it, return what it shows; fail
    on console errors, network requests, plots without data and undecodable figures."""
    driver.set_window_size(1280, 900)
    driver.get(page.resolve().as_uri())
    deadline = time.monotonic() + 30
    while driver.execute_script("return document.readyState") != "complete":
        assert time.monotonic() < deadline, f"{page}: never finished loading"
        time.sleep(0.05)
    # a window as tall as the page: every section is in view, so every one is drawn
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(1280, min(int(height) + 40, 16000))
    while not driver.execute_script(IDLE):
        assert time.monotonic() < deadline, f"{page}: the plots were never all drawn"
        time.sleep(0.05)
    time.sleep(0.3)  # the last layout settles before the screenshot
    state = json.loads(driver.execute_script(PAGE_STATE))
    errors = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(ARTIFACTS / f"{shot}.png"))
    assert errors == [], f"{page}: JavaScript console errors {errors}"
    assert state["resources"] == [], f"{page}: fetched {state['resources']} (not offline)"
    assert state["roots"] and all(r["w"] > 300 and r["h"] > 100 for r in state["roots"]), \
        f"{page}: a plot area did not render: {state['roots']}"
    empty = [p["title"] for p in state["plots"]
             if not any(s["finite"] >= 1 for s in p["series"])]
    assert state["plots"] and empty == [], f"{page}: plots without data: {empty}"
    broken = [i["alt"] for i in state["images"] if not i["ok"]]
    assert broken == [], f"{page}: figures that do not decode: {broken}"
    return state


def invoke(*args: object) -> str:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def flights(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two simulated regime-change flights saved as tables (identify on one, predict on
    the other)."""
    from etsid.sim import simulate
    from etsid.table import save_table

    root = tmp_path_factory.mktemp("flights")
    out = {}
    for name, seed in (("a", 0), ("b", 1)):
        out[name] = root / f"ige_oge_{name}.parquet"
        save_table(simulate("ige-oge", duration=24.0, seed=seed, rate_hz=100.0).table,
                   out[name])
    return out


@pytest.fixture(scope="module")
def identify_run(flights: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("ident") / "RUN"
    invoke("identify", flights["a"], "--out", run, "--vehicle", "tarot680",
           "--structure", "scheduled")  # rules on 1/altitude: the regimes to show
    invoke("report", run)
    return run


def plot_titles(state: dict[str, Any]) -> list[str]:
    return [p["title"] for p in state["plots"]]


def test_identify_report_in_chromium(browser: Any, identify_run: Path) -> None:
    state = open_report(browser, identify_run / "report" / "index.html", "identify")
    assert state["sections"][:4] == ["overview", "validation", "metrics", "regimes"]
    assert {"online", "structure", "figures"} <= set(state["sections"])
    titles = plot_titles(state)
    assert titles[0].startswith("Altitude, shaded by the rule that leads")
    shaded = state["plots"][0]["legend"]
    assert "Rule 1 (in ground effect)" in shaded and len(shaded) >= 3  # ≥ 2 rules + altitude
    assert "Leading rule (numbered as in the tables)" in titles
    for y in ("p", "q", "r"):  # each rate with the free-run errors of eTS and ARX under it
        errors = next(p for p in state["plots"] if p["title"] == f"{y}: free-run error, "
                      "measured − prediction")
        assert [s["field"] for s in errors["series"]] == ["e_arx", "e_ets"]
    assert [i["alt"] for i in state["images"]] == [
        "rates", "structure", "consequents", "residuals", "validation"]


def test_predict_report_in_chromium(browser: Any, identify_run: Path,
                                    flights: dict[str, Path], tmp_path: Path) -> None:
    run = tmp_path / "PRED"
    invoke("predict", "--rules", identify_run / "rules.json", flights["b"], "--out", run)
    invoke("report", run)
    state = open_report(browser, run / "report" / "index.html", "predict")
    assert "overview" in state["sections"] and "validation" in state["sections"]
    leading = next(p for p in state["plots"] if p["title"].startswith("Leading rule"))
    assert leading["series"][0]["finite"] > 100


def test_gap_report_in_chromium(browser: Any, tmp_path: Path) -> None:
    out = tmp_path / "GAP"
    printed = invoke("gap", ROOT / "sample_logs" / "low_hover_1.parquet",
                     ROOT / "sample_logs" / "low_hover_2.parquet", "--out", out)
    assert printed.splitlines()[-1].startswith(f"wrote {out}/ (gap.json, index.html")
    state = open_report(browser, out / "index.html", "gap")
    assert state["sections"][:3] == ["effects", "before-after", "regime"]
    titles = plot_titles(state)
    assert "az: REAL against the models" in titles and "az: REAL − model" in titles
    assert any(t.startswith("az: held-out residual against height") for t in titles)
    assert [i["alt"] for i in state["images"]] == ["gap_residual", "gap_timeseries"]


def test_control_report_in_chromium(browser: Any, tmp_path: Path) -> None:
    invoke("control", "sine", "--duration", 12, "--controller", "pid", "--no-report",
           "--out", tmp_path / "control-sine-pid")
    invoke("control", "sine", "--duration", 12, "--out", tmp_path / "control-sine-ets")
    state = open_report(browser, tmp_path / "control-sine-ets" / "report" / "index.html",
                        "control")
    track = next(p for p in state["plots"] if p["title"] == "Reference and flown height (true)")
    # eTS height, PID height (the run beside it) and the reference, drawn last (on top)
    assert [s["field"] for s in track["series"]] == ["h", "h", "ref"]
    assert [i["alt"] for i in state["images"]] == [
        "tracking", "potential", "replacements", "thrust"]


def test_fleet_report_in_chromium(browser: Any, flights: dict[str, Path],
                                  tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    shutil.copy(flights["a"], logs / "ige_oge_a.parquet")
    (logs / "broken.tlog").write_bytes(b"\xfe\x00 not a telemetry log")
    invoke("batch", "identify", logs / "ige_oge_a.parquet", logs / "broken.tlog",
           "--out", tmp_path / "B", "--jobs", 1, "--quiet")
    invoke("report", tmp_path / "B")
    state = open_report(browser, tmp_path / "B" / "report" / "index.html", "fleet")
    assert state["sections"] == ["summary", "distributions", "best-worst", "failures", "logs"]
    (scatter,) = state["plots"]  # one dot per successful flight
    assert scatter["series"] == [{"field": "y", "finite": 1}]
    assert [i["alt"] for i in state["images"]] == ["distributions"]
