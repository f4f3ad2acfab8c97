"""Every plotted series of a static (PNG) figure can be seen: none is drawn over by another.

Each figure is drawn with Agg; for every line of at least :data:`MIN_POINTS` points (a
series, not a reference line), points are sampled along its drawn path, or at its markers
when it has no line (display pixels, inside its panel), and the rendered pixel there is
compared with the line's colour laid over the panel's background at any opacity from 20 %
to full (alpha and overlapping translucent markers included). A series whose colour shows
at under :data:`MIN_VISIBLE` of its samples is hidden: another series covers it. The
identify figures come from hand-built runs (as in test_report.py), the control figures from
a real 12 s ``etsid control`` pair, the gap figures from the README's gap example on the
bundled sample tables.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from test_figure_legends import IDENTIFY_FIGURES
from test_report import fake_run, run_with_rules

from etsid.cli import cli
from etsid.report.control import CONTROL_FIGURES, find_comparison, read_control_run

ROOT = Path(__file__).resolve().parents[2]
MIN_VISIBLE = 0.03
"""Share of a line's samples that must show its colour: a line drawn over everywhere shows
none (anti-aliased edges aside, well under 1 %); a thin dashed line on top of a trace shows
about a third."""
COLOUR_TOLERANCE = 0.12
"""Largest RGB distance (0–1 per channel) from the line's colour over the background."""
MIN_POINTS = 10
"""Lines with fewer points (zero lines, spans, proxies of a legend) are not series."""


def _path_pixels(line: Line2D, step: float = 1.5) -> np.ndarray:
    """Display points (px) every ``step`` px along a line's drawn polyline (its markers
    when it is drawn without a line)."""
    xy = np.column_stack([np.asarray(line.get_xdata(), float),
                          np.asarray(line.get_ydata(), float)])
    xy = line.get_transform().transform(xy)
    if line.get_linestyle() in ("None", "none", ""):
        return xy[np.all(np.isfinite(xy), axis=1)]
    out = []
    for a, b in itertools.pairwise(xy):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            continue
        n = max(1, int(np.hypot(*(b - a)) / step))
        out.append(a + np.linspace(0.0, 1.0, n, endpoint=False)[:, None] * (b - a))
    return np.vstack(out) if out else np.empty((0, 2))


def _distance_to_blends(pixels: np.ndarray, colour: np.ndarray,
                        background: np.ndarray) -> np.ndarray:
    """RGB distance of each pixel to the nearest ``w·colour + (1 − w)·background``,
    20 % ≤ w ≤ 1 (the line at any opacity over the background)."""
    span = colour - background
    norm2 = float(span @ span)
    if norm2 < 1e-9:
        return np.linalg.norm(pixels - colour, axis=1)
    w = np.clip((pixels - background) @ span / norm2, 0.2, 1.0)
    return np.linalg.norm(pixels - (background + w[:, None] * span), axis=1)


def visible_share(fig: Figure, ax: Axes, line: Line2D, image: np.ndarray) -> float:
    """Share of ``line``'s samples inside ``ax`` where the rendered pixel has its colour."""
    height, width = image.shape[:2]
    panel = ax.get_window_extent()
    pts = _path_pixels(line)
    inside = ((pts[:, 0] > panel.x0 + 1) & (pts[:, 0] < panel.x1 - 1)
              & (pts[:, 1] > panel.y0 + 1) & (pts[:, 1] < panel.y1 - 1))
    pts = pts[inside]
    if len(pts) == 0:
        return 1.0  # nothing drawn inside the panel: nothing to hide
    cols = np.clip(np.round(pts[:, 0]).astype(int), 0, width - 1)
    rows = np.clip(height - 1 - np.round(pts[:, 1]).astype(int), 0, height - 1)
    pixels = image[rows, cols, :3]
    background = np.asarray(to_rgb(ax.get_facecolor()))
    colour = np.asarray(to_rgb(line.get_color() if line.get_linestyle() not in
                               ("None", "none", "") else line.get_markerfacecolor()))
    distance = _distance_to_blends(pixels, colour, background)
    return float(np.mean(distance < COLOUR_TOLERANCE * np.sqrt(3)))


def hidden_lines(fig: Figure) -> list[str]:
    """One entry per series that another covers (see the module's text)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba(), float) / 255.0
    found = []
    for ax in fig.axes:
        for line in ax.lines:
            if not line.get_visible() or len(np.asarray(line.get_xdata())) < MIN_POINTS:
                continue
            share = visible_share(fig, ax, line, image)
            if share < MIN_VISIBLE:
                where = ax.get_title() or ax.get_ylabel()
                found.append(f"{line.get_label()!r} ({line.get_color()}) in {where!r}: "
                             f"its colour shows at {100 * share:.1f} % of its path")
    return found


def test_the_check_finds_a_line_drawn_over() -> None:
    """The check can fail: a series under a thicker copy of itself is found, and markers
    under others at the same places; drawn dashed and thinner on top, the series is seen."""
    fig = Figure(figsize=(4, 3), dpi=100)
    ax = fig.subplots()
    t = np.linspace(0, 10, 500)
    ax.plot(t, np.sin(t), color="tab:orange", lw=1.0, label="model")
    ax.plot(t, np.sin(t), color="black", lw=2.5, label="measured")
    assert [h.split(" (")[0] for h in hidden_lines(fig)] == ["'model'"]
    ax.lines[0].remove()
    ax.plot(t, np.sin(t), color="tab:orange", lw=1.0, ls="--", label="model")
    assert hidden_lines(fig) == []
    ax.plot(t, np.cos(t), ".", ms=2, alpha=0.35, color="tab:red", label="before")
    ax.plot(t, np.cos(t), ".", ms=3, alpha=0.9, color="tab:blue", label="after")
    assert [h.split(" (")[0] for h in hidden_lines(fig)] == ["'before'"]


@pytest.mark.parametrize("name", list(IDENTIFY_FIGURES))
def test_identify_figures_hide_no_series(name: str) -> None:
    fig = IDENTIFY_FIGURES[name](run_with_rules() if name == "consequents" else fake_run())
    assert hidden_lines(fig) == []


@pytest.fixture(scope="module")
def control_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("control")
    for controller in ("pid", "ets"):
        result = CliRunner().invoke(cli, ["control", "sine-altitude", "--duration", "12",
                                          "--controller", controller, "--no-report", "--out",
                                          str(root / f"control-sine-altitude-{controller}")])
        assert result.exit_code == 0, result.output
    return root / "control-sine-altitude-ets"


@pytest.mark.parametrize("name", list(CONTROL_FIGURES))
def test_control_figures_hide_no_series(name: str, control_run: Path) -> None:
    run = read_control_run(control_run)
    builder: Callable[..., Figure] = CONTROL_FIGURES[name][0]
    fig = builder(run, find_comparison(run)) if name == "tracking" else builder(run)
    assert hidden_lines(fig) == []


def test_gap_figures_hide_no_series_and_no_legend_covers_data(tmp_path: Path) -> None:
    """The README's gap example: its two PNG figures, each labelled line seen, no legend
    over data (the check of test_figure_legends)."""
    from test_figure_legends import covered_points

    from etsid.report.gap import gap_figures

    out = tmp_path / "gap"
    result = CliRunner().invoke(cli, ["gap", str(ROOT / "sample_logs" / "low_hover_1.parquet"),
                                      str(ROOT / "sample_logs" / "low_hover_2.parquet"),
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    figures = gap_figures(out)
    assert set(figures) == {"gap_residual", "gap_timeseries"}
    for name, fig in figures.items():
        assert sum(len(line.get_xdata()) >= MIN_POINTS
                   for ax in fig.axes for line in ax.lines) >= 2, name
        assert hidden_lines(fig) == [], name
        assert covered_points(fig) == [], name
