"""``etsid report``: figures, a self-contained index.html and a report.md for a RUN_DIR."""

from __future__ import annotations

import base64
import html
import json
import shutil
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg

from etsid.errors import IdentError, ReportError
from etsid.ident.rundir import Run, read_run
from etsid.report.figures import FIGURES, label_of, outputs_of
from etsid.report.regimes import regimes_html, regimes_markdown
from etsid.report.tables import metrics_rows, rules_text

FORMATS = ("png", "svg", "pdf")


@dataclass
class Report:
    """Files a report wrote."""

    directory: Path
    figures: dict[str, Path] = field(default_factory=dict)
    html: Path | None = None
    markdown: Path | None = None


def save_figure(fig: Any, path: Path) -> Path:
    """Save a :class:`~matplotlib.figure.Figure` with the Agg canvas (no display needed)."""
    FigureCanvasAgg(fig)
    fig.savefig(path)
    return path


def make_report(run_dir: str | Path, fmt: str = "png") -> Report:
    """Write RUN_DIR/report/: one figure per entry of :data:`FIGURES`, index.html, report.md.

    Parameters
    ----------
    run_dir
        A directory written by ``etsid identify`` or ``etsid predict``, a batch directory
        of ``etsid batch`` (then: :func:`etsid.report.fleet.make_fleet_report`), or a run
        of ``etsid control`` (:mod:`etsid.report.control`).
    fmt
        Figure format: png, svg or pdf. The HTML embeds PNG or SVG; for PDF it also
        writes PNG copies to embed.

    Raises
    ------
    ReportError
        Not a run directory (the cause, an :class:`~etsid.errors.IdentError` of
        :func:`~etsid.ident.rundir.read_run`, is chained), or an unknown format.
    """
    if fmt not in FORMATS:
        raise ReportError(f"unknown figure format {fmt!r}; use one of {', '.join(FORMATS)}")
    if (Path(run_dir) / "gap.json").is_file():  # a directory written by `etsid gap`
        from etsid.report.gap import make_gap_report

        return make_gap_report(run_dir, fmt)
    from etsid.report.control import is_control_run, make_control_report
    from etsid.report.fleet import is_batch_dir, make_fleet_report

    if is_batch_dir(run_dir):  # a directory written by etsid batch: the fleet report
        return make_fleet_report(run_dir, fmt)
    if is_control_run(run_dir):  # written by ``etsid control``
        return make_control_report(run_dir, fmt)
    try:
        run = read_run(run_dir)
    except IdentError as err:
        raise ReportError(str(err)) from err
    out = Path(run_dir) / "report"
    try:
        staging = Path(tempfile.mkdtemp(prefix=".report-", dir=Path(run_dir)))
    except OSError as err:
        raise ReportError(f"{run_dir}: cannot write a report there "
                          f"({err.strerror or err})") from err
    try:
        report = _write(run, staging, fmt)
        _replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    report.directory = out
    report.figures = {name: out / path.name for name, path in report.figures.items()}
    report.html, report.markdown = out / "index.html", out / "report.md"
    return report


def _replace(staging: Path, out: Path) -> None:
    """Put the finished ``staging`` directory at ``out`` (the old report goes only then)."""
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}-old-{staging.name}")
        out.rename(old)
    try:
        staging.rename(out)
    except OSError:
        if old is not None:
            old.rename(out)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _write(run: Run, out: Path, fmt: str) -> Report:
    """Every figure, index.html and report.md of ``run`` into ``out``."""
    report = Report(out)
    embedded: dict[str, tuple[str, str]] = {}
    for name, (builder, caption) in FIGURES.items():
        fig = _build(builder, run, caption)
        report.figures[name] = save_figure(fig, out / f"{name}.{fmt}")
        if fmt == "png":
            embedded[name] = ("image/png", base64.b64encode(
                report.figures[name].read_bytes()).decode())
        elif fmt == "svg":
            embedded[name] = ("image/svg+xml", base64.b64encode(
                report.figures[name].read_bytes()).decode())
        else:
            png = save_figure(fig, out / f"{name}.png")
            embedded[name] = ("image/png", base64.b64encode(png.read_bytes()).decode())
    rules = rules_text(run)
    report.html = out / "index.html"
    report.html.write_text(render_html(run, embedded, rules))
    report.markdown = out / "report.md"
    report.markdown.write_text(render_markdown(run, report.figures, rules))
    return report


def _build(builder: Any, run: Run, caption: str) -> Any:
    """The figure of ``builder``; on data too short or degenerate for it, a figure that
    says so. Warnings of numpy and matplotlib about such data (empty legends, overflow)
    are not passed on: the figure itself says what is missing."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return builder(run)
        except (ValueError, IndexError, ZeroDivisionError, FloatingPointError, KeyError) as err:
            from matplotlib.figure import Figure

            fig = Figure(figsize=(6, 1.2))
            n = (run.metrics.get("validation") or {}).get("n_validation") \
                if isinstance(run.metrics, dict) else None
            more = f" ({n} validation samples)" if n is not None else ""
            fig.text(0.02, 0.5, f"{caption.split('.')[0]}: not drawn, the run's data are too "
                     f"short or degenerate for it{more}: {err}"[:160], va="center",
                     fontsize=8)
            return fig


def _title(run: Run) -> str:
    source = (run.config.get("input") or {}).get("path") or "table"
    return f"etsid {run.config.get('command', 'run')}: {Path(str(source)).name}"


def summary_lines(run: Run) -> list[str]:
    """Key facts of a run as short sentences (model, data, rules, skipped rows)."""
    cfg, met = run.config, run.metrics
    model = cfg.get("model", {})
    val = met.get("validation") or {}
    lines = [
        f"Outputs: {', '.join(model.get('outputs', []))}; regressors: "
        f"{model.get('regressors', '')}.",
        f"{met.get('n_samples')} usable samples; skipped rows: "
        + ", ".join(f"{k} {v}" for k, v in (met.get("skipped") or {}).items()) + ".",
        f"Rules: final {met['rules'].get('final')}, peak {met['rules'].get('peak')}, "
        f"frozen model (rules.json) {met['rules'].get('frozen')}.",
    ]
    if val.get("t_start") is not None:
        lines.append(f"Validation: last {val.get('n_validation')} samples from "
                     f"t = {val['t_start']:.2f} s, learned on the first {val.get('n_learn')}.")
    lines.extend(str(n) for n in model.get("notes") or [])
    lines.extend(f"Note: {w}" for w in cfg.get("warnings") or [])
    return lines


def render_html(run: Run, images: dict[str, tuple[str, str]], rules: str) -> str:
    """A self-contained HTML page (images as data URIs, no external resources)."""
    esc = html.escape
    head, rows = metrics_rows(run)
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(_title(run))}</title>",
        "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em;"
        "color:#222}table{border-collapse:collapse;font-size:90%}"
        "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}"
        "th{background:#eee}td:first-child,th:first-child{text-align:left}"
        "img{max-width:100%}pre{background:#f6f6f6;padding:.6em;overflow-x:auto;"
        "font-size:85%}figcaption{font-size:90%;color:#444}</style></head><body>",
        f"<h1>{esc(_title(run))}</h1>",
        "<ul>" + "".join(f"<li>{esc(s)}</li>" for s in summary_lines(run)) + "</ul>",
        "<h2>Metrics</h2>",
        "<p>RMSE in the output's unit; NDEI = RMSE / std(y); VAF and fit (NRMSE, as "
        "MATLAB's compare) in %. σ is the sensor noise when the data knows it (the floor "
        "of a one-step RMSE).</p>",
        "<table><tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr>",
        *("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row) + "</tr>" for row in rows),
        "</table>",
        *regimes_html(run),
    ]
    for name, (_, caption) in FIGURES.items():
        if name in images:
            mime, data = images[name]
            parts.append(f'<figure id="{name}"><img alt="{esc(name)}" '
                         f'src="data:{mime};base64,{data}"><figcaption>{esc(caption)}'
                         "</figcaption></figure>")
    parts += ["<h2>Rule base (rules.json)</h2>", f"<pre>{esc(rules)}</pre>",
              "<h2>Configuration and provenance (config.json)</h2>",
              f"<pre>{esc(json.dumps(run.config, indent=2))}</pre>", "</body></html>"]
    return "\n".join(parts) + "\n"


def render_markdown(run: Run, figures: dict[str, Path], rules: str) -> str:
    """The same content as :func:`render_html` in Markdown (figures linked, not embedded)."""
    head, rows = metrics_rows(run)
    lines = [f"# {_title(run)}", ""]
    lines += [f"- {s}" for s in summary_lines(run)]
    lines += ["", "## Metrics", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    lines.append("")
    lines += regimes_markdown(run)
    for name, (_, caption) in FIGURES.items():
        if name in figures:
            lines += [f"![{caption}]({figures[name].name})", "", f"*{caption}*", ""]
    lines += ["## Rule base (rules.json)", "", "```", rules, "```", "",
              "## Configuration and provenance (config.json)", "", "```json",
              json.dumps(run.config, indent=2), "```", ""]
    return "\n".join(lines)


def output_labels(run: Run) -> dict[str, str]:
    """Axis labels of every output (used by tests and the CLI)."""
    return {y: label_of(run, y) for y in outputs_of(run)}
