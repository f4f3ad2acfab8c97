"""Seeded fuzzing: mutated logs and hostile rule bases end in a table or one clean error.

Each log mutant (tests/fuzz/mutants.py) is read by ``etsid ingest`` in a worker process
with an address-space limit and a time bound; the verdict must be "read ok" (a table whose
values are physically plausible) or "clean error" (one ``etsid: error:`` line naming the
file). ``python benchmarks/fuzz.py --mutants 3000`` runs thousands; a seed it flags goes
into :data:`SEEDS` to stay fixed.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import mutants
import pytest
from click.testing import CliRunner

from etsid.cli import cli

SEEDS: list[tuple[str, int]] = [
    *[(fmt, seed) for fmt in mutants.SOURCES for seed in (1, 2)],
    # regressions found by benchmarks/fuzz.py before issue 9
    ("mcap", 1002),  # zstd "Data corruption detected" in the fast decoder
    ("ros1", 1015),  # LZ4 ERROR_decompressionFailed in the fast decoder
    ("ros1", 1113),  # non-UTF-8 header field name in the index-less scan
    ("ros2-mcap", 1046),  # a corrupt 64-bit length → MemoryError in rosbags
    ("ros2-mcap", 1137),  # a corrupt offset → OverflowError in rosbags
    ("ros2-db3", 1129),  # zeroed page: "database disk image is malformed"
    ("ros2-db3", 3418),  # flipped bytes: a NULL timestamp in a row → TypeError
    ("ros2-db3", 3544),  # flipped bytes: a blob timestamp in a row → TypeError
    ("ros2-mcap", 2187),  # metadata.yaml: a string where a number belongs → TypeError
    ("ros2-db3", 1850),  # apsw.CorruptError while rosbags iterates
    ("ros2-mcap", 1648),  # quaternion overflow: a raw numpy RuntimeWarning
    ("bin", 1755),  # DataFlash reader left its file open (ResourceWarning)
    ("ulog", 2923),  # pyulog left a damaged file open (ResourceWarning)
    ("mcap", 1121),  # kept records of a zstd chunk failing its CRC: garbled times, overflow
    ("mcap", 3025),  # garbled values in kept records: "invalid value encountered in cast"
    ("ros2-db3", 5108),  # a cut db3 whose topics row holds NULLs: internal AttributeError
]
"""(format, seed) pairs read on every test run."""

TIME_BOUND_S = 60.0
MEMORY_GB = 4.0


@pytest.fixture(scope="module")
def verdicts(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, int], tuple]:
    root = tmp_path_factory.mktemp("fuzz")
    pool = mutants.Pool(2, MEMORY_GB)
    try:
        results = list(pool.run(SEEDS, str(root), TIME_BOUND_S))
    finally:
        pool.close()
    return {(r[0], r[1]): r for r in results}


@pytest.mark.parametrize(("source", "seed"), SEEDS)
def test_log_mutant_reads_or_fails_cleanly(verdicts: dict, source: str, seed: int) -> None:
    _, _, what, kind, detail, seconds, _ = verdicts[source, seed]
    assert kind in ("read ok", "clean error"), f"{source} seed {seed} ({what}): {detail}"
    assert seconds < TIME_BOUND_S


def test_damaged_ulog_leaves_no_file_open(tmp_path: Path) -> None:
    """Seed 2923 (a duplicated 1 KiB stretch) made pyulog give up with its file still open;
    every warning is an error here, and the garbage collector runs inside the check."""
    import gc
    import warnings

    from etsid.errors import IngestError
    from etsid.ingest import read_raw

    mutant = mutants.make_mutant("ulog", 2923, tmp_path)
    gc.collect()  # what earlier tests left behind is not this read's doing
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("error")
        warnings.simplefilter("always", ResourceWarning)  # raised in __del__: record it
        try:
            read_raw(mutant.path)
        except IngestError as err:
            assert mutant.path.name in str(err)
        gc.collect()
    ours = [str(w.message) for w in caught
            if not isinstance(w.message, ResourceWarning) or mutant.path.name in str(w.message)]
    assert not ours, ours


def test_mutants_are_reproducible(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    one = mutants.make_mutant("mcap", 7, tmp_path / "a")
    two = mutants.make_mutant("mcap", 7, tmp_path / "b")
    assert one.what == two.what
    assert one.path.read_bytes() == two.path.read_bytes()
    assert one.path.read_bytes() != mutants.SOURCES["mcap"].read_bytes()


def test_truncated_ros2_bags_keep_their_valid_part(tmp_path: Path) -> None:
    for source in ("ros2-db3", "ros2-mcap"):
        bag = tmp_path / source
        shutil.copytree(mutants.SOURCES[source], bag)
        storage = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
        data = storage.read_bytes()
        storage.write_bytes(data[: int(len(data) * 0.8)])
        out = tmp_path / f"{source}.parquet"
        verdict = mutants.run_cli(["ingest", str(bag), "-o", str(out)], out, bag.name)
        assert verdict.kind == "read ok", verdict.detail
        result = CliRunner().invoke(cli, ["inspect", str(bag)])
        assert "storage file damaged" in result.output
        assert "metadata.yaml unusable" not in result.output


# ---------------------------------------------------------------------------
# rule bases from strangers


@pytest.fixture(scope="module")
def rules_variants(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[str, Path]]:
    root = tmp_path_factory.mktemp("rules")
    run = root / "run"
    data = Path(__file__).resolve().parents[1] / "data" / "gas_furnace.csv"
    result = CliRunner().invoke(cli, ["identify", str(data), "--output", "co2", "--regressors",
                                      "co2[k-1],input_gas_rate[k-4]", "--out", str(run),
                                      "--quiet"])
    assert result.exit_code == 0, result.output
    pristine = json.loads((run / "rules.json").read_text())
    return mutants.rules_variants(pristine, root)


def test_rule_base_variants_fail_cleanly(rules_variants: list[tuple[str, Path]],
                                         tmp_path: Path) -> None:
    data = Path(__file__).resolve().parents[1] / "data" / "gas_furnace.csv"
    accepted = []
    for what, path in rules_variants:
        for args in (["rules", str(path)],
                     ["predict", str(data), "--rules", str(path), "-o", str(tmp_path / "p")]):
            verdict = mutants.run_cli(args, names=path.name)
            assert verdict.kind in ("read ok", "clean error"), f"{what}: {verdict.detail}"
            assert verdict.seconds < 20, what
            if verdict.kind == "read ok":
                accepted.append(what)
    # a variant that is still a valid rule base may be read; the hostile ones may not
    hostile = {"deep nesting", "deep object nesting", "huge integer", "sample_rate_hz a string",
               "negative sample_rate_hz", "absurd sample_rate_hz", "zero sample_rate_hz",
               "max_rules 1e9", "max_rules beyond 64 bits", "empty rule list", "NaN potential",
               "focal point at 1e308", "infinite focal point"}
    assert not hostile & set(accepted)
