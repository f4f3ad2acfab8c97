"""identify merges indistinguishable rules at the freeze and at the end: the merges are in
metrics.json ``rules.merges`` and in history.parquet (``merges``, ``events``, ``n_rules``)."""

from __future__ import annotations

from regime_flight import two_regime_table

from etsid.ident import IdentConfig, identify

BASE = dict(outputs=["y"], regressors="y[k-1],u[k-1]", segments="all", radius=0.3,
            antecedent="alt[k-1]", merge=True)  # generic models do not merge by default


def test_one_physics_at_two_heights_ends_with_one_rule_and_the_merges_in_history() -> None:
    run = identify(two_regime_table(1.5, 1.5), IdentConfig(**BASE))
    merges = run.metrics["rules"]["merges"]
    assert run.metrics["rules"]["peak"] >= 2 and merges
    assert run.metrics["rules"]["frozen"] == 1
    hist = run.history
    assert int(hist["merges"].sum()) == len(merges)
    assert hist["events"].str.contains("merge").sum() >= 1
    assert int(hist["n_rules"].iloc[-1]) == run.metrics["rules"]["final"]
    kept = identify(two_regime_table(2.0, 1.0), IdentConfig(**BASE))
    assert kept.metrics["rules"]["frozen"] >= 2  # different gains: not merged
    unmerged = identify(two_regime_table(1.5, 1.5), IdentConfig(**{**BASE, "merge": None}))
    assert unmerged.metrics["rules"]["frozen"] >= 2 and not unmerged.metrics["rules"]["merges"]


def test_merges_are_marked_in_the_structure_figure() -> None:
    from etsid.report.figures import fig_structure

    run = identify(two_regime_table(1.5, 1.5), IdentConfig(**BASE))
    fig = fig_structure(run)
    labels = [t.get_text() for ax in fig.axes if ax.get_legend()
              for t in ax.get_legend().get_texts()]
    n = len(run.metrics["rules"]["merges"])
    assert f"merge ({n})" in labels
