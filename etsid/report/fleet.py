"""The fleet report of a batch directory (``etsid report DIR`` on what ``etsid batch`` wrote).

``DIR/report/``: ``index.html`` (self-contained), ``report.md`` and
``distributions.png``: the batch in numbers, distributions of the key figures, the best
and the worst flights with links to their own reports (written here when missing), the
failures grouped by cause, and every log in one table. The results are read straight from
the Parquet dataset ``DIR/results/`` (rows of the latest batch's options only).
"""

from __future__ import annotations

import base64
import os
import re
import shutil
import tempfile
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from etsid.errors import EtsidError
from etsid.escape import clean, for_html, printable
from etsid.files import read_bytes, read_json, read_parquet_dataset
from etsid.report.build import Report, save_figure
from etsid.report.figures import WIDTH, style
from etsid.report.page import markdown_safe
from etsid.report.parallel import PRELOAD, InProcess, Runner, write_report
from etsid.schemas import BATCH, validate

FIGURES = {
    "duration_s": "log duration, s",
    "fit_one_step": "validation one-step fit, % (mean over outputs)",
    "fit_free_run": "validation free-run fit, % (mean over outputs)",
    "rules_frozen": "rules of the saved model",
    "wall_s": "wall time per log, s",
    "peak_rss_mb": "peak worker memory per log, MB",
}
"""Result columns drawn as distributions (those with data), with their labels."""

INTEGER_COLUMNS = ("rules_frozen",)
"""Distributions of counts: one bar per integer."""

RANK_BY = ("fit_one_step", "fit_online")
"""Figures that rank flights best to worst (the first one with data)."""

TOP = 5
"""Flights listed as best and as worst."""

TABLE_COLUMNS = ("input", "status", "format", "duration_s", "rows", "rules_frozen",
                 "fit_one_step", "fit_free_run", "wall_s", "peak_rss_mb", "error")


def is_batch_dir(path: str | Path) -> bool:
    """True for a directory written by ``etsid batch`` (``batch.json`` and ``results/``)."""
    path = Path(path)
    return (path / "batch.json").is_file() and (path / "results").is_dir()


def load_fleet(path: str | Path) -> tuple[dict[str, Any], pd.DataFrame]:
    """``batch.json`` and the rows of its command and options, sorted by input; one row per
    log, the latest (a compacted dataset may hold an older row of a log run again)."""
    path = Path(path)
    meta = clean(validate(read_json(path / "batch.json", "batch", EtsidError), BATCH,
                          path / "batch.json", EtsidError, "batch.json"))
    frame = read_parquet_dataset(path / "results", "batch", EtsidError)
    frame, notes = checked_rows(frame, path / "results")
    meta["notes"] = notes
    if "command" in frame.columns:
        frame = frame[frame["command"].astype(str) == meta.get("command")]
    if meta.get("options_digest") and "options_digest" in frame.columns:
        frame = frame[frame["options_digest"] == meta["options_digest"]]
    if "finished" in frame.columns:
        frame = frame.sort_values("finished", kind="stable", na_position="first")
        frame = frame.drop_duplicates(subset=["sim_input", "input"], keep="last")
    return meta, frame.sort_values("input", kind="stable").reset_index(drop=True)


ROW_RANGES: dict[str, tuple[float, float]] = {
    "duration_s": (0.0, 1e7), "airborne_s": (0.0, 1e7), "rows": (0.0, 1e10),
    "rate_hz": (0.0, 1e6), "wall_s": (0.0, 1e7), "cpu_s": (0.0, 1e8),
    "peak_rss_mb": (0.0, 1e8), "rules_final": (0.0, 1e6), "rules_peak": (0.0, 1e6),
    "rules_frozen": (0.0, 1e6), "regime_count": (0.0, 1e6), "warnings": (0.0, 1e9),
    "n_samples": (0.0, 1e10), "channels": (0.0, 1e9), "ndei_one_step": (0.0, 1e6),
}
"""Physical range of the numeric result columns the fleet report draws or ranks; a fit (%)
is at most 100 (columns named fit_* or *_fit_*; unbounded below: a bad model's fit is
very negative, but finite)."""
TEXT_COLUMNS = ("input", "status", "error", "error_kind", "format", "run_dir", "vehicle",
                "autopilot", "firmware", "hardware", "command", "options_digest",
                "finished", "sim_input", "worker")


def checked_rows(frame: pd.DataFrame, source: Path) -> tuple[pd.DataFrame, list[str]]:
    """Result rows as the report can use them, and a note per column of values it dropped.

    ``input`` and ``status`` must be there (else one-line error naming ``source``); text
    columns are made printable; a numeric value that is not finite or outside its
    physical range (:data:`ROW_RANGES`, fits at most 100 %) becomes missing and is
    counted in a note, never drawn.
    """
    missing = [c for c in ("input", "status") if c not in frame.columns]
    if missing:
        raise EtsidError(f"{source}: result rows lack {', '.join(missing)} (not written by "
                         "etsid batch)")
    frame = frame.copy()
    notes: list[str] = []
    for column in frame.columns:
        values = frame[column]
        if column in TEXT_COLUMNS or values.dtype == object:
            frame[column] = values.map(lambda v: printable(v) if isinstance(v, str) else v)
            continue
        if not pd.api.types.is_numeric_dtype(values) or pd.api.types.is_bool_dtype(values):
            continue
        numbers = pd.to_numeric(values, errors="coerce").astype(float)
        low, high = ROW_RANGES.get(column, (-np.inf, np.inf))
        if column.startswith("fit") or "_fit_" in column:
            low, high = -1e12, 100.0
        bad = numbers.notna() & ~(np.isfinite(numbers) & (numbers >= low) & (numbers <= high))
        if bad.any():
            notes.append(f"{source}: {int(bad.sum())} value(s) of {column} not finite or "
                         "outside its physical range, left out")
            frame[column] = numbers.mask(bad)
    return frame, notes


def cause_of(error: str, item: str) -> str:
    """An error message as a cause: the log's path taken out, numbers replaced by N."""
    text = str(error).replace(str(item), "").strip().lstrip(":").strip()
    return re.sub(r"\d+(\.\d+)?", "N", text)


def failures_by_cause(frame: pd.DataFrame) -> pd.DataFrame:
    """Failed logs grouped by :func:`cause_of`: cause, kind, count, example logs."""
    failed = frame[frame["status"] == "error"]
    if failed.empty:
        return pd.DataFrame(columns=["cause", "kind", "count", "examples"])
    causes = [cause_of(e, i) for e, i in zip(failed["error"], failed["input"], strict=True)]
    grouped = failed.assign(cause=causes).groupby(["cause", "error_kind"], sort=False)
    table = grouped["input"].agg(["count", lambda s: ", ".join(list(s)[:3])]).reset_index()
    table.columns = ["cause", "kind", "count", "examples"]
    return table.sort_values(["count", "cause"], ascending=[False, True]).reset_index(drop=True)


def ranking(frame: pd.DataFrame) -> tuple[str | None, pd.DataFrame, pd.DataFrame]:
    """(figure, best, worst): the :data:`TOP` best and worst successful flights; when
    there are at most 2 × :data:`TOP`, every one of them as ``best`` (best first) and
    ``worst`` empty, so no flight is listed twice."""
    ok = frame[frame["status"] == "ok"]
    for column in RANK_BY:
        if column in ok.columns and ok[column].notna().any():
            ranked = ok[ok[column].notna()].sort_values([column, "input"],
                                                        ascending=[False, True])
            if len(ranked) <= 2 * TOP:  # a small fleet: one list, best first
                return column, ranked, ranked.head(0)
            return column, ranked.head(TOP), ranked.tail(TOP).iloc[::-1]
    return None, ok.head(0), ok.head(0)


def fig_distributions(frame: pd.DataFrame) -> Figure | None:
    """Histograms of the :data:`FIGURES` columns that have data (None: none has)."""
    ok = frame[frame["status"] == "ok"]
    columns = [c for c in FIGURES if c in ok.columns and ok[c].notna().any()]
    if not columns:
        return None
    ncols = 3
    nrows = (len(columns) + ncols - 1) // ncols
    with style():
        fig = Figure(figsize=(WIDTH, 2.0 * nrows), layout="constrained")
        axes = fig.subplots(nrows, ncols, squeeze=False)
        for ax, column in zip(axes.flat, columns, strict=False):
            values = ok[column].dropna().to_numpy(dtype=float)
            values = values[np.isfinite(values)]
            integer = column in INTEGER_COLUMNS
            bins: Any = (np.arange(values.min() - 0.5, values.max() + 1.5) if integer
                         and values.size else min(30, max(5, values.size // 3)))
            ax.hist(values, bins=bins, color="tab:blue", alpha=0.8)
            ax.set_xlabel(textwrap.fill(FIGURES[column], 26))
            ax.set_ylabel("logs")
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax.xaxis.set_major_locator(MaxNLocator(nbins=4, integer=integer))
            ax.ticklabel_format(axis="x", style="plain", useOffset=False)
            if values.size:
                ax.axvline(float(np.median(values)), color="tab:red", lw=1,
                           label=f"median {np.median(values):.3g}")
                ax.legend()
        for ax in list(axes.flat)[len(columns):]:
            ax.set_visible(False)
    return fig


def run_dir_inside(batch_dir: Path, run_dir: str | None) -> Path | None:
    """``DIR/run_dir`` when it lies inside ``DIR/runs/`` (None otherwise): a results
    dataset is data, and a crafted ``run_dir`` (``../victim``, an absolute path, a link
    out) must not make the report read or write outside the batch directory."""
    if not run_dir or not isinstance(run_dir, str):
        return None
    runs = (batch_dir / "runs").resolve()
    target = (batch_dir / run_dir).resolve()
    return target if target.is_relative_to(runs) and target != runs else None


def flight_reports(batch_dir: Path, listed: pd.DataFrame, command: str) -> dict[str, Path]:
    """Input → the run directory of each listed flight that has (or gets) its own report:
    identify runs whose ``run_dir`` lies inside ``DIR/runs/``."""
    if command != "identify":
        return {}
    found = {}
    for _, row in listed.iterrows():
        inside = run_dir_inside(batch_dir, row.get("run_dir"))
        if inside is not None:
            found[str(row["input"])] = inside
    return found


def run_report_link(batch_dir: Path, run_dir: Path) -> str | None:
    """Relative link from DIR/report/ to a run's own report (None: it has none)."""
    target = run_dir / "report" / "index.html"
    if not target.is_file():
        return None
    return os.path.relpath(target, batch_dir.resolve() / "report")


def _fmt(value: Any) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "–"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _html_table(frame: pd.DataFrame, columns: list[str],
                links: dict[str, str] | None = None) -> str:
    esc = for_html
    links = links or {}
    head = "".join(f"<th>{esc(c)}</th>" for c in columns)
    rows = []
    for _, row in frame.iterrows():
        cells = []
        for c in columns:
            text = esc(_fmt(row.get(c)))
            if c == "input" and row.get("input") in links:
                text = f'<a href="{esc(links[row["input"]])}">{text}</a>'
            cells.append(f"<td>{text}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def _md_table(frame: pd.DataFrame, columns: list[str],
              links: dict[str, str] | None = None) -> list[str]:
    links = links or {}
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for _, row in frame.iterrows():
        cells = []
        for c in columns:
            text = _fmt(row.get(c)).replace("|", "\\|")
            if c == "input" and row.get("input") in links:
                text = f"[{text}]({links[row['input']]})"
            cells.append(text)
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def summary_lines(meta: dict[str, Any], frame: pd.DataFrame) -> list[str]:
    """The batch in a few sentences."""
    ok = int((frame["status"] == "ok").sum())
    failed = int((frame["status"] == "error").sum())
    lines = [f"Command: etsid batch {meta.get('command')} over {len(frame)} logs: {ok} ok, "
             f"{failed} failed.",
             f"Options digest {str(meta.get('options_digest', ''))[:12]}; "
             f"{meta.get('jobs')} jobs on the {meta.get('scheduler')} scheduler; "
             f"started {meta.get('started')}, {meta.get('ended', 'running')}"
             + (f" after {meta['wall_s']:.1f} s." if meta.get("wall_s") else ".")]
    lines += [str(note) for note in meta.get("notes") or []]
    if "wall_s" in frame and frame["wall_s"].notna().any():
        lines.append(f"CPU-side time per log: median {frame['wall_s'].median():.2f} s, "
                     f"max {frame['wall_s'].max():.2f} s; peak worker memory max "
                     f"{frame['peak_rss_mb'].max():.0f} MB.")
    return lines


def make_fleet_report(batch_dir: str | Path, fmt: str = "png", say: Any = None,
                      run_with: Runner | None = None) -> Report:
    """Write ``DIR/report/``: index.html, report.md and the distributions figure.

    The ranked flights' own reports that are missing are written by ``run_with`` (default:
    here, one after the other; ``etsid report`` passes :class:`etsid.batch.pool.WarmPool`,
    worker processes that write them while this process draws the fleet's page).

    The report is written into a staging folder beside it and put in place whole: an
    interrupted report leaves the previous one (or none), never half of one.

    Raises
    ------
    EtsidError
        Not a batch directory, or unreadable results.
    """
    from etsid.report.build import _replace

    batch_dir = Path(batch_dir)
    if not is_batch_dir(batch_dir):
        raise EtsidError(f"{batch_dir}: not a batch directory (no batch.json and results/)")
    meta, frame = load_fleet(batch_dir)
    try:
        staging = Path(tempfile.mkdtemp(prefix=".report-", dir=batch_dir))
    except OSError as err:
        raise EtsidError(f"{batch_dir}: cannot write a report there "
                         f"({err.strerror or err})") from err
    try:
        report = _write_fleet(batch_dir, meta, frame, staging, fmt, say or (lambda _: None),
                              run_with or InProcess)
        staging.chmod(0o777 & ~_umask())
        _replace(staging, batch_dir / "report")
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    out = batch_dir / "report"
    report.directory = out
    report.figures = {name: out / path.name for name, path in report.figures.items()}
    report.html, report.markdown = out / "index.html", out / "report.md"
    report.notes = list(meta.get("notes") or [])
    return report


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write_fleet(batch_dir: Path, meta: dict[str, Any], frame: pd.DataFrame, out: Path,
                 fmt: str, say: Any = print, run_with: Runner = InProcess) -> Report:
    """Every part of the fleet report into ``out``."""
    command = str(meta.get("command"))
    report = Report(out)
    figure, best, worst = ranking(frame)
    flights = flight_reports(batch_dir, pd.concat([best, worst]), command)
    missing = [d for d in flights.values() if not (d / "report" / "index.html").is_file()]
    if missing:  # by run_with: with worker processes, while this one draws the page
        say(f"fleet report: writing the own reports of {len(missing)} of the "
            f"{len(best) + len(worst)} ranked flights (each links to its report) …")
    pool = run_with(write_report, [str(d) for d in missing], PRELOAD)
    try:
        image, interactive = _draw(frame, figure, report, fmt)
    except BaseException:
        pool.close(cancel=True)
        raise
    outcomes = pool.results(lambda done, run_dir: say(
        f"fleet report: {done}/{len(missing)} flight reports written ({Path(run_dir).name})"))
    failed = {d: ("the process writing its report died" if isinstance(why, BaseException)
                  else why) for d, why in zip(missing, outcomes, strict=True)}
    links = {}
    unreported = {}
    for item, run_dir in flights.items():
        link = run_report_link(batch_dir, run_dir)
        if link:
            links[item] = link
        else:
            unreported[item] = failed.get(run_dir) or "its report was not written"
    say("fleet report: writing the page …")
    causes = failures_by_cause(frame)
    parts = _Parts(meta, frame, figure, best, worst, causes, links, unreported)
    report.html = out / "index.html"
    report.html.write_text(parts.html(image, interactive))
    report.markdown = out / "report.md"
    report.markdown.write_text(markdown_safe(parts.markdown(report.figures.get("distributions"))))
    return report


def _draw(frame: pd.DataFrame, figure: str | None, report: Report, fmt: str
          ) -> tuple[tuple[str, str] | None, tuple[str, str]]:
    """The distributions figure (saved into the report; embedded as (mime, base64)) and
    the interactive scatter (head, div)."""
    fig = fig_distributions(frame)
    image = None
    if fig is not None:
        out = report.directory
        report.figures["distributions"] = save_figure(fig, out / f"distributions.{fmt}")
        png = report.figures["distributions"]
        if fmt == "pdf":
            png = save_figure(fig, out / "distributions.png")
        mime = "image/svg+xml" if fmt == "svg" else "image/png"
        image = (mime, base64.b64encode(read_bytes(png, "figure", EtsidError)).decode())
    return image, _interactive(frame, figure)


class _Parts:
    """The report's sections, rendered as HTML or Markdown."""

    def __init__(self, meta: dict[str, Any], frame: pd.DataFrame, figure: str | None,
                 best: pd.DataFrame, worst: pd.DataFrame, causes: pd.DataFrame,
                 links: dict[str, str], unreported: dict[str, str] | None = None) -> None:
        self.meta, self.frame, self.figure = meta, frame, figure
        self.best, self.worst, self.causes, self.links = best, worst, causes, links
        self.unreported = unreported or {}
        self.title = f"etsid fleet report: {meta.get('command')} over {len(frame)} logs"
        self.columns = [c for c in TABLE_COLUMNS
                        if c in frame.columns and frame[c].notna().any()]
        self.rank_columns = ["input", *[c for c in (figure, "duration_s", "rules_frozen")
                                        if c]]

    def _ranking_note(self) -> str:
        if self.figure is None:
            return "No figure ranks these logs (only identify batches are ranked)."
        return (f"Ranked by {self.figure} ({FIGURES.get(self.figure, self.figure)}); "
                "each log links to its own report.")

    def _unreported_notes(self) -> list[str]:
        """One line per ranked flight without its own report, and why."""
        return [f"No report of {item}: {why}" for item, why in self.unreported.items()]

    def html(self, image: tuple[str, str] | None,
             interactive: tuple[str, str] = ("", "")) -> str:
        from etsid.report.page import html_page

        esc = for_html
        head_js, div = interactive
        parts = [
            '<section id="summary"><h2>Summary</h2><ul>'
            + "".join(f"<li>{esc(s)}</li>" for s in summary_lines(self.meta, self.frame))
            + "</ul></section>",
            '<section id="distributions"><h2>Distributions</h2>',
        ]
        if div:
            parts += ['<p class="hint">Interactive: drag to pan, scroll to zoom, hover a dot '
                      "for the flight's name and figures.</p>", div]
        if image is not None:
            parts.append(f'<img alt="distributions" src="data:{image[0]};base64,{image[1]}">')
        else:
            parts.append("<p>No successful log to draw.</p>")
        parts += ["</section>", '<section id="best-worst"><h2>Best and worst flights</h2>',
                  f"<p>{esc(self._ranking_note())}</p>",
                  *(f"<p>{esc(n)}</p>" for n in self._unreported_notes())]
        if self.figure is not None and self.worst.empty:
            parts += ["<h3>Every ranked flight, best first</h3>",
                      _html_table(self.best, self.rank_columns, self.links)]
        elif self.figure is not None:
            parts += ["<h3>Best</h3>", _html_table(self.best, self.rank_columns, self.links),
                      "<h3>Worst</h3>", _html_table(self.worst, self.rank_columns, self.links)]
        parts += ["</section>", '<section id="failures"><h2>Failures by cause</h2>']
        if self.causes.empty:
            parts.append("<p>No log failed.</p>")
        else:
            parts.append(_html_table(self.causes, ["cause", "kind", "count", "examples"]))
        parts += ["</section>", '<section id="logs"><h2>Every log</h2>',
                  _html_table(self.frame, self.columns, self.links), "</section>"]
        return html_page(self.title, parts, head_js)

    def markdown(self, figure_path: Path | None) -> str:
        lines = [f"# {self.title}", "", "## Summary", ""]
        lines += [f"- {s}" for s in summary_lines(self.meta, self.frame)]
        lines += ["", "## Distributions", ""]
        lines.append(f"![distributions]({figure_path.name})" if figure_path
                     else "No successful log to draw.")
        lines += ["", "## Best and worst flights", "", self._ranking_note(), ""]
        lines += [*self._unreported_notes(), ""] if self.unreported else []
        if self.figure is not None and self.worst.empty:
            lines += ["### Every ranked flight, best first", "",
                      *_md_table(self.best, self.rank_columns, self.links), ""]
        elif self.figure is not None:
            lines += ["### Best", "", *_md_table(self.best, self.rank_columns, self.links),
                      "", "### Worst", "",
                      *_md_table(self.worst, self.rank_columns, self.links), ""]
        lines += ["## Failures by cause", ""]
        lines += (["No log failed."] if self.causes.empty
                  else _md_table(self.causes, ["cause", "kind", "count", "examples"]))
        lines += ["", "## Every log", "", *_md_table(self.frame, self.columns, self.links), ""]
        return "\n".join(lines)


def _interactive(frame: pd.DataFrame, figure: str | None) -> tuple[str, str]:
    """An interactive scatter of every successful flight: the ranking figure (or the rule
    count) against the log's duration; hover names the log."""
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.plotting import figure as bokeh_figure

    from etsid.report import interactive as ia

    ok = frame[frame["status"] == "ok"]
    y_col = figure or ("rules_frozen" if "rules_frozen" in ok else None)
    if y_col is None or "duration_s" not in ok or not ok[y_col].notna().any():
        return "", ""
    ok = ok[ok[y_col].notna() & ok["duration_s"].notna()]
    duration = ok["duration_s"].to_numpy(dtype=float)
    y = ok[y_col].to_numpy(dtype=float)
    x, x_label, against = duration, FIGURES["duration_s"], "against log duration"
    if len(ok) > 1 and np.ptp(duration) <= max(0.5, 0.01 * float(np.median(duration))):
        # every flight as long as the others: duration tells nothing, the flights in the
        # order of the inputs spread them out instead
        x = np.arange(1, len(ok) + 1, dtype=float)
        x_label = "flight (order of the inputs)"
        against = f"per flight (every log lasts {float(np.median(duration)):.1f} s)"
    hidden = len(ok) - len({(float(a), float(b)) for a, b in zip(x, y, strict=True)})
    src = ColumnDataSource({"x": x, "y": y, "duration": duration,
                            "input": ok["input"].astype(str).to_numpy(),
                            "rules": (ok["rules_frozen"] if "rules_frozen" in ok
                                      else ok["duration_s"] * np.nan).to_numpy(dtype=float)})
    title = (f"{FIGURES.get(y_col, y_col)} {against}, one dot per flight (hover for its "
             "name)")
    if hidden:
        title += (f"; {hidden} dot{'s' if hidden > 1 else ''} on top of another (the same "
                  "values): hover lists every flight under the pointer")
    fig = bokeh_figure(height=300, sizing_mode="stretch_width",
                       tools="pan,wheel_zoom,box_zoom,reset,save", title=title)
    fig.toolbar.logo = None
    dots = fig.scatter("x", "y", source=src, size=8, alpha=0.7, color="#1f77b4")
    fig.add_tools(HoverTool(renderers=[dots], tooltips=[
        ("log", "@input"), ("duration", "@duration{0.0} s"), (y_col, "@y{0.00}"),
        ("rules", "@rules{0}")]))
    fig.xaxis.axis_label = x_label
    fig.yaxis.axis_label = FIGURES.get(y_col, y_col)
    if y_col == "rules_frozen":
        ia.integer_axis(fig)
    head, divs = ia.embed({"fleet": fig})
    return head, divs["fleet"]
