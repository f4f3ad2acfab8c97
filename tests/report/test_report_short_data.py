"""``etsid report`` on runs with tiny validation parts: complete, atomic, no raw warnings."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import ReportError
from etsid.report import build

GAS = Path(__file__).resolve().parents[1] / "data" / "gas_furnace.csv"


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("short") / "run"
    result = CliRunner().invoke(cli, ["identify", str(GAS), "--output", "co2", "--regressors",
                                      "co2[k-1],input_gas_rate[k-4]", "--validate", "0.04",
                                      "--out", str(run), "--quiet"])
    assert result.exit_code == 0, result.output
    return run


def test_report_on_a_tiny_validation_part_is_complete(short_run: Path) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = CliRunner().invoke(cli, ["report", str(short_run)])
    assert result.exit_code == 0, result.output
    assert "Warning" not in result.stderr and not caught, [str(w.message) for w in caught]
    report = short_run / "report"
    assert (report / "index.html").stat().st_size > 1000
    assert (report / "report.md").is_file()
    assert {p.stem for p in report.glob("*.png")} == set(build.FIGURES)
    assert not [p for p in short_run.iterdir() if p.name.startswith(".report")]


def test_a_failing_report_leaves_the_old_one_untouched(short_run: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    assert CliRunner().invoke(cli, ["report", str(short_run)]).exit_code == 0
    before = {p.name: p.read_bytes() for p in (short_run / "report").iterdir()}

    def broken(*args: object) -> str:
        raise ReportError("disk full (simulated)")

    monkeypatch.setattr(build, "render_markdown", broken)
    result = CliRunner().invoke(cli, ["report", str(short_run)])
    assert result.exit_code == 1 and "disk full" in result.stderr
    after = {p.name: p.read_bytes() for p in (short_run / "report").iterdir()}
    assert after == before
    assert not [p for p in short_run.iterdir() if p.name.startswith(".report")]
