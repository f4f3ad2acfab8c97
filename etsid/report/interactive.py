"""Interactive time-series plots of the reports, drawn with Bokeh and inlined in index.html.

Why Bokeh: it is what PX4 Flight Review uses, so a flight engineer meets the same controls
(drag to pan, wheel to zoom the time axis, hover values, click a legend entry to hide a
line); linked time axes are one shared range object; and its library inlined in a page
(``components=["bokeh"]``, 1.3 MB) is a third of plotly.js (about 4.6 MB), which matters for
reports that are mailed and stored per flight. The data go into the page as binary arrays
(float32), not JSON text.

Long records are reduced before drawing (:func:`keep_rows`): every series keeps the minimum
and the maximum of each of :data:`MAX_BUCKETS` time buckets, so a spike is never lost while a
10-minute log at 250 Hz still draws from a few thousand points per line.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from itertools import pairwise
from typing import Any

import numpy as np

MAX_BUCKETS = 1000
"""Time buckets per plot; each series keeps its min and max in each (≤ 2000 points)."""

HEIGHT = 210
"""Height of one time-series plot, px."""

COLORS = {"measured": "#222222", "one_step": "#1f77b4", "free_run": "#d62728",
          "arx": "#2ca02c", "reference": "#ff7f0e", "other": "#9467bd"}
"""Line colours shared with the static figures."""

RULE_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
               "#7f7f7f", "#bcbd22", "#17becf")
"""Colour of rule i (1-based: RULE_COLORS[(i - 1) % 10])."""


@dataclass(frozen=True)
class Line:
    """One series of a plot: column ``column`` drawn as ``label``."""

    column: str
    label: str
    color: str
    width: float = 1.0
    dash: str = "solid"
    alpha: float = 1.0


MEASURED_STYLE = {"color": "#6e6e6e", "width": 1.0, "alpha": 0.8}
"""Measured data under predictions: grey and thin, drawn first (under them), so that a
prediction that follows it closely still shows on top instead of vanishing under it."""

SIGNAL_STYLE = {"color": COLORS["measured"], "width": 1.4}
"""A measured signal drawn alone (altitude, thrust command of the overview)."""

MODEL_STYLES = {
    "one_step": {"color": COLORS["one_step"], "width": 1.0, "dash": "dotted"},
    "free_run": {"color": COLORS["free_run"], "width": 1.5, "dash": "solid", "alpha": 0.85},
    "arx": {"color": COLORS["arx"], "width": 1.5, "dash": "dashed"},
}
"""eTS one-step, eTS free-run and ARX free-run: a colour, a width and a dash each (one
colour alone does not tell two close lines apart); ARX dashed on top of eTS solid, so
where they coincide both stay visible."""


def gap_cuts(t: np.ndarray) -> np.ndarray:
    """Indices where a new contiguous stretch starts (time step > 1.5 × its median)."""
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return np.zeros(0, dtype=int)
    dt = np.diff(t)
    return np.flatnonzero(dt > 1.5 * np.median(dt)) + 1


def keep_rows(t: np.ndarray, columns: Iterable[np.ndarray],
              buckets: int = MAX_BUCKETS) -> np.ndarray:
    """Row indices to draw: all rows when there are at most 2 × ``buckets``, else, per time
    bucket, the rows of the minimum and the maximum of every column (NaN ignored), plus the
    first and last row.

    >>> t = np.arange(10_000.0)
    >>> y = np.zeros(10_000); y[4321] = 5.0
    >>> rows = keep_rows(t, [y], buckets=100)
    >>> 4321 in rows, rows.size <= 202
    (True, True)
    """
    n = len(t)
    if n <= 2 * buckets:
        return np.arange(n)
    edges = np.linspace(0, n, buckets + 1).astype(int)
    keep = [np.array([0, n - 1])]
    for y in columns:
        y = np.asarray(y, dtype=float)
        if not np.isfinite(y).any():
            continue
        lo = np.where(np.isfinite(y), y, np.inf)
        hi = np.where(np.isfinite(y), y, -np.inf)
        starts = edges[:-1]
        keep.append(starts + _segment_arg(lo, edges, np.argmin))
        keep.append(starts + _segment_arg(hi, edges, np.argmax))
    return np.unique(np.concatenate(keep))


def _segment_arg(values: np.ndarray, edges: np.ndarray, arg: Any) -> np.ndarray:
    """``arg`` (np.argmin or np.argmax) within each bucket [edges[i], edges[i+1]), as an
    offset from the bucket's start."""
    return np.array([arg(values[a:b]) for a, b in pairwise(edges)],
                    dtype=int)


def source(t: np.ndarray, data: dict[str, np.ndarray], buckets: int = MAX_BUCKETS) -> Any:
    """A ColumnDataSource of ``t`` and ``data`` reduced by :func:`keep_rows`, as float32,
    with a NaN row at every time gap so lines break there."""
    from bokeh.models import ColumnDataSource

    t = np.asarray(t, dtype=float)
    cols = {k: np.asarray(v, dtype=float) for k, v in data.items()}
    rows = keep_rows(t, cols.values(), buckets)
    t_kept = t[rows]
    kept = {k: v[rows] for k, v in cols.items()}
    cuts = gap_cuts(t_kept) if len(t_kept) > 2 else np.zeros(0, dtype=int)
    if cuts.size and len(gap_cuts(t)):
        t_kept = np.insert(t_kept, cuts, np.nan)
        kept = {k: np.insert(v, cuts, np.nan) for k, v in kept.items()}
    return ColumnDataSource({"t": t_kept.astype(np.float32),
                             **{k: v.astype(np.float32) for k, v in kept.items()}})


def time_figure(y_label: str, title: str = "", x_range: Any = None,
                height: int = HEIGHT, x_label: str = "time t (s)") -> Any:
    """An empty time-series plot: x pan and wheel zoom active, box zoom, reset, save."""
    from bokeh.plotting import figure

    kwargs: dict[str, Any] = {"x_range": x_range} if x_range is not None else {}
    fig = figure(height=height, sizing_mode="stretch_width", title=title or None,
                 tools="xpan,xwheel_zoom,box_zoom,reset,save",
                 active_drag="xpan", active_scroll="xwheel_zoom", **kwargs)
    fig.xaxis.axis_label = x_label
    fig.yaxis.axis_label = y_label
    if height < HEIGHT:  # a small panel: fewer y ticks, so their labels do not overlap
        fig.yaxis.ticker.desired_num_ticks = 3
        fig.yaxis.major_label_text_font_size = "8pt"
    fig.toolbar.logo = None
    fig.title.text_font_size = "10pt"
    fig.min_border_left = 70
    return fig


def shared_range(t: np.ndarray) -> Any:
    """One x range (s) for plots whose time axes are linked, spanning ``t``."""
    from bokeh.models import Range1d

    finite = np.asarray(t, dtype=float)
    finite = finite[np.isfinite(finite)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    if hi <= lo:
        hi = lo + 1.0
    return Range1d(lo, hi, bounds=(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)))


def add_lines(fig: Any, src: Any, lines: Sequence[Line], digits: str = "0.0000",
              unit: str = "") -> list[Any]:
    """Draw ``lines`` from ``src`` in order (the last on top) with a legend (click hides a
    line) and one hover box listing every line's value at the pointer's time.

    Bokeh renders a tooltip's value template as HTML, so nothing from a file goes into it:
    the unit goes into the row's label (set as text) and a column whose name is not plain
    is read through an alias column (values substituted from data are escaped by Bokeh).
    """
    from bokeh.models import HoverTool

    renderers = []
    for line in lines:
        renderers.append(fig.line("t", line.column, source=src, color=line.color,
                                  line_width=line.width, line_dash=line.dash,
                                  alpha=line.alpha, legend_label=line.label))
    suffix = f" ({unit})" if unit and unit != "1" else ""
    tips = [("t (s)", "@t{0.000}")] + [(f"{ln.label}{suffix}",
                                         f"@{{{_field(src, ln.column)}}}{{{digits}}}")
                                        for ln in lines]
    fig.add_tools(HoverTool(renderers=renderers[-1:], tooltips=tips, mode="vline"))
    legend_above(fig)
    return renderers


_PLAIN = re.compile(r"[A-Za-z0-9_.\-\[\]]+")


def _field(src: Any, column: str) -> str:
    """A name of ``column`` in ``src`` safe inside ``@{...}`` of a tooltip template."""
    if _PLAIN.fullmatch(column):
        return column
    alias = f"_col{sorted(src.data).index(column)}"
    src.data[alias] = src.data[column]
    return alias


def legend_above(fig: Any) -> None:
    """Move every legend entry of ``fig`` into one horizontal legend above the plot area
    (nothing hides the data; a click on an entry hides its line)."""
    from bokeh.models import Legend

    legends = list(fig.legend)
    items = [item for legend in legends for item in legend.items]
    for legend in legends:
        for side in ("center", "above", "below", "left", "right"):
            if legend in getattr(fig, side):
                getattr(fig, side).remove(legend)
    if items:
        fig.add_layout(Legend(items=items, orientation="horizontal", click_policy="hide",
                              label_text_font_size="8pt", spacing=14, padding=2, margin=2,
                              border_line_alpha=0, glyph_width=22), "above")


def shade(fig: Any, start: float, end: float, color: str = "#999999", alpha: float = 0.12,
          hatch: str | None = None) -> None:
    """A vertical band from ``start`` to ``end`` (s) behind the lines; with ``hatch`` (a
    Bokeh hatch pattern such as ``"/"``) hatched lines instead of a fill, which does not
    mix with other shading into colours no legend has."""
    from bokeh.models import BoxAnnotation

    if hatch:
        fig.add_layout(BoxAnnotation(left=start, right=end, fill_alpha=0, line_alpha=0,
                                     hatch_pattern=hatch, hatch_color=color,
                                     hatch_alpha=min(1.0, 3 * alpha), hatch_scale=14,
                                     level="underlay"))
        return
    fig.add_layout(BoxAnnotation(left=start, right=end, fill_color=color, fill_alpha=alpha,
                                 level="underlay"))


def mark(fig: Any, when: float, color: str = "#555555", dash: str = "dashed") -> None:
    """A vertical line at ``when`` (s)."""
    from bokeh.models import Span

    fig.add_layout(Span(location=when, dimension="height", line_color=color,
                        line_dash=dash, line_width=1.2))


def intervals(t: np.ndarray, labels: np.ndarray) -> list[tuple[float, float, Any]]:
    """Contiguous stretches of equal ``labels``: (start, end, label), end = next start."""
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return []
    change = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.r_[0, change]
    ends = np.r_[change, t.size - 1]
    return [(float(t[a]), float(t[b]), labels[a]) for a, b in zip(starts, ends, strict=True)]


def shade_labels(fig: Any, t: np.ndarray, labels: np.ndarray, names: dict[Any, str],
                 colors: dict[Any, str], alpha: float = 0.18) -> None:
    """Shade each stretch of equal label in its colour, with one legend entry per label."""
    stretches = intervals(t, labels)
    for label, name in names.items():
        mine = [(a, b) for a, b, lab in stretches if lab == label]
        if not mine:
            continue
        fig.quad(left=[a for a, _ in mine], right=[b for _, b in mine], bottom=-1e9,
                 top=1e9, fill_color=colors[label], fill_alpha=alpha, line_alpha=0,
                 legend_label=name, level="underlay")


def integer_axis(fig: Any) -> None:
    """Integer ticks on the y axis (counts, rule numbers)."""
    from bokeh.models import AdaptiveTicker

    fig.yaxis.ticker = AdaptiveTicker(min_interval=1, num_minor_ticks=0)


@lru_cache(maxsize=1)
def bokeh_js() -> str:
    """The BokehJS library as inline ``<script>`` tags (no CDN)."""
    from bokeh.resources import Resources

    js = Resources(mode="inline", components=["bokeh"]).render_js()
    # the toolbar logo is switched off; its embedded image would only count as a figure
    return re.sub(r"url\(data:image/png;base64,[A-Za-z0-9+/=]+\)", "none", js)


LOADER = """<script>(function () {
  function draw(div) {
    if (div.dataset.drawn) return;
    div.dataset.drawn = "1";
    const item = JSON.parse(document.getElementById(div.dataset.item).textContent);
    Bokeh.embed.embed_item(item, div.id);
  }
  function start() {
    const divs = Array.from(document.querySelectorAll("div.bk-lazy"));
    if (!("IntersectionObserver" in window)) { divs.forEach(draw); return; }
    const seen = new IntersectionObserver(function (entries) {
      entries.forEach(function (e) {
        if (e.isIntersecting) { seen.unobserve(e.target); draw(e.target); }
      });
    }, {rootMargin: "400px"});
    divs.forEach(function (d) { seen.observe(d); });
    window.addEventListener("beforeprint", function () { divs.forEach(draw); });
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();</script>"""
"""Draws each plot section when it comes near the viewport (Bokeh lays out every figure of a
page at once otherwise: about 70 ms of CPU per figure, 1.5 s for a long flight's 23)."""


def embed(plots: dict[str, Any]) -> tuple[str, dict[str, str]]:
    """(head, {name: div}) for ``plots`` (Bokeh models or layouts, each its own document:
    models must not be shared between them). The head inlines the library and a loader
    that draws each plot when it scrolls into view; the div carries its data (JSON in a
    ``<script type="application/json">``) and reserves the plot's height."""
    if not plots:
        return "", {}
    import json

    from bokeh.embed import json_item

    divs = {}
    for name, model in plots.items():
        data = json.dumps(json_item(model), separators=(",", ":")).replace("</", "<\\/")
        divs[name] = (f'<script type="application/json" id="bk-item-{name}">{data}</script>'
                      f'<div class="plot bk-lazy" id="bk-{name}" data-item="bk-item-{name}" '
                      f'style="min-height:{_height(model)}px"></div>')
    return bokeh_js() + "\n" + LOADER, divs


def _height(model: Any) -> int:
    """Pixels ``model`` will take (figures' heights plus their titles and legends)."""
    children = getattr(model, "children", None)
    if children:
        return sum(_height(c) for c in children)
    return int(getattr(model, "height", None) or 300)


def column(*figures: Any) -> Any:
    """Figures stacked vertically at full width."""
    from bokeh.layouts import column as bokeh_column

    return bokeh_column(*figures, sizing_mode="stretch_width")
