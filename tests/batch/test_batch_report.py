"""``etsid report DIR`` on a batch directory: the fleet report."""

from __future__ import annotations

import html
import os
import re
import shutil
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


def test_ranked_flights_reports_are_written_at_once_linked_and_reused(
        fleet_logs: list[str], tmp_path: Path) -> None:
    """Every ranked flight links to its own report (written by the report pool when there
    are several), naming that flight; a second report reuses them; a flight whose report
    cannot be written is named with the reason, not dropped."""
    spec = BatchSpec("identify", read_options=ReadOptions(), ident_config=IdentConfig())
    run_batch(fleet_logs, spec, tmp_path, jobs=1)
    assert CliRunner().invoke(cli, ["report", str(tmp_path)]).exit_code == 0
    page = (tmp_path / "report" / "index.html").read_text()
    ranked = page.split('<section id="best-worst">')[1].split("</section>")[0]
    links = dict((html.unescape(name), href) for href, name in
                 re.findall(r'<a href="([^"]+)">([^<]+)</a>', ranked))
    ok = [log for log in fleet_logs if "broken" not in log]
    assert sorted(links) == sorted(ok)  # the four flights, one list (at most ten)
    reports = {}
    for log, href in links.items():
        target = (tmp_path / "report" / href).resolve()
        assert target.is_file() and target.is_relative_to((tmp_path / "runs").resolve())
        title = re.search(r"<title>([^<]+)</title>", target.read_text()).group(1)
        assert Path(log).name in html.unescape(title)
        reports[log] = target
    written = {log: target.stat().st_mtime_ns for log, target in reports.items()}
    # one run made unreadable: its flight is named with the reason; the others reused
    broken_log = sorted(reports)[0]
    run_dir = reports[broken_log].parents[1]
    shutil.rmtree(run_dir / "report")
    (run_dir / "metrics.json").write_text("{ not json")
    assert CliRunner().invoke(cli, ["report", str(tmp_path)]).exit_code == 0
    page = (tmp_path / "report" / "index.html").read_text()
    ranked = page.split('<section id="best-worst">')[1].split("</section>")[0]
    assert f"No report of {html.escape(broken_log)}: " in ranked
    why = ranked.split(f"No report of {html.escape(broken_log)}: ")[1].split("</p>")[0]
    assert why.startswith(str(run_dir)) and "metrics.json: not valid JSON" in why
    assert not (run_dir / "report").exists()
    for log, target in reports.items():
        if log != broken_log:
            assert target.stat().st_mtime_ns == written[log]
            assert os.path.relpath(target, tmp_path / "report") in ranked


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
