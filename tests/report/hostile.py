"""What the hostile-input page tests share: the payloads, the command runner, the checks of a
terminal, a report.md and a page's DOM in headless Chromium after hovering every plot.

Used by tests/report/test_hostile_pages.py (a table, its sidecar, a run's metrics.json) and
tests/report/test_hostile_files.py (logs, vehicle files, rule bases, gap.json).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from etsid.cli import cli

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
REQUIRED = os.environ.get("ETSID_REQUIRE_BROWSER") == "1"

PWN = "window.__pwned=1"
PAYLOAD = (f'<img src=x onerror="{PWN}"><svg onload="{PWN}"></svg><script>{PWN}</script>'
           f'<a href="javascript:{PWN}">x</a>')
FIELD_PAYLOAD = "<svg onload=__pwned=1>"
"""Markup without a dot or a slash (a dot splits TOPIC.FIELD, a slash a file name)."""
ESCAPES = "\x1b]52;c;QUFBQQ==\x07\x1b[2J\x9b31m"
"""OSC 52 (write the clipboard), CSI clear screen, the 8-bit CSI."""
RLO = "\u202e"
RAW = ("\x1b", "\x07", "\x9b", RLO)
SHOWN = "\\x1b]52"
"""How the OSC 52 sequence looks once escaped (its presence proves the string arrived)."""

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
found.pre = [...document.querySelectorAll("pre")].map(e => e.textContent);
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


def require_browser() -> None:
    """Skip the calling test module without Chromium and chromedriver (fail instead when
    ``ETSID_REQUIRE_BROWSER=1``)."""
    if not (CHROMIUM and DRIVER):
        if REQUIRED:
            raise RuntimeError("ETSID_REQUIRE_BROWSER=1 but chromium/chromedriver are missing")
        pytest.skip("needs chromium and chromedriver (apt-get install chromium "
                    "chromium-driver)", allow_module_level=True)
    pytest.importorskip("selenium.webdriver", reason="selenium (the test extra)")


def chromium() -> Iterator[Any]:
    """A headless Chromium driven by chromedriver, quit after use (a fixture's body)."""
    from selenium import webdriver
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


def load_page(driver: Any, page: Path, timeout_s: float = 60.0) -> float:
    """Open ``page`` in a 1280 × 900 window and wait until the document has loaded; the
    monotonic deadline (``timeout_s`` from now) is returned for the caller's own waits."""
    driver.set_window_size(1280, 900)
    driver.get(page.resolve().as_uri())
    deadline = time.monotonic() + timeout_s
    while driver.execute_script("return document.readyState") != "complete":
        assert time.monotonic() < deadline, f"{page}: never finished loading"
        time.sleep(0.05)
    return deadline


def hover_everything(driver: Any, page: Path) -> dict[str, Any]:
    """Load ``page``, draw every plot, move the mouse across each one (hover boxes open),
    and return what the DOM holds: handlers that ran, live markup, hover-box text, the
    title, headings, visible text and every ``<pre>`` block's text."""
    deadline = load_page(driver, page)
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


def assert_page_safe(state: dict[str, Any], page: str) -> None:
    """No handler ran, no live markup, no raw bidi or escape character on the page."""
    assert state["pwned"] == 0, f"{page}: a handler from a file ran"
    assert state["bad"] == [], f"{page}: live markup from a file in the DOM: {state['bad']}"
    shown = state["title"] + state["h1"] + state["text"] + "".join(state["pre"])
    assert raw_in(shown) == [], f"{page}: {raw_in(shown)} shown raw"


def invoke(*args: object) -> tuple[int, str]:
    """``etsid ARGS`` in this process: exit code and everything printed (stdout + stderr)."""
    result = CliRunner().invoke(cli, [str(a) for a in args])
    return result.exit_code, result.output


def run(*args: object) -> str:
    """``etsid ARGS``, which must succeed; what it printed."""
    code, output = invoke(*args)
    assert code == 0, output
    return output


def raw_in(text: str) -> list[str]:
    """The raw escape and bidi characters of :data:`RAW` found in ``text``."""
    return [repr(c) for c in RAW if c in text]


def live_markup(markdown: str) -> list[str]:
    """Tags outside code in ``markdown`` (a Markdown viewer renders them as HTML)."""
    text = re.sub(r"```.*?```", "", markdown, flags=re.S)
    text = re.sub(r"`[^`]*`", "", text)
    return re.findall(r"<(?:img|svg|script|a)\b[^>]*>", text)
