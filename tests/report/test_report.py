"""Report figures (matplotlib objects, not pixels), index.html and report.md.

The runs here are built by hand so the report is tested without the eTS core.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError, ReportError
from etsid.ident.metrics import scores
from etsid.ident.rundir import Run, read_run, write_run
from etsid.report import make_report
from etsid.report.figures import (
    autocorrelation,
    fig_consequents,
    fig_rates,
    fig_residuals,
    fig_structure,
    fig_validation,
    with_gaps,
    zoom_window,
)
from etsid.report.tables import metrics_rows, summary_table

OUTS = ("p", "q", "r")


def fake_run(n: int = 600, seed: int = 0) -> Run:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.004
    t[n // 2:] += 1.0  # a gap
    split = int(0.7 * n)
    pred: dict[str, object] = {"t": t, "part": np.where(np.arange(n) < split, "learn",
                                                       "validation")}
    outputs = {}
    for o, y in enumerate(OUTS):
        truth = np.sin(2 * np.pi * (o + 1) * t)
        meas = truth + rng.normal(scale=0.02, size=n)
        pred[y] = meas
        pred[f"{y}_hat"] = truth + rng.normal(scale=0.01, size=n)
        val = np.full(n, np.nan)
        val[split:] = truth[split:]
        pred[f"{y}_val"] = val
        pred[f"{y}_sim"] = val * 1.05
        pred[f"{y}_arx"] = truth
        pred[f"{y}_arx_val"] = val
        pred[f"{y}_arx_sim"] = val * 0.9
        one = scores(meas[split:], val[split:])
        outputs[y] = {"unit": "rad/s", "noise_std": 0.02,
                      "online": {**scores(meas, pred[f"{y}_hat"]), "rmse_over_noise": 1.1},
                      "validation": {"one_step": one, "free_run": one},
                      "arx": {"online": one, "validation": {"one_step": one, "free_run": one}}}
    steps = np.arange(1, n + 1)
    rules = np.minimum(1 + steps // 150, 4)
    births = np.r_[1, np.diff(rules)]
    history = pd.DataFrame({"step": steps, "t": t, "n_rules": rules,
                            "potential": rng.uniform(0.2, 1, n),
                            "focal_max": np.full(n, 0.9), "focal_min": np.full(n, 0.4),
                            "births": births, "replacements": np.zeros(n, int),
                            "removals": np.zeros(n, int), "events": [""] * n})
    history.loc[400, "removals"] = 1
    rows = []
    for step in range(100, n + 1, 100):
        for rid in range(rules[step - 1]):
            for term in ("1", "p[k-1]", "u_roll[k-1]"):
                for y in OUTS:
                    rows.append((step, t[step - 1], rid, y, term, 0.1 * rid + step / n))
    cons = pd.DataFrame(rows, columns=["step", "t", "rule_id", "output", "term", "value"])
    metrics = {"n_samples": n, "rules": {"final": 4, "peak": 4, "frozen": 4},
               "skipped": {"history": 4, "missing": 0},
               "validation": {"fraction": 0.3, "n_learn": split, "n_validation": n - split,
                              "t_start": float(t[split])},
               "outputs": outputs}
    config = {"command": "identify", "input": {"path": "/logs/flight.ulg"},
              "model": {"outputs": list(OUTS), "regressors": "p[k-1],u_roll[k-1]",
                        "notes": ["inputs: loop commands (u_roll)"]}}
    return Run(pd.DataFrame(pred), metrics, config, history, cons, {"schema": "x"})


def _labels(fig: object) -> list[tuple[str, str]]:
    return [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes]  # type: ignore[attr-defined]


def test_rates_figure_has_full_and_zoom_panels_per_output() -> None:
    fig = fig_rates(fake_run())
    assert len(fig.axes) == 6
    assert fig.axes[0].get_ylabel() == "roll rate p (rad/s)"
    assert fig.axes[5].get_xlabel() == "time t (s)"
    assert all(len(ax.get_lines()) == 2 for ax in fig.axes)
    zoom = fig.axes[1].get_xlim()
    assert zoom[1] - zoom[0] < 0.2 * (fig.axes[0].get_xlim()[1] - fig.axes[0].get_xlim()[0])
    # one legend above the panels (outside the data), measured first: drawn under
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["measured", "eTS one-step"]
    assert all(ax.get_legend() is None for ax in fig.axes)
    measured, hat = fig.axes[0].get_lines()
    assert measured.get_zorder() < hat.get_zorder()


def test_structure_figure_marks_events() -> None:
    fig = fig_structure(fake_run())
    ax_p, ax_r = fig.axes
    assert ax_p.get_ylabel() == "potential (–)" and ax_r.get_ylabel() == "number of rules"
    assert [ax.get_title("left")[:3] for ax in fig.axes] == ["(a)", "(b)"]
    assert len(ax_p.get_lines()) == 3
    assert 0.15 < ax_p.get_ylim()[0] < 0.25  # around the data (0.2 … 1), not 0 … 1
    labels = [t.get_text() for t in ax_r.get_legend().get_texts()]
    assert labels == ["rules", "birth (4)", "removal (1)"]


def run_with_rules() -> Run:
    """:func:`fake_run` with a real two-rule eTS rule base learnt on y = ±gain·u (the gain
    switching with x), for the consequents figure."""
    from etsid.ets import ETS

    rng = np.random.default_rng(4)
    x = np.r_[rng.normal(-2, 0.1, 300), rng.normal(2, 0.1, 300)]
    u = rng.normal(size=600)
    y = np.where(x < 0, 3.0, -1.0) * u + 0.01 * rng.normal(size=600)
    model = ETS(radius=0.3, input_names=["x", "u"], output_names=["y"])
    model.run(np.c_[x, u], y[:, None])
    run = fake_run()
    run.rules = model.to_dict()
    run.metrics["outputs"] = {"y": run.metrics["outputs"]["p"]}
    run.config["model"]["outputs"] = ["y"]
    return run


def test_consequent_figure_shows_every_rule_numbered_as_the_tables() -> None:
    run = run_with_rules()
    fig = fig_consequents(run)
    (ax,) = fig.axes
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == [f"Rule {i + 1}" for i in range(len(run.rules["rules"]))] and len(labels) >= 2
    # the input's coefficient dominates and changes sign between the two regimes
    assert ax.get_xticklabels()[0].get_text() == "u"
    heights = [bars.patches[0].get_height() for bars in ax.containers]
    assert min(heights) < -50 and max(heights) > 50
    with pytest.raises(ValueError, match="rule base not readable"):
        fig_consequents(fake_run())


def test_residual_figure_band_and_histogram() -> None:
    fig = fig_residuals(fake_run(), max_lag=20)
    assert len(fig.axes) == 6
    ax_h, ax_a = fig.axes[:2]
    assert ax_h.get_xlabel() == "residual p − ŷ (rad/s)"
    assert ax_a.get_xlabel() == "lag (samples)"
    assert len(ax_a.get_lines()) == 1 and len(ax_a.patches) == 1  # points + 95 % band
    assert "95 % band" in ax_a.get_legend().get_texts()[1].get_text()


def test_validation_figure_measured_under_and_error_panels() -> None:
    """Measured thin and under (it used to hide the free runs); each model its own dash;
    legends outside the plot areas."""
    fig = fig_validation(fake_run())
    assert len(fig.axes) == 6  # per output: the series and their free-run errors
    series, errors = fig.axes[0], fig.axes[1]
    lines = series.get_lines()
    assert lines[0].get_label() == "measured"
    assert lines[0].get_zorder() < min(ln.get_zorder() for ln in lines[1:])
    assert lines[0].get_linewidth() < min(ln.get_linewidth() for ln in lines[1:] if
                                          ln.get_linestyle() == "-")
    assert len({ln.get_linestyle() for ln in lines[1:]}) == 3
    assert series.get_legend() is None and fig.legends
    legend = errors.get_legend()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)  # right of the data, not on it
    assert legend.get_window_extent(renderer).x0 >= errors.get_window_extent(renderer).x1
    labels = [t.get_text() for t in legend.get_texts()]
    # fake_run: ARX free run = 0.9 × truth, eTS = 1.05 × truth: ARX's error is twice eTS's
    rmse = {lab.split()[0]: float(lab.split()[-1]) for lab in labels}
    assert rmse["ARX"] > 1.5 * rmse["eTS"]
    assert series.get_title("left").startswith("free-run fit eTS")


def test_helpers() -> None:
    t, y = with_gaps(np.array([0.0, 1, 2, 10, 11]), np.arange(5.0))
    assert np.isnan(t[3]) and np.isnan(y[3]) and t.size == 6
    ac = autocorrelation(np.random.default_rng(1).normal(size=4000), 5)
    assert ac[0] == 1.0 and np.abs(ac[1:]).max() < 0.05
    ac = autocorrelation(np.sin(np.arange(400) * 0.1), 3)
    assert ac[1] > 0.9
    x = np.zeros(1000)
    x[500:540] = 1.0
    a, b = zoom_window(np.arange(1000.0), x, fraction=0.06)
    assert a <= 500 and b >= 539


def test_tables() -> None:
    head, rows = metrics_rows(fake_run())
    assert head[0] == "output" and len(rows) == 3 and rows[0][2] == "0.02"
    assert ("rules: 4 in rules.json (saved at the end of the learning part); while "
            "learning: at most 4, 4 at the end of the flight") in summary_table(fake_run())


def test_make_report_writes_self_contained_html(tmp_path: Path) -> None:
    run_dir = write_run(fake_run(), tmp_path / "run")
    assert read_run(run_dir).metrics["n_samples"] == 600
    report = make_report(run_dir)
    for name in ("rates", "structure", "residuals", "validation"):
        assert (run_dir / "report" / f"{name}.png").stat().st_size > 10_000
    # the fake rule base cannot be read: its figure says so instead of failing the report
    assert (run_dir / "report" / "consequents.png").stat().st_size > 1000
    html = report.html.read_text()
    assert html.count("data:image/png;base64,") == 5
    # offline: no tag loads anything (BokehJS is inlined; the browser tests check that no
    # request leaves the page)
    assert not re.search(r"<(script|img|link)[^>]+(src|href)=\"(?!data:)", html)
    assert "Bokeh" in html and ('<h2 id="validation">' in html) and '<h2 id="online">' in html
    assert '<h2 id="overview">' not in html  # the run's input log does not exist
    assert "No flight overview: /logs/flight.ulg (the run&#x27;s input) is not there" in html
    assert "Held-out free-run fit, eTS vs ARX" in html
    assert "<table>" in html and "Rule base not readable" in html
    md = report.markdown.read_text()
    assert "![" in md and "| p | rad/s | 0.02 |" in md


def test_svg_report_and_bad_inputs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.report.build as build

    monkeypatch.setattr(build, "FIGURES", {"rates": build.FIGURES["rates"]})
    run_dir = write_run(fake_run(200), tmp_path / "run")
    report = make_report(run_dir, "svg")
    assert report.figures["rates"].suffix == ".svg"
    assert "data:image/svg+xml;base64," in report.html.read_text()
    with pytest.raises(ReportError, match="unknown figure format"):
        make_report(run_dir, "gif")
    with pytest.raises(ReportError, match="not a run directory") as caught:
        make_report(tmp_path / "nope")
    assert isinstance(caught.value.__cause__, IdentError)  # read_run's error, chained
    (run_dir / "metrics.json").unlink()
    with pytest.raises(ReportError, match="missing metrics.json"):
        make_report(run_dir)
