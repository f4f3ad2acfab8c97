"""Report of a gap run (a directory holding gap.json): figures, report.md, index.html.

Figures, from ``gap_series.parquet``: the residual of the main mismatched channel against
the locating variable before and after the augmented model, and its time series with the
held-out part marked.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from etsid.errors import ReportError
from etsid.report.build import Report, save_figure

SERIES_FILE = "gap_series.parquet"
VAR_TEXT = {"alt": "height above ground (m)", "speed": "horizontal speed (m/s)",
            "thrust": "mean motor output", "command_rate": "motor command rate (1/s)",
            "vbat": "battery voltage (V)", "time": "time (s)"}


GAP_SCHEMA = "etsid.gap/1"
NEEDED = ("verdict", "summary", "effects", "rmse_before", "rmse_after", "noise", "units")


def read_gap_json(path: Path) -> dict[str, Any]:
    """A gap.json written by ``etsid gap`` (validated against its schema when written);
    checked here for the schema name and the keys the report uses."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise ReportError(f"{path}: cannot read gap.json ({err})") from err
    if not isinstance(data, dict) or data.get("schema") != GAP_SCHEMA:
        raise ReportError(f"{path}: not a gap.json of schema {GAP_SCHEMA}")
    missing = [k for k in NEEDED if k not in data]
    if missing:
        raise ReportError(f"{path}: gap.json lacks {', '.join(missing)}")
    return data


def is_gap_dir(path: str | Path) -> bool:
    """Whether ``path`` is a directory written by ``etsid gap``."""
    return (Path(path) / "gap.json").is_file()


def _main_channel(data: dict[str, Any]) -> str | None:
    if data.get("mismatch"):
        return str(data["mismatch"]["channels"][0])
    z = data.get("nominal", {}).get("z_all", {})
    return max(z, key=z.get) if z else None


def _residual_figure(series: pd.DataFrame, data: dict[str, Any], ch: str) -> Figure:
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    regime = (data.get("mismatch") or {}).get("regime", {})
    var = regime.get("variable") or "time"
    col = f"var_{var}" if f"var_{var}" in series else "var_time"
    hold = series["held_out"].to_numpy(bool)
    x = series[col].to_numpy()[hold]
    for kind, colour in (("nominal", "tab:red"), ("augmented", "tab:blue")):
        e = (series[ch] - series[f"{ch}_{kind}"]).to_numpy()[hold]
        ax.plot(x[::3], e[::3], ".", ms=2, alpha=0.35, color=colour,
                label=f"{'before' if kind == 'nominal' else 'after'} "
                      f"(RMSE {np.sqrt(np.mean(e**2)):.3g})")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel(VAR_TEXT.get(col[4:], col[4:]))
    ax.set_ylabel(f"{ch} residual ({data['units'].get(ch, '')})")
    ax.set_title(f"{ch}: residual on held-out data against the locating variable")
    ax.legend(markerscale=5, fontsize=8)
    return fig


def _time_figure(series: pd.DataFrame, data: dict[str, Any], ch: str) -> Figure:
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    t = series.index.to_numpy()
    air = series["airborne"].to_numpy(bool)
    ax.plot(t[air], series[ch].to_numpy()[air], ",", color="0.3", label="REAL (filtered)")
    ax.plot(t[air], series[f"{ch}_nominal"].to_numpy()[air], ",", color="tab:red",
            label="nominal model from SIM")
    ax.plot(t[air], series[f"{ch}_augmented"].to_numpy()[air], ",", color="tab:blue",
            label="augmented model")
    hold = series["held_out"].to_numpy(bool)
    if hold.any():
        ax.axvspan(t[hold][0], t[hold][-1], color="0.9", zorder=-1, label="held out")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{ch} ({data['units'].get(ch, '')})")
    ax.set_title(f"{ch}: before and after")
    ax.legend(fontsize=8, markerscale=20)
    return fig


def _value(p: dict[str, Any]) -> str:
    v = p["value"]
    if isinstance(v, str | list):
        return str(v)
    err = p.get("stderr")
    return f"{v:.4g}" + (f" ± {err:.2g}" if err else "")


def _markdown(data: dict[str, Any], figures: dict[str, Path]) -> str:
    lines = ["# Gap report: simulation vs recording", "", data["summary"], "",
             f"* SIM: `{data['sim']['file']}` ({data['sim']['airborne_s']} s airborne)",
             f"* REAL: `{data['real']['file']}` ({data['real']['airborne_s']} s airborne)",
             f"* Verdict: **{data['verdict']}** — {data['reason']}", ""]
    if data["effects"]:
        lines += ["## Effects", "", "| effect | parameters | confidence | evidence |",
                  "|---|---|---|---|"]
        for e in data["effects"]:
            ps = ", ".join(f"{k} = {_value(v)} {v['unit']}".strip()
                           for k, v in e["parameters"].items())
            lines.append(f"| {e['name']} | {ps} | {e['confidence']:.2f} | {e['evidence']} |")
        lines.append("")
    lines += ["## Held-out RMSE per channel", "", "| channel | SIM noise | before | after |",
              "|---|---|---|---|"]
    for c, b in data["rmse_before"].items():
        lines.append(f"| {c} ({data['units'].get(c, '')}) | {data['noise'].get(c, 0):.3g} | "
                     f"{b:.3g} | {data['rmse_after'].get(c, b):.3g} |")
    if data.get("notes"):
        lines += ["", "## Notes", ""] + [f"* {n}" for n in data["notes"]]
    lines += [""] + [f"![{k}]({p.name})" for k, p in figures.items()]
    return "\n".join(lines) + "\n"


def make_gap_report(out_dir: str | Path, fmt: str = "png") -> Report:
    """Write report.md, index.html and figures into a gap run directory.

    Raises
    ------
    ReportError
        The directory has no readable gap.json of schema ``etsid.gap/1``.
    """
    out = Path(out_dir)
    data = read_gap_json(out / "gap.json")
    report = Report(out)
    series_path = out / SERIES_FILE
    ch = _main_channel(data)
    if series_path.is_file() and ch is not None:
        try:
            series = pd.read_parquet(series_path)
        except (OSError, ValueError) as err:
            raise ReportError(f"{series_path}: cannot read ({err})") from err
        if ch in series:
            report.figures["gap_residual"] = save_figure(
                _residual_figure(series, data, ch), out / f"gap_residual.{fmt}")
            report.figures["gap_timeseries"] = save_figure(
                _time_figure(series, data, ch), out / f"gap_timeseries.{fmt}")
    md = _markdown(data, report.figures)
    report.markdown = out / "report.md"
    report.markdown.write_text(md, encoding="utf-8")
    body = [f"<h1>Gap report</h1><p>{html.escape(data['summary'])}</p>",
            "<pre>" + html.escape(md) + "</pre>"]
    for name, path in report.figures.items():
        if path.suffix == ".png":
            b64 = base64.b64encode(path.read_bytes()).decode()
            body.append(f'<img alt="{name}" src="data:image/png;base64,{b64}">')
    report.html = out / "index.html"
    report.html.write_text("<!doctype html><meta charset=utf-8><title>etsid gap</title>"
                           + "\n".join(body), encoding="utf-8")
    return report
