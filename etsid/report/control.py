"""Report of a control RUN_DIR (``etsid control``): the chapter's Fig. 1.12 a–c and the thrust.

Reads the files only (flight.parquet, metrics.json, config.json, history.parquet,
events.parquet, rules.json; see :mod:`etsid.control.rundir`), so it needs nothing of
the control package. Writes RUN_DIR/report/: ``tracking``, ``thrust`` and, for the eTS
controller, ``potential`` and ``replacements`` figures, ``index.html`` and ``report.md``.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from etsid.errors import ControlError
from etsid.report.figures import WIDTH, style

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
        return json.loads(cfg.read_text()).get("kind") == CONTROL_KIND
    except (OSError, ValueError, AttributeError):
        return False


def read_control_run(run_dir: str | Path) -> ControlRun:
    """Read a control RUN_DIR; :class:`~etsid.errors.ControlError` names a missing/broken file."""
    from etsid.table import load_table

    path = Path(run_dir)

    def _json(name: str) -> dict[str, Any]:
        try:
            data = json.loads((path / name).read_text())
        except FileNotFoundError:
            raise ControlError(f"{path}: no {name}; not a control run directory") from None
        except (OSError, ValueError) as err:
            raise ControlError(f"{path / name}: not readable JSON ({err})") from err
        if not isinstance(data, dict):
            raise ControlError(f"{path / name}: expected a JSON object")
        return data

    def _frame(name: str) -> pd.DataFrame | None:
        file = path / name
        if not file.exists():
            return None
        try:
            return pd.read_parquet(file)
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


# ---------------------------------------------------------------------- figures
def _title(run: ControlRun) -> str:
    return (f"{run.metrics.get('controller', '?')} controller, scenario "
            f"{run.metrics.get('scenario', '?')}")


def _mark_mass_change(ax: Any, run: ControlRun) -> None:
    change = (run.config.get("scenario") or {}).get("mass_change")
    if change:
        ax.axvline(change[0], color="tab:purple", lw=0.8, ls="--", label="payload added")


def fig_tracking(run: ControlRun) -> Figure:
    """Fig. 1.12a: reference and flown height, and the tracking error."""
    f = run.flight
    t = f.index.to_numpy()
    fig = Figure(figsize=(WIDTH, 4.2))
    ax, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(t, f["alt_ref"], color="0.2", ls="--", label="reference r")
    ax.plot(t, f["true_alt"], color="tab:blue", label="height h (true)")
    _mark_mass_change(ax, run)
    ax.set_ylabel("height above ground, m")
    ax.legend(loc="upper right", ncol=3)
    ax.set_title(f"Tracking — {_title(run)}")
    err = f["alt_ref"] - f["true_alt"]
    ax2.plot(t, err, color="tab:red")
    after = run.metrics.get("score_after_s", 10.0)
    ax2.axvspan(t[0], after, color="0.9", label=f"first {after:g} s (not scored)")
    rmse = run.metrics.get("tracking_rmse")
    ax2.set_ylabel("r − h, m")
    ax2.set_xlabel("time, s")
    if rmse is not None:
        ax2.set_title(f"tracking RMSE after {after:g} s: {rmse:.4f} m", fontsize=8)
    ax2.legend(loc="upper right")
    return fig


def fig_potential(run: ControlRun) -> Figure:
    """Fig. 1.12b: the sample potential between the running bounds P_max and P_min."""
    h = run.history
    fig = Figure(figsize=(WIDTH, 3.2))
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
    ax.legend(loc="lower right", ncol=3)
    return fig


def fig_replacements(run: ControlRun) -> Figure:
    """Fig. 1.12c: cumulative rule replacements (and births, and the rule count)."""
    h = run.history
    fig = Figure(figsize=(WIDTH, 3.0))
    ax = fig.subplots()
    ax.step(h["t"], h["replacements"], where="post", color="tab:orange",
            label="rule replacements (cumulative)")
    ax.step(h["t"], h["births"], where="post", color="tab:green", label="rule births (cumulative)")
    ax.step(h["t"], h["n_rules"], where="post", color="0.3", ls=":", label="rules")
    _mark_mass_change(ax, run)
    ax.set_ylabel("count")
    ax.set_xlabel("time, s")
    ax.set_title("Evolution of the rule base")
    ax.legend(loc="upper left")
    return fig


def fig_thrust(run: ControlRun) -> Figure:
    """The collective command and its feed-forward and feedback parts."""
    f = run.flight
    t = f.index.to_numpy()
    fig = Figure(figsize=(WIDTH, 3.2))
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
    ax.legend(loc="center right", ncol=3)
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


def make_control_report(run_dir: str | Path, fmt: str = "png") -> Report:
    """Write RUN_DIR/report/ for a control run: figures, index.html, report.md."""
    from etsid.report.build import FORMATS, Report, save_figure

    if fmt not in FORMATS:
        raise ControlError(f"unknown figure format {fmt!r}; use one of {', '.join(FORMATS)}")
    run = read_control_run(run_dir)
    out = run.path / "report"
    out.mkdir(exist_ok=True)
    figures: dict[str, Path] = {}
    embedded: dict[str, str] = {}
    with style():
        for name, (builder, _, needs_history) in CONTROL_FIGURES.items():
            if needs_history and run.history is None:
                continue
            fig = builder(run)
            figures[name] = save_figure(fig, out / f"{name}.{fmt}")
            png = figures[name] if fmt == "png" else save_figure(fig, out / f"{name}.png")
            embedded[name] = base64.b64encode(png.read_bytes()).decode()
    rows = _metric_rows(run)
    rules = _rules_text(run)
    title = f"etsid control: {_title(run)}"
    esc = html.escape
    page = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(title)}</title>",
        "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em}"
        "td,th{border:1px solid #bbb;padding:2px 6px}table{border-collapse:collapse}"
        "img{max-width:100%}pre{background:#f6f6f6;padding:.6em;font-size:85%}</style>",
        "</head><body>", f"<h1>{esc(title)}</h1>", "<table>",
        *(f"<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>" for k, v in rows), "</table>",
    ]
    for name, data in embedded.items():
        caption = CONTROL_FIGURES[name][1]
        page.append(f'<figure id="{name}"><img alt="{esc(name)}" '
                    f'src="data:image/png;base64,{data}"><figcaption>{esc(caption)}'
                    "</figcaption></figure>")
    page += ["<h2>Rule base (rules.json)</h2>", f"<pre>{esc(rules)}</pre>",
             "<h2>Configuration (config.json)</h2>",
             f"<pre>{esc(json.dumps(run.config, indent=2))}</pre>", "</body></html>"]
    html_path = out / "index.html"
    html_path.write_text("\n".join(page) + "\n")
    md = [f"# {title}", "", "| metric | value |", "|---|---|"]
    md += [f"| {k} | {v} |" for k, v in rows]
    md.append("")
    for name, path in figures.items():
        md += [f"![{CONTROL_FIGURES[name][1]}]({path.name})", "",
               f"*{CONTROL_FIGURES[name][1]}*", ""]
    md += ["## Rule base (rules.json)", "", "```", rules, "```", ""]
    md_path = out / "report.md"
    md_path.write_text("\n".join(md))
    return Report(out, figures, html_path, md_path)
