"""``etsid report``: figures, a self-contained index.html and a report.md for a RUN_DIR."""

from __future__ import annotations

import base64
import json
import shutil
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg

from etsid.errors import IdentError, ReportError
from etsid.files import read_bytes
from etsid.ident.rundir import Run, read_run
from etsid.report.choices import FORMATS as FORMATS
from etsid.report.figures import FIGURES, label_of, outputs_of
from etsid.report.page import HINT, esc, html_page, make_shared_dir, markdown_safe, table_html
from etsid.report.regimes import regimes_html, regimes_markdown
from etsid.report.tables import merges_text, metrics_rows, rule_counts, rules_text

Say = Callable[[str], None]
"""Where a report says what it is doing (the CLI: a line on stderr)."""


def quiet(_: str) -> None:
    """A :data:`Say` that says nothing."""


@dataclass
class Report:
    """Files a report wrote."""

    directory: Path
    figures: dict[str, Path] = field(default_factory=dict)
    html: Path | None = None
    markdown: Path | None = None
    notes: list[str] = field(default_factory=list)
    """What the report left out of its input and why (printed by the CLI)."""


def save_figure(fig: Any, path: Path) -> Path:
    """Save a :class:`~matplotlib.figure.Figure` with the Agg canvas (no display needed).

    A PNG under the default save settings is drawn once and written as ``savefig`` writes
    it (the same bytes): ``savefig`` draws a figure with a layout engine twice, once to lay
    it out and again to render it, 15 % of a run report's time.
    """
    canvas = FigureCanvasAgg(fig)
    with warnings.catch_warnings():
        # a title longer than the figure (a long file name) leaves the layout engine no
        # room: the figure is still drawn, only not laid out; not worth a raw warning
        warnings.filterwarnings("ignore", message="constrained_layout not applied",
                                category=UserWarning)
        if path.suffix.lower() == ".png" and _default_save_settings(fig):
            import matplotlib.image

            canvas.draw()
            matplotlib.image.imsave(path, canvas.buffer_rgba(), format="png",
                                    origin="upper", dpi=fig.dpi)
            return path
        fig.savefig(path)
    return path


def _default_save_settings(fig: Any) -> bool:
    """True when ``savefig`` would render ``fig`` as drawn on its canvas: no tight bounding
    box, the figure's own resolution and colours, not transparent."""
    from matplotlib import rcParams

    return (rcParams["savefig.bbox"] in (None, "standard")
            and rcParams["savefig.dpi"] in ("figure", fig.dpi)
            and rcParams["savefig.facecolor"] == "auto"
            and rcParams["savefig.edgecolor"] == "auto"
            and not rcParams["savefig.transparent"])


def make_report(run_dir: str | Path, fmt: str = "png", say: Say = quiet,
                run_with: Any = None) -> Report:
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
    say
        Called with a line before each step that can take seconds.
    run_with
        For a batch directory: what writes the ranked flights' own reports
        (:data:`etsid.report.parallel.Runner`; default: this process).

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

        return make_gap_report(run_dir, fmt, say)
    from etsid.report.control import is_control_run, make_control_report
    from etsid.report.fleet import is_batch_dir, make_fleet_report

    if is_batch_dir(run_dir):  # a directory written by etsid batch: the fleet report
        return make_fleet_report(run_dir, fmt, say, run_with)
    if is_control_run(run_dir):  # written by ``etsid control``
        return make_control_report(run_dir, fmt, say)
    try:
        run = read_run(run_dir)
    except IdentError as err:
        raise ReportError(str(err)) from err
    out = Path(run_dir) / "report"
    try:
        staging = Path(tempfile.mkdtemp(prefix=".report-", dir=Path(run_dir)))
        make_shared_dir(staging)
    except OSError as err:
        raise ReportError(f"{run_dir}: cannot write a report there "
                          f"({err.strerror or err})") from err
    try:
        report = _write(run, staging, fmt, say, Path(run_dir).resolve().parent)
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


def _write(run: Run, out: Path, fmt: str, say: Say = quiet, base: Path | None = None
           ) -> Report:
    """Every figure, index.html and report.md of ``run`` into ``out`` (``base``: the
    directory holding RUN_DIR, where a relative input path may also be found)."""
    report = Report(out)
    embedded: dict[str, tuple[str, str]] = {}
    count = len(FIGURES)
    for i, (name, (builder, caption)) in enumerate(FIGURES.items(), start=1):
        say(f"report: drawing static figure {i}/{count}, {name}.{fmt} …")
        fig = _build(builder, run, caption)
        report.figures[name] = save_figure(fig, out / f"{name}.{fmt}")
        if fmt == "png":
            embedded[name] = ("image/png", base64.b64encode(
                read_bytes(report.figures[name], "figure", ReportError)).decode())
        elif fmt == "svg":
            embedded[name] = ("image/svg+xml", base64.b64encode(
                read_bytes(report.figures[name], "figure", ReportError)).decode())
        else:
            png = save_figure(fig, out / f"{name}.png")
            embedded[name] = ("image/png", base64.b64encode(
                read_bytes(png, "figure", ReportError)).decode())
    rules = rules_text(run)
    report.html = out / "index.html"
    report.html.write_text(render_html(run, embedded, rules,
                                       interactive_parts(run, say, base)))
    report.markdown = out / "report.md"
    report.markdown.write_text(markdown_safe(render_markdown(run, report.figures, rules)))
    return report


def interactive_parts(run: Run, say: Say = quiet, base: Path | None = None
                      ) -> tuple[str, dict[str, str], list[str]]:
    """(head, {section: div}, notes) of the interactive plots of ``run`` (``base``: see
    :func:`etsid.report.overview.read_flight`)."""
    from etsid.report import interactive as ia
    from etsid.report.overview import read_flight
    from etsid.report.run_plots import (
        online_plots,
        overview_plots,
        structure_plots,
        validation_plots,
    )

    source = (run.config.get("input") or {}).get("path")
    say(f"report: reading {source} again for the flight overview …" if source else
        "report: building the interactive plots …")
    flight = read_flight(run, base)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = run.predictions["t"].to_numpy(dtype=float)
        # one linked time range per section: each section is drawn on its own
        builders = {"overview": lambda: overview_plots(run, flight, ia.shared_range(t)),
                    "validation": lambda: validation_plots(run),
                    "online": lambda: online_plots(run, ia.shared_range(t)),
                    "structure": lambda: structure_plots(run, ia.shared_range(t))}
        groups: dict[str, Any] = {}
        for i, (name, build_section) in enumerate(builders.items(), start=1):
            say(f"report: building the interactive plots, section {i}/{len(builders)} "
                f"({name}) …")
            groups[name] = build_section()
    say("report: writing index.html (the plots embedded) …")
    head, divs = ia.embed({k: ia.column(*v) for k, v in groups.items() if v})
    return head, divs, flight.notes


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
        rule_counts(met["rules"]).capitalize() + ".",
    ]
    merged = merges_text(met["rules"], run.rules, val.get("n_learn"))
    if merged:
        lines.append(merged[0].upper() + merged[1:] + ".")
    if val.get("t_start") is not None:
        lines.append(f"Validation: last {val.get('n_validation')} samples from "
                     f"t = {val['t_start']:.2f} s, learned on the first {val.get('n_learn')}.")
    lines.extend(str(n) for n in model.get("notes") or [])
    lines.extend(f"Note: {w}" for w in cfg.get("warnings") or [])
    return lines


def headline(run: Run) -> str:
    """One sentence of the held-out free-run fits, eTS against ARX, per output."""
    parts = []
    for y, m in (run.metrics.get("outputs") or {}).items():
        ets = (((m or {}).get("validation") or {}).get("free_run") or {}).get("fit")
        arx = (((((m or {}).get("arx") or {}).get("validation") or {}).get("free_run"))
               or {}).get("fit")
        if isinstance(ets, float) and isinstance(arx, float):
            parts.append(f"{y} {ets:.1f} vs {arx:.1f} %")
    if not parts:
        return ""
    return ("Held-out free-run fit, eTS vs ARX (same regressors): " + ", ".join(parts)
            + ". The error panels under each rate show where the two differ.")


def rules_section(run: Run) -> list[str]:
    """The consequents as a flight engineer reads them: per rule (numbered as in the
    tables) its focal point in physical units and the dominant terms of each output."""
    from etsid.errors import EtsidError
    from etsid.report.rulebook import physical, summarize

    try:
        summaries = summarize(run.rules, trusted=True)
    except (EtsidError, ValueError, KeyError, TypeError, IndexError, AttributeError) as err:
        return [f"<p>Rule base not readable: {esc(repr(err))}</p>"]
    if not summaries:
        return []
    regimes = {int(r["rule"]): r.get("regime") or "" for r in
               ((run.metrics.get("regimes") or {}).get("rules") or [])}
    outputs = list(summaries[0].terms)
    gains = _own_input_gains(run, outputs)
    head = ["rule", "focal point", "regime",
            *(f"{y}: gain of {gains[y]['term']}" for y in outputs if y in gains),
            *(f"{y}: dominant terms (share)" for y in outputs)]
    rows = []
    for rule in summaries:
        focal = ", ".join(physical(n, v) for n, v in list(rule.focal.items())[:3])
        per_rule = [gains[y]["per_rule"] for y in outputs if y in gains]
        rows.append([f"Rule {rule.number}", focal, regimes.get(rule.number, ""),
                     *(f"{g[rule.number - 1]:.3g}" if rule.number <= len(g) else "–"
                       for g in per_rule),
                     *("; ".join(f"{t.coefficient:+.3g}·{t.name} ({100 * t.share:.0f} %)"
                                 for t in rule.terms[y][:4]) for y in outputs)])
    return ['<h2 id="rules">Rules: where they fire and what dominates them</h2>',
            "<p>Gain: the coefficient of the rate's own command at its shortest lag, the "
            "response one sample after a unit command (what the regime sentence compares). "
            "Share = |θ| × the input's learnt range over the sum of all terms: the part "
            "of the output's swing a term can cause. All rules are listed, numbered as in "
            "the tables above and in <code>etsid rules</code>.</p>",
            table_html(head, rows, text_columns=range(1, len(head)))]


OWN_INPUT = {"p": "u_roll", "q": "u_pitch", "r": "u_yaw"}
"""The command of each body rate (its input gain is the rule's physical number)."""


def _own_input_gains(run: Run, outputs: list[str]) -> dict[str, dict[str, Any]]:
    """metrics.json ``regimes.gains`` entry of each output's own command (u_roll for p …):
    per rule the coefficient of its shortest lag, the response one sample after a unit
    command."""
    entries = ((run.metrics.get("regimes") or {}).get("gains") or []) \
        if isinstance(run.metrics, dict) else []
    out = {}
    for entry in entries:
        y = entry.get("output")
        if y in outputs and entry.get("input") == OWN_INPUT.get(y) and entry.get("per_rule"):
            out[y] = entry
    return out


def render_html(run: Run, images: dict[str, tuple[str, str]], rules: str,
                interactive: tuple[str, dict[str, str], list[str]] | None = None) -> str:
    """A self-contained HTML page: interactive plots (Bokeh, inlined), tables, the static
    figures as data URIs; nothing is fetched from the network."""
    head_js, divs, notes = interactive or ("", {}, [])
    head, rows = metrics_rows(run)
    lead = headline(run)
    facts = summary_lines(run)
    key, more = facts[:4], facts[4:]
    if key and len(key[0]) > 160:  # the regressor list: in full under "more"
        more.insert(0, key[0])
        outputs = ", ".join((run.config.get("model") or {}).get("outputs") or [])
        key[0] = f"Outputs: {outputs}; regressors: see below."
    body = [f'<p class="lead">{esc(lead)}</p>' if lead else "",
            "<ul>" + "".join(f"<li>{esc(s)}</li>" for s in key) + "</ul>"]
    if more:
        body.append(f"<details><summary>Model choices and data notes ({len(more)})</summary>"
                    "<ul>" + "".join(f"<li>{esc(s)}</li>" for s in more) + "</ul></details>")
    body.append(f'<p class="hint">{esc(HINT)}</p>' if divs else "")
    sections = [
        ("overview", "Flight overview",
         "Altitude shaded by the leading rule, thrust command, loop commands (sticks) and "
         "the rule that leads; the yellow band is the held-out validation part, the dashed "
         "line the moment the model was frozen."),
        ("validation", "Held-out part: eTS against ARX in free run",
         "Measured (black, on top), eTS frozen one-step (thin blue), eTS free run (red "
         "dashed), ARX free run (green dashed); under each rate the free-run errors."),
        ("online", "Whole flight: online one-step prediction (predict, then learn)", ""),
        ("structure", "Rule-base evolution", ""),
    ]
    for key, title, text in sections[:2]:
        body += _section(key, title, text, divs)
    body += [*(f"<p>{esc(n)}</p>" for n in notes),
             '<h2 id="metrics">Metrics</h2>',
             "<p>RMSE in the output's unit; NDEI = RMSE / std(y); VAF and fit (NRMSE, as "
             "MATLAB's compare) in %. σ is the sensor noise when the data knows it (the floor "
             "of a one-step RMSE).</p>", table_html(head, rows),
             *regimes_html(run), *rules_section(run)]
    for key, title, text in sections[2:]:
        body += _section(key, title, text, divs)
    body.append('<h2 id="figures">Figures for papers</h2><p>The same content as static '
                "figures; the files lie beside this page.</p><details><summary>show the "
                "static figures</summary>")
    for name, (_, caption) in FIGURES.items():
        if name in images:
            mime, data = images[name]
            body.append(f'<figure id="{name}"><img alt="{esc(name)}" '
                        f'src="data:{mime};base64,{data}"><figcaption>{esc(caption)}'
                        "</figcaption></figure>")
    body += ["</details>",
             "<details><summary>Rule base, every term (rules.json)</summary>"
             f"<pre>{esc(rules)}</pre></details>",
             "<details><summary>Configuration and provenance (config.json)</summary>"
             f"<pre>{esc(json.dumps(run.config, indent=2))}</pre></details>"]
    return html_page(_title(run), body, head_js)


def _section(key: str, title: str, text: str, divs: dict[str, str]) -> list[str]:
    if key not in divs:
        return []
    return [f'<h2 id="{key}">{esc(title)}</h2>', f"<p>{esc(text)}</p>" if text else "",
            divs[key]]


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
