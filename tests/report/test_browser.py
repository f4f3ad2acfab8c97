"""Every kind of report opened in a real browser (headless Chromium driven by chromedriver).

Each page is loaded from disk with the network unused, Bokeh is waited for until its
document is idle, and the test fails on a JavaScript console error, a request for any
resource (the page must work offline), a plot without data, a static figure that does not
decode, or a section that is missing. Each page is scrolled from top to bottom in a
1280 × 900 window as a user would, every view waited for (sections are drawn as they come
near) and screenshot; then every plotted series is checked to be visible (drawn, told apart
from the others of its plot, not lying under an opaque line drawn on top). The views and a
full-page screenshot of each land in ``test-artifacts/browser/`` (gitignored; CI keeps
them as artefacts).

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
from hostile import load_page

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


IN_VIEW_DRAWN = """
const h = window.innerHeight;
const lazy = [...document.querySelectorAll("div.bk-lazy")].filter(d => {
  const r = d.getBoundingClientRect(); return r.bottom > 0 && r.top < h; });
if (!lazy.every(d => d.dataset.drawn)) return false;
if (!lazy.length) return true;
const views = Object.values(Bokeh.index);
return lazy.every(d => views.some(v => d.contains(v.el))) &&
       Bokeh.documents.every(doc => doc.is_idle);
"""
"""Every plot section in the viewport drawn (sections are drawn as they near it) and idle."""

VISIBILITY = """
const val = p => (p !== null && typeof p === "object" && "value" in p) ? p.value : p;
const col = (src, spec) => (spec && spec.field !== undefined) ?
  Array.from(src.data[spec.field] || [], Number) : null;
const problems = [];
for (const doc of Bokeh.documents) {
  for (const m of doc.all_models) {
    if (m.type !== "Figure") continue;
    const title = m.title ? m.title.text : "";
    const pxPerUnit = (m.inner_height || m.height) /
                      Math.max(Math.abs(m.y_range.end - m.y_range.start), 1e-300);
    const drawn = [];
    for (const r of m.renderers) {
      if (r.type !== "GlyphRenderer") continue;
      const g = r.glyph;
      const ys = col(r.data_source, g.y), xs = col(r.data_source, g.x);
      if (!ys) continue;
      const line = g.type === "Line";
      const dash = JSON.stringify(val(g.line_dash) ?? "solid");
      const style = {kind: g.type, dash: dash === '"solid"' || dash === "[]" ? "solid" : dash,
                     color: String(line ? val(g.line_color) : val(g.fill_color)),
                     width: Number(line ? val(g.line_width) : val(g.size)) || 0,
                     alpha: Number(line ? val(g.line_alpha) : val(g.fill_alpha)) ?? 1};
      const name = `${g.y.field} (${style.color}, ${style.dash})`;
      if (!r.visible || style.alpha < 0.05 || style.width <= 0 || g.type === undefined)
        problems.push(`${title}: ${name} is not drawn visibly`);
      drawn.push({name, xs, ys, style, line});
    }
    for (let i = 0; i < drawn.length; i++) {
      for (let j = i + 1; j < drawn.length; j++) {
        const a = drawn[i], b = drawn[j];  // b drawn after a: on top of it
        if (a.style.kind === b.style.kind && a.style.color === b.style.color &&
            a.style.dash === b.style.dash)
          problems.push(`${title}: ${a.name} and ${b.name} look the same`);
        if (!(a.line && b.line) || b.style.dash !== "solid" || b.style.alpha < 0.9) continue;
        // share of a's points inside b's stroke (both half widths, in data units)
        const reach = 0.5 * (a.style.width + b.style.width) / pxPerUnit;
        let inside = 0, finite = 0;
        const same = a.xs.length === b.xs.length && a.xs.every((x, k) => x === b.xs[k]);
        for (let k = 0; k < a.ys.length; k++) {
          if (!Number.isFinite(a.ys[k])) continue;
          let yb = NaN;
          if (same) yb = b.ys[k];
          else {
            let lo = 0, hi = b.xs.length - 1;
            while (hi - lo > 1) { const mid = (lo + hi) >> 1;
                                  if (b.xs[mid] <= a.xs[k]) lo = mid; else hi = mid; }
            if (b.xs[lo] <= a.xs[k] && a.xs[k] <= b.xs[hi]) yb = b.ys[lo];
          }
          finite += 1;
          if (Number.isFinite(yb) && Math.abs(a.ys[k] - yb) <= reach) inside += 1;
        }
        if (finite && inside / finite >= 0.5)
          problems.push(`${title}: ${a.name} is ${Math.round(100 * inside / finite)} % ` +
                        `under ${b.name}`);
      }
    }
  }
}
return JSON.stringify(problems);
"""
"""Problems with the plotted series: one not drawn visibly (hidden, transparent, zero
width), two in one plot that look the same (colour, dash and glyph), or one whose points
lie mostly (≥ 50 %) inside the stroke of an opaque solid line drawn on top of it."""

STEP_PX = 700
"""Scroll step of the simulated user, px (the window is 900 px tall: views overlap)."""


def scroll_through(driver: Any, page: Path, shot: str, deadline: float) -> int:
    """Scroll from the top to the bottom as a user would, waiting at each position for the
    sections in view to be drawn, and screenshot each view; returns the number of views."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    for old in ARTIFACTS.glob(f"{shot}-view*.png"):
        old.unlink()
    driver.execute_script("window.scrollTo(0, 0)")
    position, view = 0, 0
    while True:
        while not driver.execute_script(IN_VIEW_DRAWN):
            assert time.monotonic() < deadline, \
                f"{page}: the plots in view at {position} px were never drawn"
            time.sleep(0.05)
        time.sleep(0.2)  # the layout settles before the screenshot
        driver.save_screenshot(str(ARTIFACTS / f"{shot}-view{view:02d}.png"))
        height = driver.execute_script("return document.documentElement.scrollHeight")
        inner = driver.execute_script("return window.innerHeight")
        if position + inner >= height or view >= 40:
            return view + 1
        position += STEP_PX
        driver.execute_script(f"window.scrollTo(0, {position})")
        view += 1


def open_report(driver: Any, page: Path, shot: str) -> dict[str, Any]:
    """Load ``page`` in a 1280 × 900 window, scroll through it as a user would (each view
    drawn and screenshot), screenshot the whole page, return what it shows; fail on console
    errors, network requests, plots without data, series that cannot be seen and
    undecodable figures."""
    deadline = load_page(driver, page)
    views = scroll_through(driver, page, shot, deadline)
    assert views >= 1
    # every section was drawn by scrolling (none needs a tall window to appear)
    assert driver.execute_script(IDLE), f"{page}: scrolling did not draw every section"
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(1280, min(int(height) + 40, 16000))
    time.sleep(0.3)  # the last layout settles before the screenshot
    state = json.loads(driver.execute_script(PAGE_STATE))
    hidden = json.loads(driver.execute_script(VISIBILITY))
    errors = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    driver.save_screenshot(str(ARTIFACTS / f"{shot}.png"))
    assert hidden == [], f"{page}: plotted series that cannot be seen: {hidden}"
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
        assert [s["field"] for s in errors["series"]] == ["e_ets", "e_arx"]
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
    # the candidates tried: entries of one effect told apart by their fitted parameters
    ranked = json.loads((out / "gap.json").read_text())["candidates"]
    shown = [(c["name"], json.dumps(c["params"], sort_keys=True)) for c in ranked]
    assert all(c["params"] for c in ranked) and len(set(shown)) == len(shown)
    page = (out / "index.html").read_text()
    assert all(f"motor {c['params']['motor']}, scale" in page for c in ranked
               if c["name"] == "weak_motor")


def test_control_report_in_chromium(browser: Any, tmp_path: Path) -> None:
    invoke("control", "sine-altitude", "--duration", 12, "--controller", "pid",
           "--no-report", "--out", tmp_path / "control-sine-altitude-pid")
    invoke("control", "sine-altitude", "--duration", 12, "--out",
           tmp_path / "control-sine-altitude-ets")
    state = open_report(browser, tmp_path / "control-sine-altitude-ets" / "report" /
                        "index.html", "control")
    track = next(p for p in state["plots"] if p["title"] == "Reference and flown height (true)")
    # the reference first (wide, pale, under), the eTS height, the PID height on top
    assert [s["field"] for s in track["series"]] == ["ref", "h", "h"]
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
