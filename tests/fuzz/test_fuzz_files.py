"""Hostile files beside the logs (tests/fuzz/files.py): the cheap cases, each in a child
process bounded like the structure cases, give one clean error line or a result whose
files pass their check. ``python benchmarks/fuzz.py --files`` runs every case."""

from __future__ import annotations

from pathlib import Path

import files
import pytest
import structure

CHEAP = [c.name for c in files.CASES if c.cheap]


@pytest.mark.parametrize("name", CHEAP)
def test_hostile_file_is_bounded_and_answered(name: str, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(files, "CACHE", tmp_path.parent / "etsid-files-cache")
    case = files.case(name)
    verdict = structure.run_case(case, tmp_path / name)
    assert verdict.ok, (f"{name} ({case.what}): {verdict.detail} after {verdict.seconds:.1f} s, "
                        f"{verdict.peak_mb:.0f} MB\n" + "\n".join(verdict.lines[-5:]))


def test_the_report_check_fails_a_template_holding_the_files_string(tmp_path: Path) -> None:
    # the check is not "it ran": a unit inside a tooltip template, raw in the page, fails
    page = tmp_path / "run" / "report"
    page.mkdir(parents=True)
    (page / "report.md").write_text("ok\n")
    (page / "index.html").write_text(
        '<script>{"tooltips":[["co2","@{y}{0.0} ' + files.SCRIPT + '"]]}</script>')
    assert "tooltip template" in files._report_clean(tmp_path / "run")
    (page / "index.html").write_text(f"<p>{files.RLO}</p>")
    assert "raw" in files._report_clean(tmp_path / "run")
