"""The report's figures, as matplotlib :class:`~matplotlib.figure.Figure` objects.

Each function takes a :class:`~etsid.ident.rundir.Run` and returns one figure sized for an
A4 page (7 in wide), with labelled axes (units) and legends. No pyplot state is used, so
figures can be built in any thread and saved with the Agg backend.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from etsid.ident.rundir import Run
from etsid.table import COLUMNS

WIDTH = 7.0
"""Figure width, inches (A4 text width with margins)."""

STYLE: dict[str, Any] = {
    "font.size": 8.5,
    "axes.titlesize": 9,
    "axes.labelsize": 8.5,
    "legend.fontsize": 7.5,
    "xtick.labelsize": 7.5,
    "ytick.labelsize": 7.5,
    "lines.linewidth": 0.9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "figure.dpi": 150,
    "savefig.dpi": 150,
    "savefig.bbox": "tight",
}

COLORS = {"measured": "0.25", "one_step": "tab:blue", "free_run": "tab:red",
          "arx": "tab:green", "birth": "tab:green", "replace": "tab:orange",
          "removal": "tab:red", "merge": "tab:purple"}

NAMES = {"p": "roll rate", "q": "pitch rate", "r": "yaw rate"}


@contextmanager
def style() -> Iterator[None]:
    """The report's matplotlib style (rc settings) for the duration of a block."""
    with matplotlib.rc_context(STYLE):
        yield


def outputs_of(run: Run) -> list[str]:
    """Output names of a run, in model order."""
    return list(run.config.get("model", {}).get("outputs") or run.metrics["outputs"].keys())


def unit_of(run: Run, y: str) -> str:
    """Unit of output ``y`` (from metrics.json, else the FlightTable contract)."""
    unit = (run.metrics.get("outputs", {}).get(y) or {}).get("unit")
    if not unit and y in COLUMNS:
        unit = COLUMNS[y].unit
    return unit or ""


def label_of(run: Run, y: str) -> str:
    """Axis label of output ``y``, e.g. ``roll rate p (rad/s)``."""
    unit = unit_of(run, y)
    name = f"{NAMES[y]} {y}" if y in NAMES else y
    return f"{name} ({unit})" if unit and unit != "1" else name


def with_gaps(t: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """Insert NaN where the time step exceeds 1.5 × its median, so lines break at gaps."""
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return (t, *ys)
    dt = np.diff(t)
    cut = np.flatnonzero(dt > 1.5 * np.median(dt)) + 1
    if cut.size == 0:
        return (t, *ys)
    return (np.insert(t, cut, np.nan),
            *(np.insert(np.asarray(y, dtype=float), cut, np.nan) for y in ys))


def zoom_window(t: np.ndarray, y: np.ndarray, fraction: float = 0.06) -> tuple[float, float]:
    """Time window (s) of about ``fraction`` of the record where ``y`` varies most."""
    n = len(t)
    w = max(10, int(fraction * n))
    if n <= w:
        return float(t[0]), float(t[-1])
    filled = np.nan_to_num(np.asarray(y, dtype=float) - np.nanmean(y))
    energy = np.convolve(filled**2, np.ones(w), mode="valid")
    i = int(np.argmax(energy))
    return float(t[i]), float(t[min(n - 1, i + w - 1)])


def legend_outside(ax: Axes, **kwargs: Any) -> None:
    """The legend of ``ax`` to the right of its plot area, where it covers no data (the
    figure needs ``layout="constrained"`` to make room for it)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                  frameon=False, **kwargs)


def legend_above(fig: Figure, ax: Axes, ncols: int = 4) -> None:
    """One legend of ``ax``'s lines above every panel of ``fig`` (constrained layout)."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside upper center", ncols=ncols, frameon=False)


def fig_rates(run: Run) -> Figure:
    """Measured vs online one-step prediction per output, full record and a zoom (Fig. 1.10 a–c)."""
    pred = run.predictions
    outputs = outputs_of(run)
    with style():
        fig = Figure(figsize=(WIDTH, 1.9 * len(outputs) + 0.4), layout="constrained")
        axes = fig.subplots(len(outputs), 2, squeeze=False,
                            gridspec_kw={"width_ratios": [2.2, 1]})
        t = pred["t"].to_numpy()
        for row, y in enumerate(outputs):
            meas, hat = pred[y].to_numpy(), pred[f"{y}_hat"].to_numpy()
            tg, mg, hg = with_gaps(t, meas, hat)
            t0, t1 = zoom_window(t, meas)
            for col, ax in enumerate(axes[row]):
                # measured thin and grey under the prediction, which stays visible on top
                ax.plot(tg, mg, color="0.45", label="measured", lw=0.8, alpha=0.8, zorder=2)
                ax.plot(tg, hg, color=COLORS["one_step"], label="eTS one-step", lw=0.8,
                        alpha=0.9, zorder=3)
                ax.set_ylabel(label_of(run, y))
                if col == 1:
                    ax.set_xlim(t0, t1)
                    keep = (t >= t0) & (t <= t1)
                    vals = np.r_[meas[keep], hat[keep]]
                    vals = vals[np.isfinite(vals)]
                    if vals.size:
                        pad = 0.1 * (vals.max() - vals.min() + 1e-12)
                        ax.set_ylim(vals.min() - pad, vals.max() + pad)
                    ax.set_title(f"zoom {t0:.1f}–{t1:.1f} s", loc="left")
                else:
                    ax.axvspan(t0, t1, color="0.85", zorder=0)
                    rmse = (run.metrics["outputs"][y]["online"] or {}).get("rmse")
                    if rmse is not None:
                        ax.set_title(f"online one-step, RMSE {rmse:.4g} {unit_of(run, y)}",
                                     loc="left")
        legend_above(fig, axes[0, 0], ncols=2)
        for ax in axes[-1]:
            ax.set_xlabel("time t (s)")
    return fig


def _event_times(run: Run) -> dict[str, np.ndarray]:
    hist = run.history
    out: dict[str, np.ndarray] = {}
    for kind, col in (("birth", "births"), ("replace", "replacements"), ("removal", "removals"),
                      ("merge", "merges")):
        if col in hist.columns:
            out[kind] = hist.loc[hist[col] > 0, "t"].to_numpy()
    return out


def fig_structure(run: Run) -> Figure:
    """Potential of each sample vs focal potentials, and rule count with events (Fig. 1.10 d–e)."""
    hist = run.history
    with style():
        fig = Figure(figsize=(WIDTH, 4.2), layout="constrained")
        ax_p, ax_r = fig.subplots(2, 1, sharex=True)
        if len(hist):
            t = hist["t"].to_numpy()
            ax_p.plot(t, hist["potential"].to_numpy(), ".", ms=1.2, color="0.55",
                      label="potential of the sample $P_k(z_k)$")
            ax_p.plot(t, hist["focal_max"].to_numpy(), color="tab:blue",
                      label="max focal potential")
            ax_p.plot(t, hist["focal_min"].to_numpy(), color="tab:purple", ls="--",
                      label="min focal potential")  # dashed: equal to max with one rule
            ax_r.step(t, hist["n_rules"].to_numpy(), where="post", color="k",
                      label="rules")
            counts = hist.set_index("t")["n_rules"]
            markers = {"birth": "^", "replace": "D", "removal": "v", "merge": "X"}
            for kind, times in _event_times(run).items():
                if times.size:
                    n = int(hist["merges"].sum()) if kind == "merge" else times.size
                    ax_r.plot(times, counts.loc[times].to_numpy(), markers[kind], ms=4,
                              color=COLORS[kind], label=f"{kind} ({n})", linestyle="none")
        else:
            ax_p.text(0.5, 0.5, "no learning in this run (rules frozen)",
                      transform=ax_p.transAxes, ha="center")
        ax_p.set_ylabel("potential (–)")
        _potential_limits(ax_p, hist)
        legend_outside(ax_p, markerscale=4)
        ax_p.set_title("(a) cluster potential", loc="left")
        ax_r.set_ylabel("number of rules")
        ax_r.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax_r.set_xlabel("time t (s)")
        ax_r.set_title("(b) rule-base size, with structural events", loc="left")
        legend_outside(ax_r)
    return fig


def _potential_limits(ax: Axes, hist: pd.DataFrame) -> None:
    """Y limits around the potentials drawn (they often all lie between 0.7 and 1)."""
    cols = [c for c in ("potential", "focal_max", "focal_min") if c in hist]
    values = hist[cols].to_numpy(dtype=float).ravel() if cols and len(hist) else np.zeros(0)
    values = values[np.isfinite(values)]
    if values.size:
        lo, hi = float(np.percentile(values, 0.5)), float(values.max())
        pad = 0.05 * (hi - lo) if hi > lo else 0.05
        ax.set_ylim(max(0.0, lo - pad), min(1.02, hi + pad))
    else:
        ax.set_ylim(0, 1.02)


def fig_consequents(run: Run, top: int = 4) -> Figure:
    """The consequents as their dominant terms: per output, the ``top`` terms of each rule
    by share (|θ| × the input's learnt range over the sum of all terms; see
    :mod:`etsid.report.rulebook`), signed like θ; every rule, numbered as in the tables."""
    from etsid.errors import EtsidError
    from etsid.report.rulebook import summarize

    try:
        summaries = summarize(run.rules, trusted=True)
    except (EtsidError, TypeError, KeyError, IndexError, AttributeError) as err:
        raise ValueError(f"rule base not readable ({err!r})") from err
    if not summaries:
        raise ValueError("the rule base has no rules")
    outputs = list(summaries[0].terms)
    regimes = {int(r["rule"]): r.get("regime") or "" for r in
               (((run.metrics.get("regimes") or {}) if isinstance(run.metrics, dict) else {})
                .get("rules") or [])}
    cmap = matplotlib.colormaps["tab10"]
    with style():
        fig = Figure(figsize=(WIDTH, 2.0 * len(outputs) + 0.6), layout="constrained")
        axes = fig.subplots(len(outputs), 1, squeeze=False)[:, 0]
        for ax, y in zip(axes, outputs, strict=True):
            names = list(dict.fromkeys(t.name for rule in summaries
                                       for t in rule.terms[y][:top]))
            width = 0.8 / len(summaries)
            x = np.arange(len(names))
            for k, rule in enumerate(summaries):
                signed = {t.name: 100 * t.share * np.sign(t.coefficient)
                          for t in rule.terms[y]}
                label = f"Rule {rule.number}" + (f" ({regimes[rule.number]})"
                                                 if regimes.get(rule.number) else "")
                ax.bar(x - 0.4 + (k + 0.5) * width, [signed.get(n, 0.0) for n in names],
                       width, color=cmap(k % 10), label=label)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_xticks(x, names, rotation=30, ha="right")
            ax.set_ylabel(f"share in {y} (%, sign of θ)")
            ax.set_title(f"output {y}: dominant consequent terms", loc="left")
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside upper center",
                   ncols=min(4, len(summaries)), fontsize=7)
    return fig


def residuals_of(run: Run, y: str) -> tuple[np.ndarray, str]:
    """One-step residuals used for the whiteness check and what they are.

    The frozen validation residuals when the run has a validation part, else the online
    ones after the first 10 % (while the rule base forms).
    """
    pred = run.predictions
    if f"{y}_val" in pred and np.isfinite(pred[f"{y}_val"]).sum() > 10:
        res = (pred[y] - pred[f"{y}_val"]).to_numpy()
        what = "frozen one-step, validation part"
    else:
        res = (pred[y] - pred[f"{y}_hat"]).to_numpy()
        res = res[len(res) // 10:]
        what = "online one-step, after the first 10 %"
    return res[np.isfinite(res)], what


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation r(0 … max_lag) of ``x`` (mean removed), r(0) = 1."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    den = float(x @ x)
    if den == 0.0:
        return np.r_[1.0, np.zeros(max_lag)]
    return np.array([float(x[: n - k] @ x[k:]) / den for k in range(max_lag + 1)])


def fig_residuals(run: Run, max_lag: int = 40) -> Figure:
    """Residual histogram (with a normal fit and the known noise σ) and autocorrelation with
    the 95 % band ±1.96/√N of white noise (whiteness check)."""
    outputs = outputs_of(run)
    with style():
        fig = Figure(figsize=(WIDTH, 1.8 * len(outputs) + 0.4), layout="constrained")
        axes = fig.subplots(len(outputs), 2, squeeze=False)
        for row, y in enumerate(outputs):
            res, what = residuals_of(run, y)
            unit = unit_of(run, y)
            ax_h, ax_a = axes[row]
            if res.size < 3:
                ax_h.text(0.5, 0.5, "too few residuals", transform=ax_h.transAxes)
                continue
            sd = float(np.std(res))
            ax_h.hist(res, bins=60, density=True, color="tab:blue", alpha=0.6,
                      label="residuals")
            grid = np.linspace(res.min(), res.max(), 200)
            if sd > 0:
                ax_h.plot(grid, np.exp(-0.5 * ((grid - res.mean()) / sd) ** 2)
                          / (sd * np.sqrt(2 * np.pi)), color="k",
                          label=f"normal, s = {sd:.3g}")
            sigma = (run.metrics["outputs"].get(y) or {}).get("noise_std")
            if sigma:
                ax_h.axvline(-sigma, color="tab:red", ls="--", label=f"±σ noise = {sigma:.3g}")
                ax_h.axvline(sigma, color="tab:red", ls="--")
            ax_h.set_xlabel(f"residual {y} − ŷ ({unit})")
            ax_h.set_ylabel(f"density (1/{unit})" if unit and unit != "1" else "density")
            ax_h.set_title(what, loc="left")
            legend_outside(ax_h)
            lag_count = min(max_lag, res.size - 1)  # short validation parts: fewer lags
            lags = np.arange(lag_count + 1)
            ac = autocorrelation(res, lag_count)
            ax_a.vlines(lags, 0, ac, color="tab:blue")
            ax_a.plot(lags, ac, "o", ms=2.5, color="tab:blue", label="autocorrelation")
            band = 1.96 / np.sqrt(res.size)
            ax_a.axhspan(-band, band, color="tab:orange", alpha=0.25,
                         label=f"95 % band ±{band:.3f}")
            ax_a.set_xlabel("lag (samples)")
            ax_a.set_ylabel(f"r({y} residual)")
            legend_outside(ax_a)
    return fig


def _keep_measured_range(ax: Axes, measured: np.ndarray) -> None:
    """Y limits from the measured values (a diverging prediction cannot rescale them)."""
    finite = measured[np.isfinite(measured)]
    if finite.size:
        lo, hi = float(finite.min()), float(finite.max())
        pad = 0.25 * (hi - lo) if hi > lo else max(abs(hi), 1e-3)
        ax.set_ylim(lo - pad, hi + pad)


def fig_validation(run: Run) -> Figure:
    """Validation part: measured (thin grey, under) against eTS frozen one-step, eTS free
    run and ARX free run; under each output the free-run errors of eTS and ARX."""
    pred = run.predictions
    outputs = outputs_of(run)
    val = pred[pred["part"] == "validation"] if "part" in pred else pred.iloc[0:0]
    with style():
        fig = Figure(figsize=(WIDTH, 2.6 * len(outputs) + 0.4), layout="constrained")
        grid = fig.subplots(2 * len(outputs), 1, squeeze=False, sharex=True,
                            gridspec_kw={"height_ratios": [2, 1] * len(outputs)})[:, 0]
        t = val["t"].to_numpy()
        for row, y in enumerate(outputs):
            ax, ax_e = grid[2 * row], grid[2 * row + 1]
            ax.set_ylabel(label_of(run, y))
            ax_e.set_ylabel(f"error ({unit_of(run, y)})")
            if not len(val):
                ax.text(0.5, 0.5, "no validation part (--validate 0)", transform=ax.transAxes,
                        ha="center")
                continue
            # measured first, thin and grey (under); then each model with its own colour,
            # width and dash; ARX dashed last, so where it meets eTS both stay visible
            series = [(y, "measured", "0.45", 0.8, "-", 0.8),
                      (f"{y}_val", "eTS one-step (frozen)", COLORS["one_step"], 0.8, ":", 1.0),
                      (f"{y}_sim", "eTS free-run", COLORS["free_run"], 1.0, "-", 0.85),
                      (f"{y}_arx_sim", "ARX free-run", COLORS["arx"], 1.0, "--", 1.0)]
            cols = [val[c].to_numpy(dtype=float) if c in val else np.full(len(t), np.nan)
                    for c, *_ in series]
            tg, *gs = with_gaps(t, *cols)
            for z, ((_, label, color, lw, ls, alpha), g) in enumerate(
                    zip(series, gs, strict=True)):
                ax.plot(tg, g, color=color, label=label, lw=lw, ls=ls, alpha=alpha,
                        zorder=2 + z)
            _keep_measured_range(ax, cols[0])
            for col, label, color, ls in ((2, "eTS", COLORS["free_run"], "-"),
                                          (3, "ARX", COLORS["arx"], "--")):
                err = gs[0] - gs[col]
                finite = err[np.isfinite(err)]
                if finite.size:
                    rmse = float(np.sqrt(np.mean(finite**2)))
                    ax_e.plot(tg, err, color=color, lw=0.8, ls=ls,
                              label=f"{label} free-run error, RMSE {rmse:.3g}")
            ax_e.axhline(0, color="k", lw=0.5)
            ax_e.yaxis.set_major_locator(MaxNLocator(nbins=3))  # small panel: no overlap
            legend_outside(ax_e)
            block = (((run.metrics["outputs"][y] or {}).get("validation") or {})
                     .get("free_run") or {})
            arx = (((((run.metrics["outputs"][y] or {}).get("arx") or {}).get("validation")
                     or {}).get("free_run")) or {})
            fr = block.get("fit")
            title = f"free-run fit eTS {fr:.1f} %" if fr is not None else ""
            if title and arx.get("fit") is not None:
                title += f" vs ARX {arx['fit']:.1f} %"
            if block.get("informative") is False:
                title = (f"too little motion (std {block['signal_std']:.2g}): free-run fit "
                         f"{fr:.1f} % not informative" if fr is not None else "")
            for when in block.get("diverged_times") or []:
                ax.axvline(when, color=COLORS["free_run"], linestyle="--", linewidth=1.0)
            if block.get("diverged"):
                title = (f"eTS free-run diverged at t = {block['diverged_at']:.2f} s"
                         + (f" (fit {fr:.1f} % before)" if fr is not None else ""))
            if title:
                ax.set_title(title, loc="left")
        legend_above(fig, grid[0], ncols=4)
        grid[-1].set_xlabel("time t (s)")
    return fig


FIGURES = {
    "rates": (fig_rates, "Measured and eTS one-step predicted outputs (online, predict "
                         "then learn), full record and zoom."),
    "structure": (fig_structure, "Potential of each sample against the focal potentials, "
                                 "and the number of rules with births, replacements and "
                                 "removals."),
    "consequents": (fig_consequents, "Dominant consequent terms of every rule (share of "
                                     "the output's swing, signed like θ), rules numbered "
                                     "as in the tables."),
    "residuals": (fig_residuals, "Residual histogram and autocorrelation with the 95 % "
                                 "band of white noise."),
    "validation": (fig_validation, "Validation part: measured (thin grey, under the models) "
                                   "against the frozen one-step prediction (dotted) and the "
                                   "free runs of eTS (solid) and ARX (dashed); under each "
                                   "output the free-run errors."),
}
"""Report figures: name → (builder, caption)."""
