"""Batch rows: validation means leave out outputs whose numbers describe noise and
diverged free runs (metrics.json flags them)."""

from __future__ import annotations

import pytest

from etsid.batch.tasks import metrics_fields


def _output(one_fit: float, free_fit: float, informative: bool = True,
            diverged: bool = False) -> dict:
    flags = {"informative": informative, "signal_std": 0.2 if informative else 0.01}
    return {"online": {"fit": 50.0},
            "validation": {"one_step": {"fit": one_fit, "ndei": 0.1, **flags},
                           "free_run": {"fit": free_fit, "diverged": diverged, **flags}}}


def test_means_skip_uninformative_outputs_and_diverged_free_runs() -> None:
    metrics = {"outputs": {"p": _output(90.0, 64.0), "q": _output(80.0, 20.0, diverged=True),
                           "r": _output(-10.0, -351.0, informative=False)}}
    row = metrics_fields(metrics, {})
    assert row["fit_one_step"] == pytest.approx(85.0)  # p and q; r describes noise
    assert row["fit_free_run"] == pytest.approx(64.0)  # q diverged, r not informative
    assert row["fit_online"] == pytest.approx(50.0)
    assert row["r_fit_one_step"] == pytest.approx(-10.0)  # per-output columns stay as is
    none_left = {"outputs": {"r": _output(-10.0, -351.0, informative=False)}}
    assert metrics_fields(none_left, {})["fit_free_run"] is None
