"""Report of a long flight: how big index.html is and how fast Chromium shows it.

Run:  python benchmarks/report.py [--duration 600] [--rate 250] [--repeat 3]

1. Simulates a ``--duration`` s ige-oge flight at ``--rate`` Hz (the regime-change flight),
   saves it as a table, runs ``etsid identify`` (defaults, --vehicle tarot680) and
   ``etsid report`` on it (CPU and wall time of the report).
2. Prints the size of index.html and how many points the interactive plots hold.
3. Opens the page ``--repeat`` times in headless Chromium (Debian's chromium and
   chromedriver, driven by selenium) and prints the time from navigation start to the Bokeh
   document being idle (every plot drawn), as measured by the page's own clock
   (``performance.now()``), first load and the rest.

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


def open_times(page: Path, repeat: int) -> list[float]:
    """Seconds from navigation start to Bokeh idle, per load."""
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
            driver.get("about:blank")
            driver.get(page.resolve().as_uri())
            while not driver.execute_script(
                    "return typeof Bokeh !== 'undefined' && Bokeh.documents.length > 0 && "
                    "Bokeh.documents.every(d => d.is_idle) && "
                    "(window.__idle = window.__idle || performance.now())"):
                time.sleep(0.01)
            times.append(driver.execute_script("return window.__idle") / 1000.0)
    finally:
        driver.quit()
    return times


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
        print("Chromium, navigation start to every plot drawn: "
              + ", ".join(f"{t:.2f} s" for t in times) + " (first load first)")


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
