"""No legend of a static (PNG) figure covers plotted data.

Each figure is drawn with Agg; every legend's window extent (display pixels) is compared with
every data point of every line and point collection of every panel, in display coordinates,
counting only points inside their panel (points outside it are clipped, not drawn). A legend
over a panel's empty corner passes; one over a single drawn point fails. The identify figures
come from a hand-built run (as in test_report.py), the control figures from a real 12 s
``etsid control`` flight.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import Collection
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.transforms import Bbox
from test_report import fake_run, run_with_rules

from etsid.cli import cli
from etsid.report.control import CONTROL_FIGURES, find_comparison, read_control_run
from etsid.report.figures import (
    fig_consequents,
    fig_rates,
    fig_residuals,
    fig_structure,
    fig_validation,
)


def _points(artist: Line2D | Collection, ax: Axes) -> np.ndarray:
    """Display coordinates (px) of an artist's data points, NaN rows dropped."""
    if isinstance(artist, Line2D):
        xy = np.column_stack([np.asarray(artist.get_xdata(), float),
                              np.asarray(artist.get_ydata(), float)])
        transform = artist.get_transform()
    else:
        xy = np.asarray(artist.get_offsets(), float).reshape(-1, 2)
        transform = artist.get_offset_transform()
        if len(xy) <= 1:  # fills and spans: their vertices, not one offset
            paths = artist.get_paths()
            if not paths:
                return np.empty((0, 2))
            xy = np.vstack([p.vertices for p in paths])
            transform = artist.get_transform()
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    return transform.transform(xy) if len(xy) else np.empty((0, 2))


def covered_points(fig: Figure) -> list[str]:
    """One entry per (legend, artist) pair where the legend covers drawn data points."""
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    legends: list[Legend] = [*fig.legends,
                             *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
    found = []
    for legend in legends:
        box: Bbox = legend.get_window_extent(renderer)
        for ax in fig.axes:
            panel = ax.get_window_extent(renderer)
            for artist in [*ax.lines, *ax.collections]:
                if not artist.get_visible():
                    continue
                xy = _points(artist, ax)
                inside_panel = ((xy[:, 0] >= panel.x0) & (xy[:, 0] <= panel.x1)
                                & (xy[:, 1] >= panel.y0) & (xy[:, 1] <= panel.y1))
                under = inside_panel & ((xy[:, 0] >= box.x0) & (xy[:, 0] <= box.x1)
                                        & (xy[:, 1] >= box.y0) & (xy[:, 1] <= box.y1))
                if under.any():
                    found.append(f"legend {[t.get_text() for t in legend.get_texts()][:3]} "
                                 f"covers {int(under.sum())} points of "
                                 f"{artist.get_label()!r} in {ax.get_title()!r}")
            for container in ax.containers:  # bars: any overlap of a drawn bar counts
                for bar in container:
                    if not isinstance(bar, Rectangle):
                        continue
                    drawn = Bbox.intersection(bar.get_window_extent(renderer), panel)
                    if drawn is not None and drawn.overlaps(box):
                        found.append(f"legend covers a bar of {container.get_label()!r}")
    return found


def test_the_check_finds_a_legend_over_data() -> None:
    """The check can fail: a legend placed inside a panel full of data is found."""
    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    x = np.linspace(0, 1, 400)
    ax.plot(x, np.full_like(x, 0.95), label="near the top")
    ax.plot(x, x, label="diagonal")
    ax.set_ylim(0, 1)
    ax.legend(loc="upper right")
    assert covered_points(fig)
    ax.get_legend().remove()
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    assert covered_points(fig) == []


IDENTIFY_FIGURES: dict[str, Callable[..., Figure]] = {
    "rates": fig_rates, "structure": fig_structure, "consequents": fig_consequents,
    "residuals": fig_residuals, "validation": fig_validation}


@pytest.mark.parametrize("name", list(IDENTIFY_FIGURES))
def test_identify_figure_legends_cover_no_data(name: str) -> None:
    fig = IDENTIFY_FIGURES[name](run_with_rules() if name == "consequents" else fake_run())
    assert fig.legends or any(ax.get_legend() for ax in fig.axes), "no legend to check"
    assert covered_points(fig) == []


@pytest.fixture(scope="module")
def control_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("control")
    runner = CliRunner()
    for controller in ("pid", "ets"):
        result = runner.invoke(cli, ["control", "sine-altitude", "--duration", "12",
                                     "--controller", controller, "--no-report",
                                     "--out", str(root / f"control-sine-altitude-{controller}")])
        assert result.exit_code == 0, result.output
    return root / "control-sine-altitude-ets"


@pytest.mark.parametrize("name", list(CONTROL_FIGURES))
def test_control_figure_legends_cover_no_data(name: str, control_runs: Path) -> None:
    run = read_control_run(control_runs)
    other = find_comparison(run)
    builder = CONTROL_FIGURES[name][0]
    fig = builder(run, other) if name == "tracking" else builder(run)
    assert other is not None or name != "tracking"
    assert any(ax.get_legend() for ax in fig.axes), "no legend to check"
    assert covered_points(fig) == []
