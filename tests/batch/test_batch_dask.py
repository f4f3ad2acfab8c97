"""The Dask path: the same batch on a LocalCluster of two worker processes, with inputs given
as fsspec URLs, gives the rows of the local pool."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from etsid.batch import VOLATILE, BatchSpec, read_results, run_batch
from etsid.ingest import ReadOptions

pytest.importorskip("dask.distributed")


def test_local_cluster_of_two_workers_matches_the_local_run(fleet_logs: list[str],
                                                             tmp_path: Path) -> None:
    spec = BatchSpec("ingest", read_options=ReadOptions(), rate_hz=100.0)
    local = run_batch(fleet_logs, spec, tmp_path / "local", jobs=1)
    urls = [Path(p).resolve().as_uri() for p in fleet_logs]
    dask = run_batch(urls, spec, tmp_path / "dask", jobs=2, scheduler="processes")
    assert (local.ok, local.failed) == (dask.ok, dask.failed) == (4, 1)
    a = read_results(tmp_path / "local").sort_values("input_sha256", ignore_index=True)
    b = read_results(tmp_path / "dask").sort_values("input_sha256", ignore_index=True)
    # the URL rows name the URL wherever the local rows name the path
    path_of = dict(zip(urls, fleet_logs, strict=True))
    b["error"] = [e if not isinstance(e, str) else e.replace(u, path_of[u])
                  for e, u in zip(b["error"], b["input"], strict=True)]
    b["input"] = b["input"].map(path_of)
    drop = [*VOLATILE, "run_dir"]
    assert a.drop(columns=drop).equals(b.drop(columns=drop))
    assert b["rate_hz"].dropna().eq(100.0).all()
    assert str(os.getpid()) not in {w.split(":")[1] for w in b["worker"]}
    tables = sorted((tmp_path / "dask" / "runs").rglob("table.parquet"))
    assert len(tables) == 4
