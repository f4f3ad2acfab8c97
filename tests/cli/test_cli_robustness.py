"""Bad input gives one clear line naming the file/option, a non-zero exit, no traceback.

Each case is a regression: before the fix it crashed (``internal error``), was silently
ignored, or printed nothing about what was repaired.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli

ROOT = Path(__file__).resolve().parents[2]
TLOG = ROOT / "sample_logs" / "hexa_ige_oge.tlog"
BIN = ROOT / "tests" / "data" / "arduplane_truncated.BIN"
VEHICLE = ROOT / "etsid" / "sim" / "vehicles" / "tarot680.toml"


def run(*args: object) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


def assert_error(args: list[object], *names: str, code: int = 1) -> str:
    exit_code, _, err = run(*args)
    assert exit_code == code, err
    assert "Traceback" not in err and "internal error" not in err, err
    line = err.strip().splitlines()[-1]
    if code == 1:
        assert len(err.strip().splitlines()) == 1, err
    for name in names:
        assert name in line, line
    return line


@pytest.fixture(scope="module")
def table(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small saved FlightTable (first 4 s of the sample tlog)."""
    path = tmp_path_factory.mktemp("tbl") / "flight.parquet"
    code, _, err = run("ingest", "-q", TLOG, "-o", path, "--end", "4")
    assert code == 0, err
    return path


# ---------------------------------------------------------------- ingest options


@pytest.mark.parametrize("opt", [["--start", "nan"], ["--end", "nan"], ["--start", "-5"]])
def test_ingest_bad_window(tmp_path: Path, opt: list[str]) -> None:
    assert_error(["ingest", "-q", TLOG, "-o", tmp_path / "o.parquet", *opt], TLOG.name, opt[0])


@pytest.mark.parametrize("rate", ["1e9", "nan", "inf", "-inf", "1e-6", "0", "fast"])
def test_ingest_absurd_rate_names_the_option(tmp_path: Path, rate: str) -> None:
    line = assert_error(["ingest", "-q", TLOG, "-o", tmp_path / "o.parquet", "--rate", rate],
                        "--rate", code=2)
    assert rate in line
    assert not (tmp_path / "o.parquet").exists()


def test_ident_rate_above_the_log_rate_is_refused(tmp_path: Path) -> None:
    gas = ROOT / "tests" / "data" / "gas_furnace.csv"
    assert_error(["identify", gas, "--output", "co2", "--regressors", "co2[k-1]",
                  "--ident-rate", "5000", "--out", tmp_path / "run"], "--ident-rate",
                 "gas_furnace.csv", code=2)
    assert_error(["identify", gas, "--output", "co2", "--regressors", "co2[k-1]",
                  "--ident-rate", "1e9", "--out", tmp_path / "run"], "--ident-rate", code=2)


def test_unwritable_out_is_refused_before_the_log_is_read(tmp_path: Path) -> None:
    # the log does not exist: had it been read first, the error would name it
    line = assert_error(["identify", tmp_path / "missing.tlog", "--out", "/proc/x"], "--out",
                        code=2)
    assert "missing.tlog" not in line


def test_ingest_says_it_overwrote(tmp_path: Path) -> None:
    out = tmp_path / "o.parquet"
    first = run("ingest", "-q", TLOG, "-o", out)
    assert first[0] == 0 and "overwrote the existing file" not in first[1]
    second = run("ingest", "-q", TLOG, "-o", out)
    assert second[0] == 0 and "overwrote the existing file" in second[1]


def test_bare_etsid_prints_help_to_stdout() -> None:
    code, out, err = run()
    assert code == 0 and err == ""
    assert "Usage:" in out and "ingest" in out and "identify" in out


def test_map_non_numeric_dataflash_field(tmp_path: Path) -> None:
    assert_error(["ingest", "-q", BIN, "-o", tmp_path / "o.parquet", "--map", "p=MSG.Message"],
                 BIN.name, "not numeric")


def test_mapping_file_section_not_a_table(tmp_path: Path) -> None:
    bad = tmp_path / "m.toml"
    bad.write_text("map = 3\n")
    assert_error(["inspect", TLOG, "--mapping", bad], "m.toml", "[map]")


# ---------------------------------------------------------------- saved tables


def test_inspect_and_ingest_accept_a_saved_table(table: Path, tmp_path: Path) -> None:
    code, out, err = run("inspect", table)
    assert code == 0, err
    assert "table" in out and "rows:" in out
    code, out, err = run("ingest", table, "-o", tmp_path / "cut.csv", "--start", "1", "--end", "2")
    assert code == 0, err
    back = pd.read_csv(tmp_path / "cut.csv")
    assert back["t"].iloc[0] == 0.0 and back["t"].iloc[-1] == pytest.approx(1.0)


@pytest.mark.parametrize("cmd", ["ingest", "identify"])
@pytest.mark.parametrize("opt", [["--rate", "5"], ["--map", "p=ATTITUDE.rollspeed"]])
def test_log_options_on_a_table_are_refused(table: Path, tmp_path: Path, cmd: str,
                                            opt: list[str]) -> None:
    assert_error([cmd, "-q", table, "-o", tmp_path / "out.parquet", *opt], table.name, opt[0])


def test_table_with_text_time_column(table: Path, tmp_path: Path) -> None:
    frame = pd.read_parquet(table)
    frame["t"] = frame["t"].astype(str) + "s"
    bad = tmp_path / "strt.csv"
    frame.to_csv(bad, index=False)
    assert_error(["identify", "-q", bad, "-o", tmp_path / "run"], "strt.csv", "'t'")


def test_table_without_rate_attrs_can_be_ingested(tmp_path: Path) -> None:
    src = tmp_path / "plain.csv"
    pd.DataFrame({"t": [0.0, 0.1, 0.2], "p": [0.0, 0.1, 0.2]}).to_csv(src, index=False)
    code, out, err = run("ingest", src, "-o", tmp_path / "o.parquet")
    assert code == 0, err
    assert "10.00 Hz" in out


def test_ingest_into_missing_directory(table: Path, tmp_path: Path) -> None:
    assert_error(["ingest", table, "-o", tmp_path / "nope" / "o.parquet"], "o.parquet",
                 "cannot write")


def test_ingest_empty_table(table: Path, tmp_path: Path) -> None:
    empty = tmp_path / "empty.parquet"
    pd.read_parquet(table).head(0).to_parquet(empty)
    assert_error(["ingest", empty, "-o", tmp_path / "o.csv"], "empty.parquet", "no rows")


def test_identify_names_the_table_on_missing_columns(tmp_path: Path) -> None:
    src = tmp_path / "data.csv"
    rng = np.random.default_rng(0)
    pd.DataFrame({"t": np.arange(50.0), "y": rng.normal(size=50)}).to_csv(src, index=False)
    assert_error(["identify", "-q", src, "-o", tmp_path / "r", "--output", "y",
                  "--regressors", "nope[k-1]"], "data.csv", "nope")


def test_identify_prints_ingest_warnings(tmp_path: Path) -> None:
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(TLOG.read_bytes()[:298830])
    # a 4 Hz telemetry log: the rate model is refused, a generic model runs
    code, _, err = run("identify", "-q", cut, "-o", tmp_path / "r", "--validate", "0",
                       "--output", "p", "--regressors", "p[k-1],u_roll[k-1]")
    assert code == 0, err
    assert "truncated" in err and "dropped:" in err


def test_identify_warns_about_missing_t(tmp_path: Path) -> None:
    src = tmp_path / "data.csv"
    rng = np.random.default_rng(0)
    pd.DataFrame({"y": rng.normal(size=60)}).to_csv(src, index=False)
    code, _, err = run("identify", "-q", src, "-o", tmp_path / "r", "--output", "y",
                       "--regressors", "y[k-1]")
    assert code == 0, err
    assert "no 't' column" in err


# ---------------------------------------------------------------- predict / report


@pytest.fixture(scope="module")
def run_dir(table: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run") / "run"
    code, _, err = run("identify", "-q", table, "-o", out, "--ident-rate", "25")
    assert code == 0, err
    return out


def test_predict_sim_from_nan(run_dir: Path, table: Path, tmp_path: Path) -> None:
    assert_error(["predict", "-q", "--rules", run_dir, table, "-o", tmp_path / "p",
                  "--sim-from", "nan"], "--sim-from", code=2)


def test_predict_rules_of_other_model_names_file(run_dir: Path, tmp_path: Path) -> None:
    src = tmp_path / "other.csv"
    pd.DataFrame({"t": np.arange(20.0), "co2": np.arange(20.0)}).to_csv(src, index=False)
    assert_error(["predict", "-q", "--rules", run_dir, src, "-o", tmp_path / "p"],
                 "other.csv", "missing")


def test_report_on_corrupt_metrics(run_dir: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad"
    shutil.copytree(run_dir, bad)
    (bad / "metrics.json").write_text(json.dumps({}))
    assert_error(["report", bad], "bad", "metrics.json")


def test_report_on_wrong_predictions(run_dir: Path, table: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad"
    shutil.copytree(run_dir, bad)
    shutil.copy(table, bad / "predictions.parquet")
    assert_error(["report", bad], "bad", "predictions.parquet")


# ---------------------------------------------------------------- simulate


def test_simulate_into_missing_directory(tmp_path: Path) -> None:
    out = tmp_path / "nope" / "s.tlog"
    assert_error(["simulate", "hover-ige", "--duration", "0.1", "-o", out], "s.tlog",
                 "does not exist")


def test_simulate_format_contradicts_extension(tmp_path: Path) -> None:
    assert_error(["simulate", "hover-ige", "--duration", "0.1", "-o", tmp_path / "s.bag",
                  "--format", "tlog"], "s.bag", "--format")


@pytest.mark.parametrize("opt", [["--duration", "1e9"], ["--rate", "1e7"]])
def test_simulate_huge_values(tmp_path: Path, opt: list[str]) -> None:
    assert_error(["simulate", "hover-ige", "-o", tmp_path / "s.tlog", *opt], opt[0], code=2)


def test_simulate_vehicle_binary_file(table: Path, tmp_path: Path) -> None:
    assert_error(["simulate", "hover-ige", "--duration", "0.1", "-o", tmp_path / "s.tlog",
                  "--vehicle", table], table.name, "TOML")


def test_simulate_vehicle_too_heavy(tmp_path: Path) -> None:
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(VEHICLE.read_text().replace("mass = 4.2 ", "mass = 400 ", 1))
    assert_error(["simulate", "hover-ige", "--duration", "0.1", "-o", tmp_path / "s.tlog",
                  "--vehicle", heavy], "cannot lift")  # in mass's range, beyond its rotors
    heavy.write_text(VEHICLE.read_text().replace("mass = 4.2 ", "mass = 1e9 ", 1))
    assert_error(["simulate", "hover-ige", "--duration", "0.1", "-o", tmp_path / "s.tlog",
                  "--vehicle", heavy], "field 'mass' must lie in [0.005, 500] kg")


def test_simulate_with_output_but_no_scenario_is_a_usage_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["simulate", "-o", str(tmp_path / "x.tlog")])
    assert result.exit_code == 2 and "SCENARIO" in result.output
    assert not (tmp_path / "x.tlog").exists()
