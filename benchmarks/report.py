"""Report of a long flight: how big index.html is and how fast Chromium shows it.

Run:  python benchmarks/report.py [--duration 600] [--rate 250] [--repeat 3]

1. Simulates a ``--duration`` s ige-oge flight at ``--rate`` Hz (the regime-change flight),
   saves it as a table, runs ``etsid identify`` (defaults, --vehicle tarot680) and
   ``etsid report`` on it (CPU and wall time of the report).
2. Prints the size of index.html and how many points the interactive plots hold.
3. Opens the page ``--repeat`` times in headless Chromium (Debian's chromium and
   chromedriver, driven by selenium) and prints the time from navigation start to the Bokeh
   document being idle (every plot drawn), as measured by the page's own clock
   (``performance.now()``), first load and the rest, and the CPU seconds all browser
   processes used meanwhile (from /proc: on a loaded machine the wall time grows, the CPU
   time does not).

The numbers go to docs/report.md.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

from click.testing import CliRunner

from etsid.cli import cli
from etsid.sim import simulate
from etsid.table import save_table


def run(*args: object) -> None:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    if result.exit_code != 0:
        raise SystemExit(result.output)


FIRST_SCREEN = """return document.readyState === 'complete' && typeof Bokeh !== 'undefined'
  && Bokeh.documents.length > 0
  && Bokeh.documents.length === document.querySelectorAll('div.bk-lazy[data-drawn]').length
  && Bokeh.documents.every(d => d.is_idle)
  && (window.__idle = window.__idle || performance.now())"""

WHOLE_PAGE = """return Bokeh.documents.length === document.querySelectorAll('div.bk-lazy').length
  && Bokeh.documents.every(d => d.is_idle)
  && (window.__all = window.__all || performance.now())"""


def open_times(page: Path, repeat: int) -> list[tuple[float, float, float, float]]:
    """Per load: (seconds from navigation start to the first screen's plots drawn, CPU
    seconds the browser spent until then, seconds until every section is drawn (the window
    made as tall as the page), CPU seconds until then). CPU: every browser process, from
    /proc; a busy machine inflates the wall times, not these."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = shutil.which("chromium") or "chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,900"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    times = []
    try:
        for _ in range(repeat):
            driver.set_window_size(1280, 900)
            driver.get("about:blank")
            before = _task_seconds(driver)
            driver.get(page.resolve().as_uri())
            while not driver.execute_script(FIRST_SCREEN):
                time.sleep(0.01)
            first, first_cpu = (driver.execute_script("return window.__idle") / 1000.0,
                                _task_seconds(driver) - before)
            height = driver.execute_script("return document.documentElement.scrollHeight")
            driver.set_window_size(1280, min(int(height) + 40, 16000))
            while not driver.execute_script(WHOLE_PAGE):
                time.sleep(0.01)
            times.append((first, first_cpu, driver.execute_script("return window.__all")
                          / 1000.0, _task_seconds(driver) - before))
    finally:
        driver.quit()
    return times


def _task_seconds(driver: object) -> float:
    """CPU seconds (user + system) used so far by every browser process under the driver
    (read from /proc; the renderer, GPU and browser processes together)."""
    import os

    root = driver.service.process.pid  # type: ignore[attr-defined]
    parents = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parents[int(pid)] = (int(fields[1]), int(fields[11]) + int(fields[12]))
    total = 0
    for pid, (_, ticks) in parents.items():
        up = pid
        while up in parents and up != root:
            up = parents[up][0]
        if up == root:
            total += ticks
    return total / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=600.0)
    parser.add_argument("--rate", type=float, default=250.0)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        table = Path(tmp) / "flight.parquet"
        t0 = time.perf_counter()
        save_table(simulate("ige-oge", duration=args.duration, seed=5,
                            rate_hz=args.rate).table, table)
        print(f"simulated {args.duration:g} s at {args.rate:g} Hz in "
              f"{time.perf_counter() - t0:.1f} s")
        run_dir = Path(tmp) / "RUN"
        t0 = time.perf_counter()
        run("identify", table, "--out", run_dir, "--vehicle", "tarot680")
        print(f"identify: {time.perf_counter() - t0:.1f} s wall")
        c0, t0 = time.process_time(), time.perf_counter()
        run("report", run_dir)
        print(f"report: {time.perf_counter() - t0:.1f} s wall, "
              f"{time.process_time() - c0:.1f} s CPU (this process)")
        page = run_dir / "report" / "index.html"
        text = page.read_text()
        pngs = sum(p.stat().st_size for p in page.parent.glob("*.png"))
        print(f"index.html: {page.stat().st_size / 1e6:.2f} MB "
              f"(of which BokehJS {len(_bokeh_js()) / 1e6:.2f} MB, the static figures "
              f"{pngs * 4 / 3 / 1e6:.2f} MB as base64)")
        print(f"plots: {text.count('ColumnDataSource')} data sources "
              f"(summary: {json.dumps(_points(text))})")
        times = open_times(page, args.repeat)
        print("Chromium (first load first), navigation start to the first screen's plots "
              "drawn: " + ", ".join(f"{t[0]:.2f} s wall / {t[1]:.2f} s CPU" for t in times))
        print("  … to every section drawn: "
              + ", ".join(f"{t[2]:.2f} s wall / {t[3]:.2f} s CPU" for t in times))


def _bokeh_js() -> str:
    from etsid.report.interactive import bokeh_js

    return bokeh_js()


def _points(text: str) -> dict[str, int]:
    """Rough count of the time-series points the page holds (from the embedded arrays)."""
    import re

    shapes = [int(m) for m in re.findall(r'"shape":\[(\d+)\]', text)]
    return {"arrays": len(shapes), "points": sum(shapes), "largest": max(shapes or [0])}


if __name__ == "__main__":
    main()
