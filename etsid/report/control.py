"""Report of a control RUN_DIR (``etsid control``): the chapter's Fig. 1.12 a–c and the thrust.

Reads the files only (flight.parquet, metrics.json, config.json, history.parquet,
events.parquet, rules.json; see :mod:`etsid.control.rundir`), so it needs nothing of
the control package. Writes RUN_DIR/report/: ``tracking``, ``thrust`` and, for the eTS
controller, ``potential`` and ``replacements`` figures, ``index.html`` and ``report.md``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from etsid.errors import ControlError
from etsid.escape import clean
from etsid.files import read_json, read_parquet_frame
from etsid.report.figures import WIDTH, legend_outside, style

if TYPE_CHECKING:  # pragma: no cover
    from etsid.report.build import Report

CONTROL_KIND = "control"


@dataclass
class ControlRun:
    """A control RUN_DIR in memory."""

    path: Path
    flight: pd.DataFrame
    metrics: dict[str, Any]
    config: dict[str, Any]
    history: pd.DataFrame | None
    events: pd.DataFrame | None
    rules: dict[str, Any] | None


def is_control_run(run_dir: str | Path) -> bool:
    """True if ``run_dir`` holds a control run (config.json with ``"kind": "control"``)."""
    cfg = Path(run_dir) / "config.json"
    if not cfg.is_file():
        return False
    try:
        data = read_json(cfg, "run", ControlError)
    except ControlError:
        return False
    return isinstance(data, dict) and data.get("kind") == CONTROL_KIND


def read_control_run(run_dir: str | Path) -> ControlRun:
    """Read a control RUN_DIR; :class:`~etsid.errors.ControlError` names a missing/broken file."""
    from etsid.table import load_table

    path = Path(run_dir)

    def _json(name: str) -> dict[str, Any]:
        if not (path / name).exists():
            raise ControlError(f"{path}: no {name}; not a control run directory")
        data = clean(read_json(path / name, "run", ControlError))
        if not isinstance(data, dict):
            raise ControlError(f"{path / name}: expected a JSON object")
        return data

    def _frame(name: str) -> pd.DataFrame | None:
        file = path / name
        if not file.exists():
            return None
        try:
            return read_parquet_frame(file, "table", ControlError)
        except ControlError:
            raise
        except Exception as err:  # pyarrow raises many types for broken files
            raise ControlError(f"{file}: not a readable parquet file ({err})") from err

    config = _json("config.json")
    metrics = _json("metrics.json")
    if not (path / "flight.parquet").exists():
        raise ControlError(f"{path}: no flight.parquet; not a control run directory")
    flight = load_table(path / "flight.parquet")
    missing = {"alt_ref", "true_alt", "u_thrust"} - set(flight.columns)
    if missing:
        raise ControlError(f"{path / 'flight.parquet'}: missing column(s) "
                           f"{', '.join(sorted(missing))}")
    rules = _json("rules.json") if (path / "rules.json").exists() else None
    return ControlRun(path, flight, metrics, config, _frame("history.parquet"),
                      _frame("events.parquet"), rules)


def find_comparison(run: ControlRun) -> ControlRun | None:
    """The run of the same scenario by the other controller beside ``run`` (a sibling
    directory, as ``etsid control SCENARIO --controller pid`` names it next to the eTS run),
    the newest if there are several; None when there is none."""
    me = run.metrics.get("controller")
    scenario = run.metrics.get("scenario")
    found = []
    try:
        siblings = [p for p in run.path.resolve().parent.iterdir() if p.is_dir()]
    except OSError:
        return None
    for path in siblings:
        if path.resolve() == run.path.resolve() or not is_control_run(path):
            continue
        try:
            metrics = read_json(path / "metrics.json", "run", ControlError)
        except ControlError:
            continue
        if (isinstance(metrics, dict) and metrics.get("scenario") == scenario
                and metrics.get("controller") not in (None, me)):
            found.append((path.stat().st_mtime, path))
    for _, path in sorted(found, reverse=True):
        try:
            return read_control_run(path)
        except ControlError:
            continue
    return None


# ---------------------------------------------------------------------- figures
def _title(run: ControlRun) -> str:
    return (f"{run.metrics.get('controller', '?')} controller, scenario "
            f"{run.metrics.get('scenario', '?')}")


def _mark_mass_change(ax: Any, run: ControlRun) -> None:
    change = (run.config.get("scenario") or {}).get("mass_change")
    if change:
        ax.axvline(change[0], color="tab:purple", lw=0.8, ls="--", label="payload added")


def fig_tracking(run: ControlRun, other: ControlRun | None = None) -> Figure:
    """Fig. 1.12a: reference and flown height (and the other controller's, when given), and
    the tracking errors. The reference is wide and pale, under the heights; this run's
    height is solid and the other's dashed on top, so none hides another where they
    coincide. Legends sit outside the plot area."""
    f = run.flight
    t = f.index.to_numpy()
    fig = Figure(figsize=(WIDTH, 4.2), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    name = run.metrics.get("controller", "?")
    ax.plot(t, f["alt_ref"], color="tab:orange", lw=4.0, alpha=0.35, zorder=1,
            label="reference r")
    ax.plot(t, f["true_alt"], color="tab:blue", lw=1.4, alpha=0.85, zorder=2,
            label=f"height h, {name}")
    if other is not None:
        ax.plot(other.flight.index.to_numpy(), other.flight["true_alt"], color="tab:green",
                lw=1.1, ls="--", zorder=3,
                label=f"height h, {other.metrics.get('controller', '?')}")
    _mark_mass_change(ax, run)
    ax.set_ylabel("height above ground, m")
    legend_outside(ax)
    ax.set_title(f"Tracking — {_title(run)}")
    ax2.plot(t, f["alt_ref"] - f["true_alt"], color="tab:blue", lw=0.9, alpha=0.85,
             label=name)
    if other is not None:
        o = other.flight
        ax2.plot(o.index.to_numpy(), o["alt_ref"] - o["true_alt"], color="tab:green", lw=0.9,
                 ls="--", label=str(other.metrics.get("controller", "?")))
    after = run.metrics.get("score_after_s", 10.0)
    ax2.axvspan(t[0], after, color="0.9", label=f"first {after:g} s (not scored)")
    rmse = run.metrics.get("tracking_rmse")
    ax2.set_ylabel("r − h, m")
    ax2.set_xlabel("time, s")
    if rmse is not None:
        text = f"tracking RMSE after {after:g} s: {name} {rmse:.4f} m"
        if other is not None and other.metrics.get("tracking_rmse") is not None:
            text += (f", {other.metrics.get('controller')} "
                     f"{other.metrics['tracking_rmse']:.4f} m")
        ax2.set_title(text, fontsize=8)
    ax2.yaxis.set_major_locator(MaxNLocator(nbins=3))  # small panel: no overlap
    legend_outside(ax2)
    return fig


def fig_potential(run: ControlRun) -> Figure:
    """Fig. 1.12b: the sample potential between the running bounds P_max and P_min."""
    h = run.history
    fig = Figure(figsize=(WIDTH, 3.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(h["t"], h["potential"], color="tab:blue", lw=0.6, label="P(z_k), sample")
    ax.plot(h["t"], h["focal_max"], color="tab:red", label="P_max (focal points)")
    ax.plot(h["t"], h["focal_min"], color="tab:green", label="P_min (focal points)")
    ev = run.events if run.events is not None else pd.DataFrame(columns=["t", "kind"])
    for kind, color, mark in (("birth", "tab:green", "^"), ("replace", "tab:orange", "o")):
        sel = ev[ev["kind"] == kind]
        if len(sel):
            pot = np.interp(sel["t"], h["t"], h["potential"])
            ax.plot(sel["t"], pot, mark, ms=3, color=color, label=f"rule {kind}")
    _mark_mass_change(ax, run)
    ax.set_ylabel("potential")
    ax.set_xlabel("time, s")
    ax.set_title("Potential of the data sample and its bounds (eTS structure test)")
    legend_outside(ax)
    return fig


def fig_replacements(run: ControlRun) -> Figure:
    """Fig. 1.12c: cumulative rule replacements (and births, and the rule count)."""
    h = run.history
    fig = Figure(figsize=(WIDTH, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.step(h["t"], h["replacements"], where="post", color="tab:orange",
            label="rule replacements (cumulative)")
    ax.step(h["t"], h["births"], where="post", color="tab:green", label="rule births (cumulative)")
    ax.step(h["t"], h["n_rules"], where="post", color="0.3", ls=":", label="rules")
    _mark_mass_change(ax, run)
    ax.set_ylabel("count")
    ax.set_xlabel("time, s")
    ax.set_title("Evolution of the rule base")
    legend_outside(ax)
    return fig


def fig_thrust(run: ControlRun) -> Figure:
    """The collective command and its feed-forward and feedback parts."""
    f = run.flight
    t = f.index.to_numpy()
    fig = Figure(figsize=(WIDTH, 3.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(t, f["u_thrust"], color="0.2", lw=0.6, label="u_thrust (sent)")
    if "u_ff" in f:
        ax.plot(t, f["u_ff"], color="tab:blue", label="feed-forward")
    if "u_fb" in f:
        ax.plot(t, f["u_fb"], color="tab:red", lw=0.6, label="feedback")
    _mark_mass_change(ax, run)
    ax.set_ylabel("collective, 0..1")
    ax.set_xlabel("time, s")
    ax.set_title("Thrust command")
    legend_outside(ax)
    return fig


CONTROL_FIGURES: dict[str, tuple[Callable[[ControlRun], Figure], str, bool]] = {
    "tracking": (fig_tracking, "Fig. 1.12a — altitude reference and flown height; error "
                 "below (true height, the first seconds learn from zero rules)", False),
    "potential": (fig_potential, "Fig. 1.12b — potential of each new data sample against "
                  "the running bounds P_max / P_min of the focal points", True),
    "replacements": (fig_replacements, "Fig. 1.12c — cumulative rule replacements and "
                     "births", True),
    "thrust": (fig_thrust, "Collective thrust command, with its feed-forward (hover "
               "thrust or learnt inverse) and feedback parts", False),
}
"""name → (builder, caption, needs the eTS history)."""


# ---------------------------------------------------------------------- pages
def _metric_rows(run: ControlRun) -> list[tuple[str, str]]:
    m = run.metrics

    def fmt(v: Any, unit: str = "") -> str:
        if v is None:
            return "—"
        if isinstance(v, float):
            return f"{v:.4g}{unit}"
        if isinstance(v, list):
            return ", ".join(fmt(x) for x in v) + unit
        return f"{v}{unit}"

    rows = [("controller", fmt(m.get("controller"))), ("scenario", fmt(m.get("scenario"))),
            ("stable", fmt(m.get("stable"))),
            (f"tracking RMSE after {m.get('score_after_s', 10):g} s", fmt(
                m.get("tracking_rmse"), " m")),
            ("max error (scored part)", fmt(m.get("max_error"), " m")),
            ("max error (whole flight)", fmt(m.get("max_error_all"), " m")),
            ("control effort (RMS du/dt)", fmt(m.get("control_effort"), " 1/s"))]
    if m.get("settling_time") is not None:
        rows.append(("settling times", fmt(m.get("settling_time"), " s")))
    rows += [("rules (final)", fmt(m.get("rules_final"))),
             ("rule births", fmt(m.get("rule_births"))),
             ("rule replacements", fmt(m.get("rule_replacements")))]
    timing = m.get("timing") or {}
    if timing:
        rows.append(("controller time per step", fmt(timing.get("controller_us_per_step"),
                                                      " µs")))
    return rows


def _rules_text(run: ControlRun) -> str:
    if run.rules is None:
        return "(no rule base: PID controller)"
    from etsid.ets import ETS

    return ETS.from_dict(run.rules).rules()


def _interactive(run: ControlRun, other: ControlRun | None) -> tuple[str, dict[str, str]]:
    """Linked time series: reference and heights, tracking errors, thrust, rule count."""
    from etsid.report import interactive as ia

    runs = [run] + ([other] if other is not None else [])
    colors = [ia.COLORS["one_step"], ia.COLORS["arx"]]
    # this run solid under, the run beside it dashed on top: where the two coincide (the
    # thrust of eTS and PID in steady flight) both stay visible
    dashes, alphas = ["solid", "dashed"], [0.85, 1.0]
    t0 = run.flight.index.to_numpy(dtype=float)
    x_range = ia.shared_range(t0)
    track = ia.time_figure("height above ground (m)", "Reference and flown height (true)",
                           x_range, height=260)
    err = ia.time_figure("r − h (m)", "Tracking error", x_range, height=170)
    thrust = ia.time_figure("collective (0…1)", "Thrust command", x_range, height=170)
    for k, r in enumerate(runs):
        f = r.flight
        name = str(r.metrics.get("controller", "?"))
        src = ia.source(f.index.to_numpy(dtype=float),
                        {"h": f["true_alt"].to_numpy(dtype=float),
                         "ref": f["alt_ref"].to_numpy(dtype=float),
                         "e": (f["alt_ref"] - f["true_alt"]).to_numpy(dtype=float),
                         "u": f["u_thrust"].to_numpy(dtype=float)})
        track_lines = [ia.Line("h", f"height, {name}", colors[k], 1.8 if k == 0 else 1.4,
                               dashes[k], alphas[k])]
        if k == 0:  # the reference first, wide and pale: under the heights that track it
            track_lines.insert(0, ia.Line("ref", "reference r", ia.COLORS["reference"], 4.0,
                                          "solid", 0.35))
        ia.add_lines(track, src, track_lines, digits="0.000", unit="m")
        rmse = r.metrics.get("tracking_rmse")
        label = name + (f" (RMSE {rmse:.4f} m after {r.metrics.get('score_after_s', 10):g} s)"
                        if rmse is not None else "")
        ia.add_lines(err, src, [ia.Line("e", label, colors[k], 1.2, dashes[k], alphas[k])],
                     digits="0.0000", unit="m")
        ia.add_lines(thrust, src, [ia.Line("u", f"u_thrust, {name}", colors[k], 1.2,
                                           dashes[k], alphas[k])], digits="0.000")
    after = float(run.metrics.get("score_after_s", 10.0))
    for fig in (track, err, thrust):
        ia.shade(fig, float(t0[0]), after, "#888888", 0.12)
        change = (run.config.get("scenario") or {}).get("mass_change")
        if change:
            ia.mark(fig, float(change[0]), "#9467bd")
    figs = [track, err, thrust]
    hist = next((r.history for r in runs if r.history is not None and len(r.history)), None)
    if hist is not None:
        count = ia.time_figure("count", "eTS rule base: rules and cumulative replacements",
                               x_range, height=170)
        src = ia.source(hist["t"].to_numpy(dtype=float),
                        {c: hist[c].to_numpy(dtype=float)
                         for c in ("n_rules", "replacements", "births") if c in hist})
        ia.add_lines(count, src, [ia.Line("n_rules", "rules", "#222222", 1.5),
                                  ia.Line("replacements", "replacements (cumulative)",
                                          "#ff7f0e", 1.2)], digits="0")
        ia.integer_axis(count)
        figs.append(count)
    return ia.embed({"tracking": ia.column(*figs)})


def make_control_report(run_dir: str | Path, fmt: str = "png",
                        say: Callable[[str], None] | None = None) -> Report:
    """Write RUN_DIR/report/ for a control run: figures, index.html, report.md. The run of
    the same scenario by the other controller, when it lies beside RUN_DIR, is drawn with
    it (:func:`find_comparison`)."""
    from etsid.report.build import FORMATS, Report, save_figure
    from etsid.report.page import (
        HINT,
        esc,
        html_page,
        image_html,
        make_shared_dir,
        markdown_safe,
    )

    if fmt not in FORMATS:
        raise ControlError(f"unknown figure format {fmt!r}; use one of {', '.join(FORMATS)}")
    say = say or (lambda _: None)
    run = read_control_run(run_dir)
    other = find_comparison(run)
    out = run.path / "report"
    out.mkdir(exist_ok=True)
    make_shared_dir(out)
    figures: dict[str, Path] = {}
    shown: dict[str, Path] = {}
    say(f"control report: drawing the figures into {out}/ …")
    with style():
        for name, (builder, _, needs_history) in CONTROL_FIGURES.items():
            if needs_history and run.history is None:
                continue
            fig = fig_tracking(run, other) if name == "tracking" else builder(run)
            figures[name] = save_figure(fig, out / f"{name}.{fmt}")
            shown[name] = (figures[name] if fmt != "pdf"
                           else save_figure(fig, out / f"{name}.png"))
    head_js, divs = _interactive(run, other)
    rows = _metric_rows(run)
    other_rows = dict(_metric_rows(other)) if other is not None else {}
    rules = _rules_text(run)
    title = f"etsid control: {_title(run)}"
    me = str(run.metrics.get("controller", "?"))
    body = []
    lead = _lead(run, other)
    if lead:
        body.append(f'<p class="lead">{esc(lead)}</p>')
    if other is not None:
        rel = Path(os.path.relpath(other.path, run.path)).as_posix()
        body.append(f"<p>Beside it: the {esc(other.metrics.get('controller'))} run of the same "
                    f"scenario in <code>{esc(rel)}</code>.</p>")
    else:
        twin = "pid" if me == "ets" else "ets"
        scenario = run.metrics.get("scenario", "SCENARIO")
        body.append(f"<p>No {twin} run of this scenario beside this one: <code>etsid control "
                    f"{esc(scenario)} --controller {twin} --out "
                    f"{esc(run.path.parent / f'control-{scenario}-{twin}')}</code> then "
                    f"<code>etsid report {esc(run.path)}</code> draws the two together.</p>")
    body += ['<h2 id="tracking">Tracking</h2>', f'<p class="hint">{esc(HINT)}</p>',
             "<p>Reference: the wide pale orange band under the heights; this run solid, "
             "the run beside it dashed on top; grey: the first seconds, not scored (the "
             "eTS controller starts from zero rules).</p>", divs.get("tracking", "")]
    head = ["metric", me] + ([str(other.metrics.get("controller"))] if other else [])
    body += ['<h2 id="metrics">Metrics</h2>',
             _table(head, [[k, v] + ([other_rows.get(k, "—")] if other else [])
                           for k, v in rows])]
    body.append('<h2 id="figures">Figures for papers</h2>')
    body += [image_html(path, name, CONTROL_FIGURES[name][1]) for name, path in shown.items()]
    body += ["<h2>Rule base (rules.json)</h2>", f"<pre>{esc(rules)}</pre>",
             "<details><summary>Configuration (config.json)</summary>"
             f"<pre>{esc(json.dumps(run.config, indent=2))}</pre></details>"]
    html_path = out / "index.html"
    html_path.write_text(html_page(title, body, head_js))
    md = [f"# {title}", ""]
    if lead:
        md += [lead, ""]
    md += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    md += ["| " + " | ".join([k, v] + ([other_rows.get(k, "—")] if other else [])) + " |"
           for k, v in rows]
    md.append("")
    for name, path in figures.items():
        md += [f"![{CONTROL_FIGURES[name][1]}]({path.name})", "",
               f"*{CONTROL_FIGURES[name][1]}*", ""]
    md += ["## Rule base (rules.json)", "", "```", rules, "```", ""]
    md_path = out / "report.md"
    md_path.write_text(markdown_safe("\n".join(md)))
    return Report(out, figures, html_path, md_path)


def _lead(run: ControlRun, other: ControlRun | None) -> str:
    m = run.metrics
    rmse = m.get("tracking_rmse")
    if rmse is None:
        return ""
    after = m.get("score_after_s", 10)
    text = f"Tracking RMSE after {after:g} s: {m.get('controller')} {rmse:.4f} m"
    if other is not None and other.metrics.get("tracking_rmse") is not None:
        text += f", {other.metrics.get('controller')} {other.metrics['tracking_rmse']:.4f} m"
    return text + "."


def _table(head: list[str], rows: list[list[str]]) -> str:
    from etsid.report.page import table_html

    return table_html(head, rows)
