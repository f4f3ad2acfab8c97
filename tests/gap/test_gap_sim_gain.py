"""Only the gain beyond SIM's own counts: a law that also improves SIM's held-out fit against
SIM's nominal model corrects that model's structure (a term its regression lacks), not a
difference between the vehicles (:func:`etsid.gap.criterion.sim_gains`)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from etsid.gap.criterion import Evaluated, net_gain
from etsid.gap.run import analyse

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def _model(gain_per_sample: float, sim_per_sample: float | None) -> Evaluated:
    return Evaluated("rotor_drag", (), [], np.full(10, 10.0 * gain_per_sample), 100,
                     sim_per_sample=sim_per_sample)


def test_the_gain_per_sample_is_reals_beyond_sims_own() -> None:
    assert _model(0.03, None).per_sample == pytest.approx(0.03)
    assert _model(0.03, 0.01).per_sample == pytest.approx(0.02)
    assert net_gain(_model(0.03, 0.01)) == pytest.approx(2.0)
    # a law that makes SIM's own held-out fit worse does not add to REAL's gain
    assert _model(0.03, -0.02).per_sample == pytest.approx(0.03)
    row = {"name": "rotor_drag", "per_sample": 0.02, "n_scored": 100}
    assert net_gain(row) == pytest.approx(2.0)


@pytest.mark.slow
def test_a_law_sims_own_log_also_needs_is_not_named() -> None:
    """A Tarot 680 against itself (no effect; development seed, not a benchmark pair): the
    nominal model has no moment on the body velocity, so rotor drag's moment improves both
    logs' held-out fits; REAL's gain alone is past the naming threshold, the part beyond
    SIM's is not."""
    from gap_concealed import make_pair

    sim, real, truth = make_pair("none", 32000)
    assert truth["vehicle"] == "tarot680" and truth["effects"] == []
    data = analyse(sim, real, "SIM", "REAL").data
    drag = next(m for m in data["criterion"]["models"] if m["name"] == "rotor_drag")
    own = drag["sim_per_sample"]
    assert own > 0.25 * (drag["per_sample"] + own), drag
    assert drag["per_sample"] + own > data["criterion"]["thresholds"]["gain_per_sample"]
    assert data["verdict"] == "consistent", data["summary"]


@pytest.mark.slow
def test_a_real_difference_gains_nothing_on_sims_own_log() -> None:
    """The same kind of pair with rotor drag added to REAL: the law's gain on SIM's own log
    is a small share of its gain on REAL, and it is named."""
    from gap_concealed import EFFECTS, make_pair

    sim, real, truth = make_pair("rotor_drag", 32000 + EFFECTS.index("rotor_drag"))
    assert truth["effects"] == ["rotor_drag"]
    data = analyse(sim, real, "SIM", "REAL").data
    drag = next(m for m in data["criterion"]["models"] if m["name"] == "rotor_drag")
    assert drag["sim_per_sample"] < 0.05 * drag["per_sample"], drag
    assert [e["name"] for e in data["effects"]] == ["rotor_drag"], data["summary"]
