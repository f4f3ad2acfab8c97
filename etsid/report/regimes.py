"""Regime tables of a run (metrics.json ``regimes``, computed by :mod:`etsid.ident.regimes`):
scores per altitude band, the rule → regime table and the sentence of what the model learnt."""

from __future__ import annotations

from typing import Any

from etsid.escape import for_html
from etsid.ident.rundir import Run
from etsid.report.tables import fmt, text_table

REGIME_HEAD = ["regime", "range", "learn / val samples", "output", "eTS 1-step RMSE",
               "ARX 1-step RMSE", "eTS free-run RMSE", "ARX free-run RMSE",
               "eTS free-run fit %", "ARX free-run fit %"]
RULE_HEAD = ["rule", "focal point", "alt (m)", "z/R", "thrust", "leads %", "support",
             "born (s)", "lifetime (s)", "regime"]


def regimes_of(run: Run) -> dict[str, Any] | None:
    """metrics.json ``regimes`` of ``run`` (None for runs written before it existed)."""
    block = run.metrics.get("regimes") if isinstance(run.metrics, dict) else None
    return block if isinstance(block, dict) else None


def _score(entry: dict[str, Any], key: str, field: str, digits: int = 4) -> str:
    block = entry.get(key) or {}
    return fmt(block.get(field), digits)


def regime_rows(run: Run) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the per-regime scores (validation part), one row per regime and
    output; a regime the validation part never visits has one row saying so."""
    block = regimes_of(run) or {}
    rows = []
    for regime in block.get("per_regime") or []:
        counts = f"{regime.get('n_learn', 0)} / {regime.get('n_validation', 0)}"
        outputs = regime.get("outputs") or {}
        if not outputs:
            rows.append([regime["name"], regime.get("label", ""), counts, "–", *["–"] * 6])
            continue
        for y, m in outputs.items():
            rows.append([regime["name"], regime.get("label", ""), counts, y,
                         _score(m, "one_step", "rmse"), _score(m, "arx_one_step", "rmse"),
                         _score(m, "free_run", "rmse"), _score(m, "arx_free_run", "rmse"),
                         _score(m, "free_run", "fit", 3), _score(m, "arx_free_run", "fit", 3)])
    return REGIME_HEAD, rows


def _focal_text(rule: dict[str, Any]) -> str:
    focal = rule.get("focal") or {}
    if not focal:
        return f"({rule.get('n_antecedents', '?')} regressors)"
    return ", ".join(f"{name} {value:.3g}" for name, value in focal.items())


def rule_rows(run: Run) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the rule → regime table (rules of the frozen rule base)."""
    block = regimes_of(run) or {}
    radius = block.get("rotor_radius_m")
    rows = []
    for rule in block.get("rules") or []:
        alt = rule.get("alt_m")
        alt_text = "–" if alt is None else f"{alt:.2f}" + (
            "" if rule.get("alt_source") == "focal" else " (median)")
        share = rule.get("share")
        thrust = rule.get("thrust")
        thrust_text = "–" if thrust is None else f"{thrust:.3f}" + (
            "" if rule.get("thrust_source") == "focal" else " (median)")
        rows.append([
            str(rule["rule"]), _focal_text(rule), alt_text,
            f"{alt / radius:.2g}" if alt is not None and radius else "–", thrust_text,
            "–" if share is None else f"{100 * share:.0f}",
            str(rule.get("support", "–")), fmt(rule.get("born_t"), 4),
            fmt(rule.get("lifetime_s"), 4), rule.get("regime") or "–",
        ])
    return RULE_HEAD, rows


def regime_notes(run: Run) -> list[str]:
    """Sentences under the tables: how the bands were made and what a column means."""
    block = regimes_of(run) or {}
    notes = []
    if block.get("note"):
        notes.append(f"Regimes: {block['note']}.")
    notes.append("Rule table: the frozen rule base (rules.json). Focal point in the antecedent "
                 "variables; alt is the focal altitude when altitude is an antecedent, else "
                 "the median altitude of the learning samples the rule leads; thrust likewise "
                 "for the thrust command u_thrust (0…1); leads % = share "
                 "of the learning samples where it fires strongest; lifetime = from birth to "
                 "the freeze.")
    if block.get("gain_kind"):
        notes.append(f"Gains compared: {block['gain_kind']}.")
    return notes


def regime_text(run: Run) -> str:
    """The stdout block of ``etsid identify``: the rule → regime table and the sentence
    (empty for runs without regimes)."""
    block = regimes_of(run)
    if not block:
        return ""
    head, rows = rule_rows(run)
    lines = []
    if rows:
        lines += ["rule → regime (" + (block.get("note") or "") + "):", text_table(head, rows)]
    if block.get("sentence"):
        lines.append(f"learnt: {block['sentence']}")
    return "\n".join(lines)


def regimes_markdown(run: Run) -> list[str]:
    """report.md lines of the regime section (none for runs without regimes)."""
    block = regimes_of(run)
    if not block:
        return []
    lines = ["## What the model learnt", ""]
    if block.get("sentence"):
        lines += [f"**{block['sentence']}**", ""]
    for title, (head, rows) in (("Rules and regimes", rule_rows(run)),
                                ("Metrics per regime (validation part)", regime_rows(run))):
        if rows:
            lines += [f"### {title}", "", "| " + " | ".join(head) + " |",
                      "|" + "---|" * len(head), *("| " + " | ".join(r) + " |" for r in rows),
                      ""]
    lines += [f"- {n}" for n in regime_notes(run)]
    return [*lines, ""]


def regimes_html(run: Run) -> list[str]:
    """index.html parts of the regime section (none for runs without regimes)."""

    esc = for_html
    block = regimes_of(run)
    if not block:
        return []
    parts = ['<h2 id="regimes">What the model learnt</h2>']
    if block.get("sentence"):
        parts.append(f"<p><strong>{esc(block['sentence'])}</strong></p>")
    from etsid.report.page import table_html

    for title, (head, rows), text in (
            ("Rules and regimes", rule_rows(run), (1, 9)),
            ("Metrics per regime (validation part)", regime_rows(run), (0, 1))):
        if rows:
            parts += [f"<h3>{esc(title)}</h3>", table_html(head, rows, text_columns=text)]
    parts.append("<ul>" + "".join(f"<li>{esc(n)}</li>" for n in regime_notes(run)) + "</ul>")
    return parts
