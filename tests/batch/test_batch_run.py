"""``etsid batch``: one row per log, errors as rows, the same results whatever the job count,
resume, and the gap command before gap analysis exists."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from etsid.batch import SCHEMA, VOLATILE, BatchSpec, read_results, run_batch
from etsid.cli import cli
from etsid.ident import IdentConfig, identify
from etsid.ident.inputs import load_for_ident
from etsid.ingest import ReadOptions


def identify_spec(**config: object) -> BatchSpec:
    return BatchSpec("identify", read_options=ReadOptions(),
                     ident_config=IdentConfig(**config))  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def serial(fleet_logs: list[str], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An identify batch of the fleet, run in this process (--jobs 1)."""
    out = tmp_path_factory.mktemp("serial")
    summary = run_batch(fleet_logs, identify_spec(), out, jobs=1)
    assert (summary.total, summary.ok, summary.failed) == (5, 4, 1)
    return out


def test_one_row_per_log_with_the_schema(serial: Path, fleet_logs: list[str]) -> None:
    files = sorted((serial / "results" / "command=identify").glob("*.parquet"))
    assert len(files) == len(fleet_logs)
    for path in files:
        assert pq.read_schema(path).remove_metadata().equals(SCHEMA.remove_metadata())
    frame = read_results(serial)
    assert sorted(frame["input"]) == sorted(fleet_logs)
    assert set(frame["command"]) == {"identify"}
    ok = frame[frame["status"] == "ok"].set_index("input")
    assert sorted(ok["format"]) == ["mcap", "ros1", "ros2", "tlog"]
    assert (ok["duration_s"] > 7.5).all() and (ok["duration_s"] < 8.5).all()
    assert ok["input_sha256"].str.fullmatch("[0-9a-f]{64}").all()
    assert (ok["peak_rss_mb"] > 10).all() and (ok["wall_s"] > 0).all()
    assert (ok["airborne_s"] > 0).all()  # from identify's metrics.json flight block
    # the simulator's tlog HEARTBEAT says hexarotor (MAV_TYPE 13) and ArduPilot; the bags
    # and the MCAP have no topic that names the aircraft
    facts = ok.set_index("format")[["vehicle", "autopilot"]]
    assert facts.loc["tlog"].tolist() == ["hexarotor", "ArduPilot"]
    assert facts.drop(index="tlog").isna().all().all()


def test_rows_hold_what_identify_itself_gives(serial: Path, fleet: Path) -> None:
    frame = read_results(serial).set_index("input")
    log = fleet / "a.tlog"
    run = identify(load_for_ident(log), IdentConfig(), source=log)
    row = frame.loc[str(log)]
    assert json.loads(row["metrics_json"]) == json.loads(json.dumps(run.metrics))
    assert row["rules_frozen"] == run.metrics["rules"]["frozen"]
    fit = run.metrics["outputs"]["q"]["validation"]["one_step"]["fit"]
    assert row["q_fit_one_step"] == fit
    assert row["airborne_s"] == run.metrics["flight"]["airborne_s"] > 0
    assert (serial / row["run_dir"] / "rules.json").read_text() == \
        json.dumps(run.rules, indent=1) + "\n"


def test_a_broken_log_is_an_error_row(serial: Path, fleet: Path) -> None:
    frame = read_results(serial).set_index("input")
    row = frame.loc[str(fleet / "broken.tlog")]
    assert row["status"] == "error"
    assert row["error_kind"] == "IngestError"
    assert "broken.tlog" in row["error"] and "\n" not in row["error"]
    assert len(row["input_sha256"]) == 64
    assert frame.loc[frame["status"] == "ok", "error"].isna().all()


def test_two_jobs_give_the_same_rows_bit_for_bit(serial: Path, fleet_logs: list[str],
                                                 tmp_path: Path) -> None:
    run_batch(fleet_logs, identify_spec(), tmp_path, jobs=2)
    one = read_results(serial).drop(columns=list(VOLATILE))
    two = read_results(tmp_path).drop(columns=list(VOLATILE))
    assert len(one) == 5
    assert one.equals(two)


def test_workers_are_renewed_without_losing_a_log(serial: Path, fleet_logs: list[str],
                                                 tmp_path: Path, monkeypatch) -> None:
    """A worker that grew past the bound gets the pool renewed: every log still gets its
    row, the same as in one process (Python 3.11's ``max_tasks_per_child`` hung here; the
    pool is renewed whole)."""
    from etsid.batch import local

    pools = []

    class CountedPool(local.ProcessPoolExecutor):
        def __init__(self, *args, **kwargs) -> None:
            pools.append(self)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(local, "ProcessPoolExecutor", CountedPool)
    monkeypatch.setattr(local, "RENEW_GROWTH_MB", -1.0)  # every worker "grew": renew
    summary = run_batch(fleet_logs, identify_spec(), tmp_path, jobs=2)
    assert summary.ok + summary.failed == len(fleet_logs)
    assert len(pools) >= 2  # 5 logs, a window of 4: at least one renewal
    one = read_results(serial).drop(columns=list(VOLATILE))
    again = read_results(tmp_path).drop(columns=list(VOLATILE))
    assert one.equals(again)


def test_a_pool_is_not_renewed_while_memory_stays_flat(fleet_logs: list[str],
                                                      tmp_path: Path, monkeypatch) -> None:
    from etsid.batch import local

    pools = []

    class CountedPool(local.ProcessPoolExecutor):
        def __init__(self, *args, **kwargs) -> None:
            pools.append(self)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(local, "ProcessPoolExecutor", CountedPool)
    summary = run_batch(fleet_logs, identify_spec(), tmp_path, jobs=2)
    assert summary.ok + summary.failed == len(fleet_logs)
    assert len(pools) == 1


def test_resume_skips_finished_logs_retries_failed_and_reruns_on_new_options(
        fleet_logs: list[str], tmp_path: Path) -> None:
    logs = fleet_logs[:2]  # a.tlog (ok) and broken.tlog (an error row)
    spec = identify_spec()
    run_batch(logs, spec, tmp_path, jobs=1)
    rows = sorted((tmp_path / "results" / "command=identify").glob("*.parquet"))
    stamps = {p: p.stat().st_mtime_ns for p in rows}
    status = read_results(tmp_path).set_index("input")["status"]
    assert status.to_dict() == {logs[0]: "ok", logs[1]: "error"}
    # the failed log runs again (its row replaced, still one); the ok one is skipped
    again = run_batch(logs, spec, tmp_path, jobs=1, resume=True)
    assert (again.skipped, again.ok, again.failed) == (1, 0, 1)
    after = sorted((tmp_path / "results" / "command=identify").glob("*.parquet"))
    assert after == rows and len(read_results(tmp_path)) == 2
    ok_row = next(p for p in rows if read_results(tmp_path).set_index("input").loc[
        logs[0], "input_sha256"][:32] in p.name)
    assert ok_row.stat().st_mtime_ns == stamps[ok_row]
    assert any(p.stat().st_mtime_ns != stamps[p] for p in rows if p != ok_row)
    # --skip-failed: neither runs
    skip = run_batch(logs, spec, tmp_path, jobs=1, resume=True, retry_failed=False)
    assert (skip.skipped, skip.ok, skip.failed) == (2, 0, 0)
    # a third log is new; the first two stay skipped
    more = run_batch(fleet_logs[:3], spec, tmp_path, jobs=1, resume=True,
                     retry_failed=False)
    assert (more.skipped, more.ok + more.failed) == (2, 1)
    # other options: every log runs again, into rows of their own
    changed = run_batch(logs, identify_spec(radius=1.5), tmp_path, jobs=1, resume=True)
    assert changed.skipped == 0 and changed.ok + changed.failed == 2
    frame = read_results(tmp_path)
    assert frame["options_digest"].nunique() == 2 and len(frame) == 5


def test_cli_batch_inspect_and_gap(fleet: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["batch", "inspect", str(fleet), "-o", str(tmp_path / "b"),
                                 "-j", "1"])
    assert result.exit_code == 0, result.output
    assert "5 logs: 4 ok, 1 failed" in result.output
    frame = read_results(tmp_path / "b")
    assert (frame.loc[frame["status"] == "ok", "channels"] > 3).all()
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(f"{fleet / 'a.tlog'},{fleet / 'd.mcap'}\n")
    result = runner.invoke(cli, ["batch", "gap", str(pairs), "-o", str(tmp_path / "g"),
                                 "-j", "1"])
    assert result.exit_code == 0, result.output
    row = read_results(tmp_path / "g").iloc[0]
    # 8 s flights: too little airborne data for a verdict, said as such (not an error)
    assert row["status"] == "ok" and row["gap_verdict"] == "insufficient"
    assert json.loads(row["gap_json"])["schema"] == "etsid.gap/1"
    assert (tmp_path / "g" / row["run_dir"] / "gap.json").is_file()


DATA = Path(__file__).parents[1] / "data"


def test_rows_name_the_aircraft_where_the_log_does(tmp_path: Path) -> None:
    logs = [str(DATA / n) for n in ("ardupilot_sitl_quadplane.tlog", "px4_sitl_tagged.ulg",
                                    "arduplane_truncated.BIN")]
    run_batch(logs, BatchSpec("inspect", read_options=ReadOptions()), tmp_path, jobs=1)
    rows = read_results(tmp_path).set_index("input")
    facts = ["vehicle", "autopilot", "firmware", "hardware"]
    got = {Path(k).name: [None if v is None or v != v else v for v in r]
           for k, r in rows[facts].iterrows()}
    assert got == {
        "ardupilot_sitl_quadplane.tlog": ["fixed wing", "ArduPilot",
                                          "ArduPlane V3.10.0-dev (f2b4e06a)", None],
        "px4_sitl_tagged.ulg": ["quadrotor", "PX4", "v1.13.0-dev (cea3da71)", "PX4_SITL"],
        "arduplane_truncated.BIN": ["fixed wing", "ArduPilot",
                                    "ArduPlane V3.8.2-dev (8178ab40)", "PX4v4"],
    }


def test_regimes_come_from_the_runs_rules_json(fleet: Path, tmp_path: Path) -> None:
    log = str(fleet / "a.tlog")
    run_batch([log], identify_spec(antecedent="alt[k-1]"), tmp_path, jobs=1)
    row = read_results(tmp_path).iloc[0]
    assert row["status"] == "ok", row["error"]
    rules = json.loads((tmp_path / row["run_dir"] / "rules.json").read_text())
    assert rules["antecedents"]["scheduled"] and rules["antecedents"]["names"] == ["alt[k-1]"]
    assert row["regime_count"] == len(rules["rules"]) == row["rules_frozen"]
    parts = row["regimes"].split("; ")
    assert len(parts) == len(rules["rules"])
    for part, rule in zip(parts, rules["rules"], strict=True):
        name, value = part.removesuffix(" m").split("=")
        assert name == "alt"
        assert float(value) == pytest.approx(rule["focal_point"][0], rel=5e-3, abs=1e-9)


def test_an_unscheduled_rule_base_has_a_count_and_no_regimes(fleet: Path,
                                                             tmp_path: Path) -> None:
    run_batch([str(fleet / "a.tlog")], identify_spec(antecedent="none"), tmp_path, jobs=1)
    ok = read_results(tmp_path).query("status == 'ok'")
    assert len(ok) == 1
    assert (ok["regime_count"] == ok["rules_frozen"]).all()
    assert ok["regimes"].isna().all()


def test_rows_of_scheduled_runs_name_their_regimes(fleet: Path, tmp_path: Path) -> None:
    """A run scheduled on 1/altitude says where in its row. (identify's structure choice
    gives the fleet's 8 s single-height flights one rule: the scheduled structure is forced.)"""
    run_batch([str(fleet / "a.tlog")], identify_spec(structure="scheduled"), tmp_path, jobs=1)
    serial = tmp_path
    ok = read_results(serial).query("status == 'ok'")
    n_scheduled = 0
    for _, row in ok.iterrows():
        rules = json.loads((serial / row["run_dir"] / "rules.json").read_text())
        scheduled = bool((rules.get("antecedents") or {}).get("scheduled"))
        n_scheduled += scheduled
        assert (row["regimes"] is not None and row["regimes"] == row["regimes"]) == scheduled
        if scheduled:
            assert row["regimes"].startswith("inv_alt=")
        assert row["regime_count"] == len(rules["rules"])
    assert n_scheduled >= 1
