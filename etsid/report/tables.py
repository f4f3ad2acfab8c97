"""Text tables of a run: the metrics per output and the readable rule base."""

from __future__ import annotations

from typing import Any

from etsid.ident.rundir import Run

HEAD = ["output", "unit", "σ noise", "online RMSE", "RMSE/σ", "online NDEI", "online fit %",
        "val 1-step RMSE", "val 1-step fit %", "free-run RMSE", "free-run fit %",
        "ARX online RMSE", "ARX val 1-step RMSE", "ARX free-run fit %",
        "no-change val 1-step RMSE"]


def _get(entry: Any, *keys: str) -> Any:
    for key in keys:
        if not isinstance(entry, dict):
            return None
        entry = entry.get(key)
    return entry


def fmt(value: Any, digits: int = 4) -> str:
    """A number in ``digits`` significant figures, ``–`` for missing values."""
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def free_run_text(block: Any) -> str:
    """Free-run fit %, or ``diverged at t = … s (fit … before)`` when it diverged, or
    ``not informative (fit; std …)`` when the output barely moves in the validation part."""
    if not isinstance(block, dict):
        return "–"
    if block.get("diverged"):
        before = block.get("fit")
        tail = f", fit {before:.3g} % before" if isinstance(before, float) else ""
        return f"diverged at t = {block['diverged_at']:.2f} s{tail}"
    if block.get("informative") is False:
        return (f"not informative ({fmt(block.get('fit'), 3)}; std "
                f"{block['signal_std']:.2g})")
    if block.get("unstable_model"):
        return (f"{fmt(block.get('fit'), 3)} (unstable model: ρ = "
                f"{block['spectral_radius']:.4g}, doubles in {block['doubling_time_s']:.3g} s)")
    return fmt(block.get("fit"), 3)


def metrics_rows(run: Run) -> tuple[list[str], list[list[str]]]:
    """Header and one row of strings per output (see :data:`HEAD`)."""
    rows = []
    for y, m in run.metrics["outputs"].items():
        rows.append([
            y, m.get("unit") or "", fmt(m.get("noise_std")),
            fmt(_get(m, "online", "rmse")), fmt(_get(m, "online", "rmse_over_noise"), 3),
            fmt(_get(m, "online", "ndei")), fmt(_get(m, "online", "fit"), 3),
            fmt(_get(m, "validation", "one_step", "rmse")),
            fmt(_get(m, "validation", "one_step", "fit"), 3),
            fmt(_get(m, "validation", "free_run", "rmse")),
            free_run_text(_get(m, "validation", "free_run")),
            fmt(_get(m, "arx", "online", "rmse")),
            fmt(_get(m, "arx", "validation", "one_step", "rmse")),
            free_run_text(_get(m, "arx", "validation", "free_run")),
            fmt(_get(m, "persistence", "validation", "rmse")),
        ])
    return HEAD, rows


def text_table(head: list[str], rows: list[list[str]]) -> str:
    """Columns aligned with spaces (first column left, the rest right)."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h)
              for i, h in enumerate(head)]

    def line(cells: list[str]) -> str:
        return "  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                         for i, (c, w) in enumerate(zip(cells, widths, strict=True)))

    return "\n".join([line(head), *(line(r) for r in rows)])


def summary_table(run: Run) -> str:
    """The short stdout summary of ``identify`` / ``predict``: key metrics and rules."""
    keep = [0, 2, 3, 4, 7, 12, 14, 10, 13]
    head, rows = metrics_rows(run)
    # a column of only "–" says nothing (no noise estimate, no ARX baseline in predict);
    # the online RMSE equals the 1-step one when every row is scored without learning
    keep = [i for i in keep if any(r[i] != "–" for r in rows)]
    if all(r[3] == r[7] for r in rows) and 3 in keep and 7 in keep:
        keep.remove(3)
    table = text_table([head[i] for i in keep], [[r[i] for i in keep] for r in rows])
    counts = rule_counts(run.metrics["rules"])
    if run.config.get("command") == "predict":
        counts = f"rules: {run.metrics['rules'].get('frozen')} (the rule base applied)"
        if run.metrics["rules"].get("final") != run.metrics["rules"].get("frozen"):
            counts += f", {run.metrics['rules'].get('final')} after learning on (--learn)"
    return (f"{table}\n{counts}; samples "
            f"{run.metrics['n_samples']}, skipped "
            f"{sum((run.metrics.get('skipped') or {}).values())}")


def rule_counts(rules: dict[str, Any]) -> str:
    """The rule counts of metrics.json ``rules`` in one phrase, the saved rule base first
    (the one every table, ``etsid rules`` and the report show)."""
    saved, peak, final = rules.get("frozen"), rules.get("peak"), rules.get("final")
    text = f"rules: {saved} in rules.json (saved at the end of the learning part)"
    if peak is not None and final is not None:
        text += f"; while learning: at most {peak}, {final} at the end of the flight"
    return text


def merges_text(rules: dict[str, Any], saved: dict[str, Any] | None,
                n_learn: int | None) -> str:
    """The merges of metrics.json ``rules`` in words, rules numbered as in rules.json
    (``saved``: its dict), the tables and ``etsid rules``; a rule merged away is named by
    its birth time. ``n_learn``: rows of the learning part (merges after it are not in
    rules.json)."""
    merges = rules.get("merges") or []
    if not merges:
        return ""
    number = {int(r["id"]): k + 1 for k, r in enumerate((saved or {}).get("rules") or [])}
    saved_part, later = [], []
    for m in merges:
        born = m.get("absorbed_born_t")
        what = f"the rule born at {born:.1f} s" if born is not None else "a rule"
        if n_learn is None or m["after_rows"] <= n_learn:
            kept = number.get(int(m["kept"]))
            into = f"rule {kept}" if kept is not None else "a rule merged later"
            saved_part.append(f"{what} into {into} at {m['t']:.1f} s")
        else:
            later.append(m)
    text = "merged (consequents indistinguishable): " + ("; ".join(saved_part) or "none")
    text += " before rules.json was saved"
    if later:
        text += (f"; {len(later)} more after it, at {later[0]['t']:.1f} s, in the online "
                 "model only")
    return text


def rules_text(run: Run | dict[str, Any]) -> str:
    """The rule base of a run (or a rules.json dict) in readable IF … THEN … form."""
    from etsid.errors import EtsidError
    from etsid.ets import ETS

    data = run.rules if isinstance(run, Run) else run
    try:
        model = ETS.from_dict(data)
        text = model.rules()
    except (EtsidError, ValueError, KeyError, TypeError, ImportError) as err:
        return f"(rule base not readable: {err})"
    spec = data.get("regressors") or {}
    head = (f"# outputs: {', '.join(spec.get('outputs', []))}; regressors: "
            f"{spec.get('regressors', '')}\n") if spec else ""
    return head + text
