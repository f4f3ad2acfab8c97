"""The interactive plots of an identify/predict report (Bokeh, see :mod:`.interactive`).

* ``overview``: altitude with the leading rule shaded, thrust command, sticks, the leading
  rule number; the validation part shaded and the freeze marked. Time axis linked with
  ``online`` and ``structure``.
* ``validation``: per output, measured (thin grey, under) against eTS frozen one-step,
  eTS free-run and ARX free-run (dashed), and under it the free-run errors of eTS and ARX.
  Time axes linked among themselves.
* ``online``: per output, measured and the online one-step prediction, and its error.
* ``structure``: potential of each sample between the focal potentials, and rule count.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from etsid.ident.rundir import Run
from etsid.report import interactive as ia
from etsid.report.figures import label_of, outputs_of, unit_of
from etsid.report.overview import Overview

STICKS = {"u_roll": ("u_roll", "#1f77b4"), "u_pitch": ("u_pitch", "#d62728"),
          "u_yaw": ("u_yaw", "#2ca02c")}
"""The loop commands of the overview (sticks, or the input family identify chose)."""


def _validation_start(run: Run) -> float | None:
    """Start of the held-out part, s; None when there is none or when it is the whole
    record (``etsid predict``: a frozen rule base on another flight)."""
    val = (run.metrics.get("validation") or {}) if isinstance(run.metrics, dict) else {}
    start = val.get("t_start")
    if start is None or not val.get("n_learn"):
        return None
    return float(start)


def _mark_parts(fig: Any, run: Run, t_end: float) -> None:
    start = _validation_start(run)
    if start is not None:
        ia.shade(fig, start, t_end, color="#a07800", alpha=0.15, hatch="/")
        ia.mark(fig, start)


def _rule_names(run: Run) -> dict[int, str]:
    rows = ((run.metrics.get("regimes") or {}).get("rules") or []) \
        if isinstance(run.metrics, dict) else []
    names = {}
    for row in rows:
        regime = row.get("regime")
        names[int(row["rule"])] = f"Rule {row['rule']}" + (f" ({regime})" if regime else "")
    return names


def overview_plots(run: Run, flight: Overview, x_range: Any) -> list[Any]:
    """The flight overview (empty list when the flight could not be read)."""
    table = flight.table
    if table is None or table.empty:
        return []
    t = table.index.to_numpy(dtype=float)
    t_end = float(t[-1])
    figs = []
    if "alt" in table:
        fig = ia.time_figure("altitude (m)", "Altitude, shaded by the rule that leads "
                             "(hatched: validation part, dashed line: model frozen)",
                             x_range)
        if flight.lead is not None and flight.lead_t is not None:
            names = _rule_names(run)
            rules = sorted({int(r) for r in flight.lead})
            ia.shade_labels(fig, flight.lead_t, flight.lead,
                            {r: names.get(r, f"Rule {r}") for r in rules},
                            {r: ia.RULE_COLORS[(r - 1) % 10] for r in rules})
        src = ia.source(t, {"alt": table["alt"].to_numpy(dtype=float)})
        ia.add_lines(fig, src, [ia.Line("alt", "altitude", **ia.SIGNAL_STYLE)],
                     digits="0.000", unit="m")
        finite = table["alt"].to_numpy(dtype=float)
        finite = finite[np.isfinite(finite)]
        if finite.size:
            from bokeh.models import Range1d

            pad = 0.08 * (finite.max() - finite.min() + 1e-6)
            fig.y_range = Range1d(finite.min() - pad, finite.max() + pad)
        _mark_parts(fig, run, t_end)
        figs.append(fig)
    if "u_thrust" in table:
        fig = ia.time_figure("thrust command (0…1)", "Thrust command", x_range, height=180)
        src = ia.source(t, {"u_thrust": table["u_thrust"].to_numpy(dtype=float)})
        ia.add_lines(fig, src, [ia.Line("u_thrust", "u_thrust", **ia.SIGNAL_STYLE)],
                     digits="0.000")
        _mark_parts(fig, run, t_end)
        figs.append(fig)
    sticks = [c for c in STICKS if c in table]
    if sticks:
        chosen = (run.config.get("model") or {}).get("inputs")
        kind = chosen.get("kind") if isinstance(chosen, dict) else None
        fig = ia.time_figure("command", "Loop commands" + (f" ({kind})" if kind else ""),
                             x_range, height=180)
        src = ia.source(t, {c: table[c].to_numpy(dtype=float) for c in sticks})
        ia.add_lines(fig, src, [ia.Line(c, STICKS[c][0], STICKS[c][1], 1.0) for c in sticks],
                     digits="0.000")
        _mark_parts(fig, run, t_end)
        figs.append(fig)
    if flight.lead is not None and flight.lead_t is not None:
        fig = ia.time_figure("rule", "Leading rule (numbered as in the tables)", x_range,
                             height=170)
        src = ia.source(flight.lead_t, {"rule": flight.lead.astype(float)})
        ia.add_lines(fig, src, [ia.Line("rule", "leading rule", "#444444", 1.2)], digits="0")
        ia.integer_axis(fig)
        _mark_parts(fig, run, t_end)
        figs.append(fig)
    return figs


def _rmse(e: np.ndarray) -> float:
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e * e))) if e.size else float("nan")


def validation_plots(run: Run) -> list[Any]:
    """Per output: the held-out part in free run, and the errors of eTS and ARX under it."""
    pred = run.predictions
    if "part" not in pred or not (pred["part"] == "validation").any():
        return []
    val = pred[pred["part"] == "validation"]
    t = val["t"].to_numpy(dtype=float)
    x_range = ia.shared_range(t)
    figs = []
    for y in outputs_of(run):
        unit = unit_of(run, y)
        cols = {"measured": val[y].to_numpy(dtype=float)}
        lines = []
        for col, key, label in ((f"{y}_val", "one_step", "eTS one-step (frozen)"),
                                (f"{y}_sim", "free_run", "eTS free-run"),
                                (f"{y}_arx_sim", "arx", "ARX free-run")):
            if col in val:
                cols[key] = val[col].to_numpy(dtype=float)
                lines.append(ia.Line(key, label, **ia.MODEL_STYLES[key]))
        block = (((run.metrics["outputs"].get(y) or {}).get("validation") or {})
                 .get("free_run") or {})
        arx = ((((run.metrics["outputs"].get(y) or {}).get("arx") or {}).get("validation")
                or {}).get("free_run") or {})
        title = f"{label_of(run, y)}: held-out part, free run"
        if block.get("fit") is not None and arx.get("fit") is not None:
            title += f" — fit eTS {block['fit']:.1f} % vs ARX {arx['fit']:.1f} %"
        fig = ia.time_figure(label_of(run, y), title, x_range)
        errors = {}
        if "free_run" in cols:
            errors["e_ets"] = cols["measured"] - cols["free_run"]
        if "arx" in cols:
            errors["e_arx"] = cols["measured"] - cols["arx"]
        src = ia.source(t, {**cols, **errors})
        ia.add_lines(fig, src, [ia.Line("measured", "measured", **ia.MEASURED_STYLE), *lines],
                     unit=unit)
        _keep_measured_range(fig, cols["measured"])
        figs.append(fig)
        if errors:
            err_fig = ia.time_figure(f"error ({unit})" if unit and unit != "1" else "error",
                                     f"{y}: free-run error, measured − prediction", x_range,
                                     height=150)
            err_lines = []
            if "e_ets" in errors:
                err_lines.append(ia.Line("e_ets", f"eTS (RMSE {_rmse(errors['e_ets']):.4g})",
                                         **{**ia.MODEL_STYLES["free_run"], "width": 1.1}))
            if "e_arx" in errors:  # dashed, on top: where the errors agree both show
                err_lines.append(ia.Line("e_arx", f"ARX (RMSE {_rmse(errors['e_arx']):.4g})",
                                         **{**ia.MODEL_STYLES["arx"], "width": 1.1}))
            ia.add_lines(err_fig, src, err_lines, unit=unit)
            _zero_line(err_fig)
            figs.append(err_fig)
    return figs


def _zero_line(fig: Any) -> None:
    from bokeh.models import Span

    fig.add_layout(Span(location=0, dimension="width", line_color="#888888",
                        line_width=0.8))


def _keep_measured_range(fig: Any, measured: np.ndarray) -> None:
    """Y range from the measured values, so a diverging prediction cannot squash them."""
    from bokeh.models import Range1d

    finite = measured[np.isfinite(measured)]
    if finite.size:
        lo, hi = float(finite.min()), float(finite.max())
        pad = 0.25 * (hi - lo) if hi > lo else max(abs(hi), 1e-3)
        fig.y_range = Range1d(lo - pad, hi + pad)


def online_plots(run: Run, x_range: Any) -> list[Any]:
    """Per output: measured and the online one-step prediction (predict, then learn)."""
    pred = run.predictions
    t = pred["t"].to_numpy(dtype=float)
    t_end = float(t[-1]) if t.size else 0.0
    figs = []
    for y in outputs_of(run):
        unit = unit_of(run, y)
        meas, hat = pred[y].to_numpy(dtype=float), pred[f"{y}_hat"].to_numpy(dtype=float)
        src = ia.source(t, {"measured": meas, "hat": hat, "err": meas - hat})
        fig = ia.time_figure(label_of(run, y), f"{label_of(run, y)}: online one-step "
                             "prediction", x_range)
        ia.add_lines(fig, src, [ia.Line("measured", "measured", **ia.MEASURED_STYLE),
                                ia.Line("hat", "eTS one-step (online)",
                                        **{**ia.MODEL_STYLES["one_step"], "dash": "solid",
                                           "alpha": 0.85})],
                     unit=unit)
        _mark_parts(fig, run, t_end)
        err = ia.time_figure(f"error ({unit})" if unit and unit != "1" else "error",
                             f"{y}: one-step error (RMSE {_rmse(meas - hat):.4g})", x_range,
                             height=130)
        ia.add_lines(err, src, [ia.Line("err", "measured − eTS one-step",
                                        ia.COLORS["one_step"], 0.9)], unit=unit)
        _zero_line(err)
        figs += [fig, err]
    return figs


def structure_plots(run: Run, x_range: Any) -> list[Any]:
    """Potential of each sample and the focal potentials; number of rules."""
    hist = run.history
    if hist is None or not len(hist):
        return []
    t = hist["t"].to_numpy(dtype=float)
    src = ia.source(t, {c: hist[c].to_numpy(dtype=float)
                        for c in ("potential", "focal_max", "focal_min", "n_rules")})
    pot = ia.time_figure("potential (–)", "(a) potential of each sample against the focal "
                         "potentials", x_range)
    # min focal dashed over max focal (equal with one rule: both still show), the sample's
    # potential thin and translucent on top of both (it sits on them while a rule leads)
    ia.add_lines(pot, src, [ia.Line("focal_max", "max focal", "#1f77b4", 1.4),
                            ia.Line("focal_min", "min focal", "#9467bd", 1.4, "dashed"),
                            ia.Line("potential", "sample P(z)", "#666666", 0.8, "solid", 0.7)])
    count = ia.time_figure("rules", "(b) number of rules", x_range, height=150)
    ia.add_lines(count, src, [ia.Line("n_rules", "rules", "#222222", 1.5)], digits="0")
    ia.integer_axis(count)
    return [pot, count]
