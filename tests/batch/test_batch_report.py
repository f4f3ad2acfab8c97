"""``etsid report DIR`` on a batch directory: the fleet report."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from etsid.batch import BatchSpec, run_batch
from etsid.cli import cli
from etsid.ident import IdentConfig
from etsid.ingest import ReadOptions
from etsid.report.fleet import cause_of, failures_by_cause


def test_fleet_report_sections_links_and_failures(fleet: Path, tmp_path: Path) -> None:
    logs = [str(fleet / "a.tlog"), str(fleet / "broken.tlog")]
    spec = BatchSpec("identify", read_options=ReadOptions(), ident_config=IdentConfig())
    run_batch(logs, spec, tmp_path, jobs=1)
    result = CliRunner().invoke(cli, ["report", str(tmp_path)])
    assert result.exit_code == 0, result.output
    page = (tmp_path / "report" / "index.html").read_text()
    ids = re.findall(r'<section id="([a-z-]+)"', page)
    assert ids == ["summary", "distributions", "best-worst", "failures", "logs"]
    assert "over 2 logs: 1 ok, 1 failed" in page
    assert 'src="data:image/png;base64,' in page
    # the best and worst flights link to their own reports, which now exist
    links = re.findall(r'<a href="([^"]+)">', page)
    assert links and all(x.endswith("report/index.html") for x in links)
    for link in links:
        assert (tmp_path / "report" / link).resolve().is_file()
    failures = page.split('<section id="failures">')[1].split("</section>")[0]
    assert "not a MAVLink telemetry log" in failures and "IngestError" in failures
    markdown = (tmp_path / "report" / "report.md").read_text()
    assert re.findall(r"^## (.+)$", markdown, flags=re.M) == [
        "Summary", "Distributions", "Best and worst flights", "Failures by cause",
        "Every log"]


def test_failures_are_grouped_by_cause() -> None:
    frame = pd.DataFrame({
        "input": ["x/a.tlog", "x/b.tlog", "x/c.ulg", "x/d.bag"],
        "status": ["error", "error", "error", "ok"],
        "error": ["x/a.tlog: no valid MAVLink packets found (7 bytes scanned)",
                  "x/b.tlog: no valid MAVLink packets found (123 bytes scanned)",
                  "x/c.ulg: empty file", None],
        "error_kind": ["IngestError", "IngestError", "IngestError", None]})
    assert cause_of(frame["error"][0], "x/a.tlog") == \
        "no valid MAVLink packets found (N bytes scanned)"
    table = failures_by_cause(frame)
    assert table["count"].tolist() == [2, 1]
    assert table["examples"][0] == "x/a.tlog, x/b.tlog"
