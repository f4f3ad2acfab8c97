"""Report of a gap run (a directory holding gap.json): figures, report.md, index.html.

Figures, from ``gap_series.parquet``: the residual of the main mismatched channel against
the locating variable before and after the augmented model, and its time series with the
held-out part marked.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from etsid.errors import ReportError
from etsid.escape import clean
from etsid.files import read_json, read_parquet_frame
from etsid.report.build import Report, save_figure
from etsid.report.page import markdown_safe
from etsid.schemas import validate

SERIES_FILE = "gap_series.parquet"
VAR_TEXT = {"alt": "height above ground (m)", "speed": "horizontal speed (m/s)",
            "thrust": "mean motor output", "command_rate": "motor command rate (1/s)",
            "vbat": "battery voltage (V)", "time": "time (s)"}


GAP_SCHEMA = "etsid.gap/1"
GAP_SCHEMA_PATH = Path(__file__).resolve().parents[1] / "gap" / "gap.schema.json"
"""The schema ``etsid gap`` validates gap.json with when writing it (a data file: the
report does not import the gap package)."""
NEEDED = ("verdict", "summary", "effects", "rmse_before", "rmse_after", "noise", "units")


def read_gap_json(path: Path) -> dict[str, Any]:
    """A gap.json written by ``etsid gap`` (validated against its schema when written);
    checked here for the schema name and the keys the report uses."""
    data = read_json(path, "gap", ReportError, "gap.json")
    if not isinstance(data, dict) or data.get("schema") != GAP_SCHEMA:
        raise ReportError(f"{path}: not a gap.json of schema {GAP_SCHEMA}")
    schema = read_json(GAP_SCHEMA_PATH, "package", ReportError)
    data = clean(validate(data, schema, path, ReportError, "gap.json"))
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


def _unit(unit: str | None) -> str:
    """A unit to print after a number: '' for the dimensionless "1"."""
    return "" if unit in (None, "", "1", "–", "-") else str(unit)


def _regime_mask(series: pd.DataFrame, data: dict[str, Any]) -> np.ndarray | None:
    """Rows inside the located regime (the range of its locating variable), or None."""
    regime = (data.get("mismatch") or {}).get("regime") or {}
    col = f"var_{regime.get('variable')}"
    rng = regime.get("range")
    if col not in series or not isinstance(rng, list) or len(rng) != 2:
        return None
    v = series[col].to_numpy(dtype=float)
    return (v >= float(rng[0])) & (v <= float(rng[1]))


def _residual_figure(series: pd.DataFrame, data: dict[str, Any], ch: str) -> Figure:
    from matplotlib.lines import Line2D

    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    regime = (data.get("mismatch") or {}).get("regime", {})
    var = regime.get("variable") or "time"
    col = f"var_{var}" if f"var_{var}" in series else "var_time"
    hold = series["held_out"].to_numpy(bool)
    x = series[col].to_numpy()[hold]
    handles = []
    for kind, colour in (("nominal", "tab:red"), ("augmented", "tab:blue")):
        e = (series[ch] - series[f"{ch}_{kind}"]).to_numpy()[hold]
        ax.plot(x[::3], e[::3], ".", ms=2, alpha=0.35, color=colour)
        label = (f"{'before' if kind == 'nominal' else 'after'} "
                 f"(RMSE {np.sqrt(np.nanmean(e**2)):.3g})")
        handles.append(Line2D([], [], color=colour, marker="o", ls="none", ms=6, label=label))
    rng = regime.get("range")
    if col != "var_time" and isinstance(rng, list) and len(rng) == 2:
        ax.axvspan(rng[0], rng[1], color="tab:orange", alpha=0.15, zorder=0)
        handles.append(Line2D([], [], color="tab:orange", alpha=0.4, lw=8,
                              label="located regime"))
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel(VAR_TEXT.get(col[4:], col[4:]))
    ax.set_ylabel(f"{ch} residual ({data['units'].get(ch, '')})")
    ax.set_title(f"{ch}: residual on held-out data against the locating variable")
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              borderaxespad=0.0, frameon=False)
    return fig


def _time_figure(series: pd.DataFrame, data: dict[str, Any], ch: str) -> Figure:
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    t = series.index.to_numpy(dtype=float)
    air = series["airborne"].to_numpy(bool)
    # REAL first, thin and grey (under): the augmented model that follows it stays visible
    for col, label, colour, lw, ls, alpha in (
            (ch, "REAL (filtered)", "0.45", 0.8, "-", 0.8),
            (f"{ch}_nominal", "nominal model from SIM", "tab:red", 1.0, "--", 1.0),
            (f"{ch}_augmented", "with the named effects", "tab:blue", 1.1, "-", 0.85)):
        values = np.where(air, series[col].to_numpy(dtype=float), np.nan)
        ax.plot(t, values, color=colour, lw=lw, ls=ls, alpha=alpha, label=label)
    hold = series["held_out"].to_numpy(bool)
    if hold.any():
        ax.axvspan(t[hold][0], t[hold][-1], color="0.9", zorder=-1, label="held out")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{ch} ({data['units'].get(ch, '')})")
    ax.set_title(f"{ch}: before and after")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
              frameon=False)
    return fig


def _value(p: dict[str, Any]) -> str:
    v = p["value"]
    if isinstance(v, str | list):
        return str(v)
    err = p.get("stderr")
    return f"{v:.4g}" + (f" ± {err:.2g}" if err else "")


def parameters_text(effect: dict[str, Any]) -> str:
    """``R = 0.2498 ± 0.0084 m, exponent = 1.236 ± 0.026`` (no unit for dimensionless)."""
    return ", ".join(f"{k} = {_value(v)} {_unit(v.get('unit'))}".strip()
                     for k, v in effect["parameters"].items())


def _rmse_rows(data: dict[str, Any]) -> list[list[str]]:
    rows = []
    for c, before in data["rmse_before"].items():
        after = data["rmse_after"].get(c, before)
        change = f"{100 * (after - before) / before:+.0f} %" if before else "–"
        rows.append([c, _unit(data["units"].get(c)), f"{data['noise'].get(c, 0):.3g}",
                     f"{before:.3g}", f"{after:.3g}", change])
    return rows


RMSE_HEAD = ["channel", "unit", "SIM noise", "before", "after", "change"]


def _regime_text(data: dict[str, Any]) -> str:
    regime = (data.get("mismatch") or {}).get("regime") or {}
    return str(regime.get("description") or "")


def _markdown(data: dict[str, Any], figures: dict[str, Path]) -> str:
    lines = ["# Gap report: simulation vs recording", "", data["summary"], "",
             f"* SIM: `{data['sim']['file']}` ({data['sim']['airborne_s']} s airborne)",
             f"* REAL: `{data['real']['file']}` ({data['real']['airborne_s']} s airborne)",
             f"* Verdict: **{data['verdict']}** — {data['reason']}"]
    if _regime_text(data):
        lines.append(f"* Located regime: {_regime_text(data)}")
    lines.append("")
    if data["effects"]:
        lines += ["## Effects", "", "| effect | parameters | confidence | evidence |",
                  "|---|---|---|---|"]
        for e in data["effects"]:
            lines.append(f"| {e['name']} | {parameters_text(e)} | {e['confidence']:.2f} | "
                         f"{e['evidence']} |")
        lines.append("")
    lines += ["## Held-out RMSE per channel", "", "| " + " | ".join(RMSE_HEAD) + " |",
              "|" + "---|" * len(RMSE_HEAD)]
    lines += ["| " + " | ".join(r) + " |" for r in _rmse_rows(data)]
    if data.get("notes"):
        lines += ["", "## Notes", ""] + [f"* {n}" for n in data["notes"]]
    lines += [""] + [f"![{k}]({p.name})" for k, p in figures.items()]
    return "\n".join(lines) + "\n"


CAPTIONS = {
    "gap_residual": "Residual of the main mismatched channel on held-out data against the "
                    "locating variable, before (nominal model from SIM) and after (augmented "
                    "with the named effects); the located regime shaded.",
    "gap_timeseries": "The main mismatched channel over time: REAL, the nominal model and "
                      "the augmented model; the held-out part shaded.",
}


def _html(data: dict[str, Any], figures: dict[str, Path],
          interactive: tuple[str, dict[str, str]]) -> str:
    from etsid.report.page import HINT, esc, html_page, image_html, table_html

    head_js, divs = interactive
    body = [f'<p class="lead">{esc(data["summary"])}</p>',
            table_html(["", "file", "airborne (s)", "duration (s)", "rate (Hz)", "inputs"],
                       [[role, d.get("file", ""), d.get("airborne_s", ""),
                         d.get("duration_s", ""), d.get("rate_hz", ""), d.get("inputs", "")]
                        for role, d in (("SIM", data["sim"]), ("REAL", data["real"]))]),
            f"<p><strong>Verdict: {esc(data['verdict'])}</strong> — {esc(data['reason'])}</p>"]
    if _regime_text(data):
        body.append(f"<p><strong>Located regime:</strong> {esc(_regime_text(data))}</p>")
    if data["effects"]:
        body += ['<h2 id="effects">Missing physics, fitted</h2>',
                 table_html(["effect", "parameters", "confidence", "evidence"],
                            [[e["name"], parameters_text(e), f"{e['confidence']:.2f}",
                              e["evidence"]] for e in data["effects"]],
                            text_columns=(1, 3))]
    if "timeseries" in divs:
        body += ['<h2 id="before-after">Before and after, per mismatched channel</h2>',
                 f'<p class="hint">{esc(HINT)}</p>',
                 "<p>REAL (black, on top), the nominal model from SIM (red dashed) and the "
                 "model with the named effects (blue); below, both errors. Grey band and "
                 "dashed line: the held-out part the effects were proven on; orange band "
                 "(error panels): where the located regime holds.</p>",
                 divs["timeseries"]]
    if "regime" in divs:
        body += ['<h2 id="regime">Where it differs: residual against the locating variable'
                 "</h2>", divs["regime"]]
    body += ['<h2 id="rmse">Held-out RMSE per channel</h2>',
             table_html(RMSE_HEAD, _rmse_rows(data))]
    if data.get("candidates"):
        body += ['<h2 id="candidates">Candidate effects tried</h2>',
                 table_html(["effect", "fitted parameters", "share of the excess removed",
                             "score"],
                            [[c["name"], candidate_params(c), f"{c['share']:.3f}",
                              f"{c['score']:.3f}"] for c in data["candidates"]])]
    if data.get("notes"):
        body += ['<h2 id="notes">Notes</h2>',
                 "<ul>" + "".join(f"<li>{esc(n)}</li>" for n in data["notes"]) + "</ul>"]
    if figures:
        body.append('<h2 id="figures">Figures for papers</h2>')
        body += [image_html(_embeddable(path), name, CAPTIONS.get(name, name))
                 for name, path in figures.items()]
    return html_page("Gap report: simulation vs recording", body, head_js)


def candidate_params(candidate: dict[str, Any]) -> str:
    """``motor m3, scale 0.82``: a ranked candidate's fitted parameters in words."""
    parts = []
    for name, value in (candidate.get("params") or {}).items():
        if isinstance(value, dict):
            unit = value.get("unit") or ""
            unit = "" if unit in ("", "1") else f" {unit}"
            parts.append(f"{name} {value.get('value'):.3g}{unit}")
        else:
            parts.append(f"{name} {value}")
    return ", ".join(parts) or "–"


def _embeddable(path: Path) -> Path:
    """The PNG beside a PDF figure (a page cannot show PDF inline)."""
    return path.with_suffix(".png") if path.suffix == ".pdf" else path


def _interactive(series: pd.DataFrame, data: dict[str, Any]) -> tuple[str, dict[str, str]]:
    """Time series (REAL, nominal, augmented, errors) of every mismatched channel, linked,
    and the residual against the locating variable."""
    from etsid.report import interactive as ia

    channels = [c for c in ((data.get("mismatch") or {}).get("channels") or [])
                if c in series and f"{c}_nominal" in series]
    main = _main_channel(data)
    if not channels and main in series:
        channels = [main]
    if not channels:
        return "", {}
    t = series.index.to_numpy(dtype=float)
    air = series["airborne"].to_numpy(bool)
    hold = series["held_out"].to_numpy(bool)
    inside = _regime_mask(series, data)
    x_range = ia.shared_range(t[air] if air.any() else t)
    figs = []
    for ch in channels:
        unit = _unit(data["units"].get(ch))
        real = np.where(air, series[ch].to_numpy(dtype=float), np.nan)
        cols = {"real": real,
                "nominal": np.where(air, series[f"{ch}_nominal"].to_numpy(dtype=float), np.nan),
                "augmented": np.where(air, series[f"{ch}_augmented"].to_numpy(dtype=float),
                                      np.nan)}
        cols["e_nominal"] = real - cols["nominal"]
        cols["e_augmented"] = real - cols["augmented"]
        src = ia.source(t, cols)
        label = f"{ch} ({unit})" if unit else ch
        fig = ia.time_figure(label, f"{ch}: REAL against the models", x_range)
        err = ia.time_figure(f"error ({unit})" if unit else "error",
                             f"{ch}: REAL − model", x_range, height=160)
        if hold.any():
            ia.shade(fig, float(t[hold][0]), float(t[hold][-1]), "#888888", 0.15)
            ia.mark(err, float(t[hold][0]))
        if inside is not None:
            for a, b, flag in ia.intervals(t, inside & air):
                if flag:
                    ia.shade(err, a, b, "#ff7f0e", 0.15)
        # REAL first (thin grey, under): the model that follows it closely stays visible
        ia.add_lines(fig, src, [ia.Line("real", "REAL (filtered)", **ia.MEASURED_STYLE),
                                ia.Line("nominal", "nominal model from SIM",
                                        ia.COLORS["free_run"], 1.4, "dashed"),
                                ia.Line("augmented", "with the named effects",
                                        ia.COLORS["one_step"], 1.5, "solid", 0.85)],
                     unit=unit)
        rms = {k: float(np.sqrt(np.nanmean(cols[k][hold] ** 2))) if hold.any() else np.nan
               for k in ("e_nominal", "e_augmented")}
        ia.add_lines(err, src, [ia.Line("e_nominal", f"before (held-out RMSE "
                                        f"{rms['e_nominal']:.3g})", ia.COLORS["free_run"], 1.0,
                                        "solid", 0.8),
                                ia.Line("e_augmented", f"after (held-out RMSE "
                                        f"{rms['e_augmented']:.3g})", ia.COLORS["one_step"],
                                        1.2, "dashed")], unit=unit)
        figs += [fig, err]
    plots = {"timeseries": ia.column(*figs)}
    regime_fig = _regime_scatter(series, data, channels[0], hold)
    if regime_fig is not None:
        plots["regime"] = regime_fig
    return ia.embed(plots)


def _regime_scatter(series: pd.DataFrame, data: dict[str, Any], ch: str,
                    hold: np.ndarray) -> Any:
    from bokeh.models import BoxAnnotation, ColumnDataSource, HoverTool
    from bokeh.plotting import figure

    regime = (data.get("mismatch") or {}).get("regime") or {}
    col = f"var_{regime.get('variable')}"
    if col not in series or not hold.any():
        return None
    x = series[col].to_numpy(dtype=float)[hold]
    unit = _unit(data["units"].get(ch))
    fig = figure(height=320, sizing_mode="stretch_width", tools="pan,wheel_zoom,box_zoom,"
                 "reset,save", title=f"{ch}: held-out residual against "
                 f"{VAR_TEXT.get(col[4:], col[4:])}")
    fig.toolbar.logo = None
    step = max(1, x.size // 3000)
    for kind, colour, label in (("nominal", "#d62728", "before"),
                                ("augmented", "#1f77b4", "after")):
        e = (series[ch] - series[f"{ch}_{kind}"]).to_numpy(dtype=float)[hold]
        src = ColumnDataSource({"x": x[::step].astype(np.float32),
                                "e": e[::step].astype(np.float32)})
        r = fig.scatter("x", "e", source=src, size=3, alpha=0.4, color=colour,
                        legend_label=f"{label} (RMSE {np.sqrt(np.nanmean(e**2)):.3g})")
        fig.add_tools(HoverTool(renderers=[r], tooltips=[("x", "@x{0.000}"),
                                                         ("residual", "@e{0.000}")]))
    rng = regime.get("range")
    if isinstance(rng, list) and len(rng) == 2:
        fig.add_layout(BoxAnnotation(left=rng[0], right=rng[1], fill_color="#ff7f0e",
                                     fill_alpha=0.15, level="underlay"))
    fig.xaxis.axis_label = VAR_TEXT.get(col[4:], col[4:])
    fig.yaxis.axis_label = f"residual ({unit})" if unit else "residual"
    from etsid.report.interactive import legend_above

    legend_above(fig)
    return fig


def _series(out: Path, data: dict[str, Any]) -> pd.DataFrame | None:
    """The gap directory's per-sample series, or None when it has none of the main channel."""
    series_path = out / SERIES_FILE
    ch = _main_channel(data)
    if not series_path.is_file() or ch is None:
        return None
    try:
        series = read_parquet_frame(series_path, "table", ReportError)
    except (OSError, ValueError) as err:
        raise ReportError(f"{series_path}: cannot read ({err})") from err
    return series if ch in series else None


def _figures(series: pd.DataFrame, data: dict[str, Any]) -> dict[str, Figure]:
    ch = _main_channel(data)
    assert ch is not None
    return {"gap_residual": _residual_figure(series, data, ch),
            "gap_timeseries": _time_figure(series, data, ch)}


def gap_figures(out_dir: str | Path) -> dict[str, Figure]:
    """The static figures of a gap directory by name (none when it has no series)."""
    out = Path(out_dir)
    data = read_gap_json(out / "gap.json")
    series = _series(out, data)
    return {} if series is None else _figures(series, data)


def make_gap_report(out_dir: str | Path, fmt: str = "png",
                    say: Callable[[str], None] | None = None) -> Report:
    """Write report.md, index.html and figures into a gap run directory.

    Raises
    ------
    ReportError
        The directory has no readable gap.json of schema ``etsid.gap/1``.
    """
    say = say or (lambda _: None)
    out = Path(out_dir)
    data = read_gap_json(out / "gap.json")
    report = Report(out)
    interactive: tuple[str, dict[str, str]] = ("", {})
    series = _series(out, data)
    if series is not None:
        say(f"gap report: drawing the figures into {out}/ …")
        for name, fig in _figures(series, data).items():
            report.figures[name] = save_figure(fig, out / f"{name}.{fmt}")
            if fmt == "pdf":
                save_figure(fig, out / f"{name}.png")
        interactive = _interactive(series, data)
    md = _markdown(data, report.figures)
    report.markdown = out / "report.md"
    report.markdown.write_text(markdown_safe(md), encoding="utf-8")
    report.html = out / "index.html"
    report.html.write_text(_html(data, report.figures, interactive), encoding="utf-8")
    return report
