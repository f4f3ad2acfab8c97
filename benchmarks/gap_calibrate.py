"""Calibrate ``etsid gap``'s likelihood criterion and score it generator by generator.

The criterion (etsid/gap/criterion.py) decides from three numbers per pair that do not
depend on any threshold: REAL's innovation-variance ratio per channel under the nominal
model, every candidate's held-out log-likelihood gain per scored sample, and the gain of
the best single's pairs over it. This script

* ``record``: runs ``etsid gap`` (with low recording thresholds so that every model a
  calibration could name is evaluated) on pairs of a generator and appends one JSON line
  per pair (the criterion's numbers, the label; records made before the tiers method was
  deleted also hold its answer under ``old``, for the comparison);
* ``fit``: sets the thresholds from the records of the generators named, at a stated
  false-positive rate, and writes the calibration file (by default the package's
  ``etsid/gap/calibration.json``):
  - ``mismatch_ratio``: the largest dynamic channel's ratio of the no-effect pairs (a
    sensor-consistency channel is judged by its offset's F law at the rate,
    etsid/gap/criterion.py ``offset_limit``, nothing calibrated),
  - ``gain_per_sample``: the best significant single's gain of the no-effect pairs (an
    effect is named only when its gain is also significant at the rate among the singles
    tried, ``criterion.significant``),
  - ``pair_gain_per_sample``: the best second effect's gain over a correctly named first
    effect on the single-effect pairs, and never below ``gain_per_sample`` (a second
    effect's extra gain comes from the same model errors as a first effect's);
  each the largest recorded value: a new exchangeable pair exceeds the largest of n with
  probability 1/(n + 1), the rate the records can show (printed, and written to the file
  as ``supported_rate``); no tail model extrapolates below it;
* ``score``: decides the recorded pairs of a generator again under a calibration file and
  prints named-right, false positives, out-of-vocabulary answers, the reliability of
  confidence ≥ 0.9 and, where recorded, the old (tiers) method pair by pair.

Leave-one-generator-out::

    python benchmarks/gap_calibrate.py record --etsid-seeds 700,701 --out rec.jsonl
    python benchmarks/gap_calibrate.py record --dir SETDIR --out rec.jsonl
    python benchmarks/gap_calibrate.py record --again old.jsonl [--dir SETDIR] --out rec.jsonl
    python benchmarks/gap_calibrate.py fit rec.jsonl --generators pyflyt,multirotor \\
        --out cal_etsid.json
    python benchmarks/gap_calibrate.py score rec.jsonl --generator etsid --calibration \\
        cal_etsid.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from etsid.gap.calibration import (
    CALIBRATION_ENV,
    CALIBRATION_PATH,
    Calibration,
    calibration_dict,
    load_calibration,
)
from etsid.gap.criterion import answer_size, choose, mismatched, significant
from etsid.gap.detectable import (
    BELOW_CONFIDENCE,
    BY_NAME,
    cap_below_detectable,
    detectable_sizes,
)
from etsid.gap.likelihood import AIRFRAME_SCALES
from etsid.gap.scale import scale_mismatched, significant_delta

RECORDING = {"mismatch_ratio": 1.0, "gain_per_sample": 0.004, "pair_gain_per_sample": 0.004}
RECORDING_RATE = 0.5
"""Thresholds and rate while recording: looser than any a calibration sets, so that every
model a calibrated run could name (pairs included) is fully evaluated."""
CONFIDENT = 0.9
GYRO_SCALE_FACTOR_TOLERANCE = 0.01
"""Least gyro-scale tolerance (a slope difference, etsid/gap/scale.py): a healthy MEMS gyro's
sensitivity differs from its nominal by up to ±1 % (ICM-20602 datasheet, DS-000176, the
tightest of the common flight-controller gyros), and PX4 applies no gyro scale calibration,
so a real gyro may differ this much from a simulated ideal one without a fault."""


# ---------------------------------------------------------------- record
def truth_sizes(expected: str, truth: dict[str, Any]) -> dict[str, list[list[Any]]]:
    """Per expected effect, the true size of each parameter it changes as ``[parameter,
    direction, size]`` in the units of gap.json's ``detectable`` (scales as |s − 1|), from
    a generator's truth (the third-party sets' ``labels.json`` or etsid's ``make_pair``).
    An effect whose truth does not map onto its parameters is left out: only a
    ``detectable`` status of ``insufficient`` can then call it below detectable."""
    out: dict[str, list[list[Any]]] = {}

    def scale(effect: str, key: str, param: str = "scale") -> None:
        if key in truth:
            v = float(truth[key])
            out[effect] = [[param, "up" if v >= 1.0 else "down", abs(v - 1.0)]]

    def components(effect: str, key: str, names: tuple[str, ...]) -> None:
        if key in truth:
            vals = np.ravel(np.asarray(truth[key], dtype=float))[:len(names)]
            out[effect] = [[n, "up" if v >= 0 else "down", abs(float(v))]
                           for n, v in zip(names, vals, strict=False) if v != 0.0]

    for effect in expected.split("+"):
        if effect == "thrust_scale":
            scale(effect, "scale")
        elif effect == "inertia_scale":
            scale(effect, "inertia")
        elif effect == "yaw_torque_scale":
            scale(effect, "yaw_scale")
        elif effect == "mass":
            scale(effect, "mass_scale", "ratio")
        elif effect == "time_delay" and "delay" in truth:
            out[effect] = [["delay", "up", float(truth["delay"])]]
        elif effect == "rate_damping" and "rate_damping" in truth:  # on all three axes
            d = float(truth["rate_damping"])
            out[effect] = [["damping", "up", d], ["yaw", "up", d]]
        elif effect in ("gyro_bias", "accel_bias"):
            components(effect, "bias_frd" if "bias_frd" in truth else "bias",
                       ("bx", "by", "bz"))
    return out


def stated_sizes(row: dict[str, Any], cal: Calibration) -> dict[str, Any]:
    """The pair's detectable sizes under ``cal`` (from the threshold-free evidence a record
    holds; a record made before it was kept: the sizes as recorded)."""
    evidence = (row.get("criterion") or {}).get("detectable_evidence")
    if evidence:
        return detectable_sizes(evidence, cal)
    return row.get("detectable") or {}


def below_detectable(effect: str, row: dict[str, Any], cal: Calibration) -> bool:
    """Whether the pair's detectable sizes under ``cal`` say it could not have seen
    ``effect`` at its true size: the effect is ``insufficient`` at any size, or every
    parameter it changes is below the stated size in its direction (None there: not within
    the parameter's range)."""
    entry = stated_sizes(row, cal).get(effect)
    if not entry:
        return False
    if entry.get("status") == "insufficient":
        return True
    sizes = (row.get("truth_sizes") or {}).get(effect)
    if not sizes:
        return False
    per = entry.get("per_parameter") or {}
    for param, way, size in sizes:
        limit = (per.get(param) or {}).get(way)
        if limit is not None and size >= float(limit):
            return False
    return True


def _answer(data: dict[str, Any]) -> str:
    named = sorted(e["name"] for e in data.get("effects", []) if e["name"] != "unexplained")
    return "+".join(named) if named else str(data.get("verdict"))


def _etsid_pairs(seeds: list[int], labels: list[str] | None, wanted: set[str] | None):
    from gap_concealed import EFFECTS, make_pair
    for s in seeds:
        for j, effect in enumerate(EFFECTS):
            pid = f"etsid-{s * 100 + j}"
            if (labels and effect not in labels) or (wanted and pid not in wanted):
                continue
            sim, real, truth = make_pair(effect, s * 100 + j)
            expected = "+".join(sorted(truth["effects"])) or "consistent"
            yield pid, effect, expected, False, sim, real, truth


def _dir_pairs(folder: Path, labels: list[str] | None, wanted: set[str] | None):
    from thirdparty.common import expected_name, out_of_vocabulary

    from etsid.ingest import read_log
    entries = json.loads((folder / "labels.json").read_text())["pairs"]
    for e in entries:
        if (labels and e["label"] not in labels) or (wanted and e["id"] not in wanted):
            continue
        sim = read_log(folder / e["sim_log"])
        real = read_log(folder / e["real_log"])
        # the expectation of today's vocabulary, not the one written at generation
        yield (e["id"], e["label"], expected_name(e["label"], e["sim"]),
               out_of_vocabulary(e["label"], e["sim"]), sim, real, e.get("truth", {}))


def record(args: argparse.Namespace) -> None:
    from etsid.gap.run import analyse

    rec_file = Path(args.out).with_suffix(".recording.json")
    rec_file.write_text(json.dumps({"schema": "etsid.gap.calibration/1",
                                    "false_positive_rate": RECORDING_RATE,
                                    "thresholds": RECORDING,
                                    "source": {"note": "recording thresholds"}}))
    labels = args.only.split(",") if args.only else None
    again = {str(r["id"]) for r in load([args.again])} if args.again else None
    seeds = ([int(s) for s in args.etsid_seeds.split(",")] if args.etsid_seeds else
             sorted({int(i.split("-")[1]) // 100 for i in again or () if i.startswith("etsid-")}))
    done = {str(r["id"]) for r in load([args.out])} if Path(args.out).exists() else set()
    if done:
        print(f"{len(done)} pairs already in {args.out}: not recorded again", flush=True)
    wanted = again - done if again is not None else None
    if wanted is not None and not wanted:
        return
    pairs = (_etsid_pairs(seeds, labels, wanted) if seeds
             else _dir_pairs(Path(args.dir), labels, wanted))
    for pid, label, expected, oov, sim, real, truth in pairs:
        if pid in done:
            continue
        gen = pid.split("-")[0]
        row: dict[str, Any] = {"id": pid, "generator": gen, "label": label,
                               "expected": expected, "oov": oov,
                               "truth_sizes": truth_sizes(expected, truth)}
        os.environ[CALIBRATION_ENV] = str(rec_file)
        t0 = time.process_time()
        data = analyse(sim, real, "SIM", "REAL").data
        row["seconds_new"] = round(time.process_time() - t0, 1)
        row["verdict"] = data["verdict"]
        row["criterion"] = data.get("criterion")
        row["effect_confidence"] = {e["name"]: e["confidence"] for e in data["effects"]}
        # the sizes under the loose recording thresholds mean nothing: a record keeps the
        # threshold-free evidence (criterion.detectable_evidence), stated again by score
        with open(args.out, "a", encoding="utf-8") as out:
            out.write(json.dumps(row) + "\n")
        print(f"{pid:18s} {label:24s} {row['seconds_new']:5.1f} s", flush=True)


# ---------------------------------------------------------------- decide
def decide(row: dict[str, Any], cal: Calibration) -> dict[str, Any]:
    """The answer the criterion gives a recorded pair under ``cal``: verdict, names and
    their confidences (the recorded pseudo-BMA weights)."""
    crit = row.get("criterion")
    if not crit:  # decided before the criterion (insufficient, different-vehicle)
        return {"answer": row["verdict"], "verdict": row["verdict"], "confidence": {}}
    models = crit["models"]
    name = choose(models, cal, crit.get("after_lead"), crit.get("offset"))
    if name is not None:
        m = next(m for m in models if m["name"] == name)
        theta = m["theta"]
        i = 0
        for part in name.split("+"):
            lo, hi = AIRFRAME_SCALES.get(part, (-np.inf, np.inf))
            if not lo <= theta[i] <= hi:
                return {"answer": "different-vehicle", "verdict": "different-vehicle",
                        "confidence": {}}
            i += _n_params(part, models, theta)
    best = next((m["gain"] for m in models if m["name"] == name), -np.inf) if name else -np.inf
    top = max((m["gain"] for m in models if "+" not in m["name"]), default=-np.inf)
    for m in models:  # the single that explains most is an airframe scale held at its bound
        if (m.get("refused", "").startswith("at bound") and "+" not in m["name"]
                and m["per_sample"] > cal.gain_per_sample and m["gain"] > best
                and m["gain"] >= top):
            lo, hi = AIRFRAME_SCALES.get(m["name"], (-np.inf, np.inf))
            if not lo <= m["theta"][0] <= hi:
                return {"answer": "different-vehicle", "verdict": "different-vehicle",
                        "confidence": {}}
    scaled = scale_mismatched(crit.get("scale", {}), cal)  # left after every model
    mismatch = bool(mismatched(crit["innovation_ratio"], crit.get("offset", {}), cal) or scaled)
    if name is None:
        verdict = "mismatch" if mismatch else "consistent"
        return {"answer": verdict, "verdict": verdict, "confidence": {}}
    conf = {}
    size = answer_size(name)  # weights are among the models of the answer's size
    for part in name.split("+"):
        conf[part] = float(sum(m["weight"] for m in models
                               if answer_size(m["name"]) == size
                               and part in m["name"].split("+")))
    lead = crit.get("after_lead") or {}
    if scaled or ("+" not in name and lead.get("name") == name and mismatched(
            lead["ratio"], {c: tuple(v) for c, v in lead.get("offset", {}).items()}, cal)):
        # a partial explanation (the package's likelihood.cap_partial); the records hold
        # the held-out channels after a single effect only, so a pair is capped here by
        # what the lead leaves or by a gyro scale (which every model leaves)
        conf = {k: min(v, BELOW_CONFIDENCE) for k, v in conf.items()}
    # as the package does (likelihood.py): a name fitted below the size this pair can
    # detect, or that it cannot detect at any size, is a hint
    named = _fitted(name, theta, conf)
    cap_below_detectable(named, stated_sizes(row, cal))
    return {"answer": "+".join(sorted(name.split("+"))), "verdict": "mismatch",
            "confidence": {e["name"]: e["confidence"] for e in named}}


def _fitted(name: str, theta: list[float], conf: dict[str, float]) -> list[dict[str, Any]]:
    """The answer's effects as gap.json's entries (name, confidence, fitted parameters), the
    pair's parameters split in the order of its parts."""
    out, i = [], 0
    for part in name.split("+"):
        params = BY_NAME[part].params if part in BY_NAME else ()
        out.append({"name": part, "confidence": conf[part],
                    "parameters": {p.name: {"value": float(theta[i + j])}
                                   for j, p in enumerate(params)}})
        i += len(params)
    return out


def _n_params(part: str, models: list[dict[str, Any]], theta: list[float]) -> int:
    single = next((m for m in models if m["name"] == part), None)
    return len(single["theta"]) if single else len(theta)


def _same(expected: str, named: str) -> bool:
    from thirdparty.common import same_answer
    return same_answer(expected, named)


def named_in(expected: str, name: str) -> bool:
    """Whether the one effect ``name`` is one of the ``expected`` answer's effects, under
    the same equivalences as :func:`_same` (a mass for a thrust scale + delay's thrust
    scale is right, as a mass for a thrust scale alone is)."""
    return any(_same(part, name) for part in expected.split("+"))


# ---------------------------------------------------------------- fit
def _largest(values: list[float]) -> float:
    """The threshold no recorded value exceeds: the largest of ``values`` (a value ≤ 0, a
    model that loses to its base, counts as 0). For exchangeable pairs a new one exceeds
    the largest of n with probability 1/(n + 1), the rate n pairs can show; a tail model
    that extrapolates to a smaller rate from a few pairs is not used (round 2: a
    log-normal over values spread across two decades put the 1 % quantile 2–2.5× above
    every recorded value and above several true effects)."""
    return float(max([0.0] + [float(x) for x in values]))


def load(paths: list[str]) -> list[dict[str, Any]]:
    """Every record of ``paths``, in order; a pair recorded again in a later file replaces
    its earlier record (a set's no-effect pairs re-recorded after a fix, say)."""
    rows: dict[str, dict[str, Any]] = {}
    for p in paths:
        for line in Path(p).read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                rows[str(row.get("id", len(rows)))] = row
    return list(rows.values())


def fit(args: argparse.Namespace, rows: list[dict[str, Any]] | None = None) -> None:
    """Fit and write a calibration from ``args.records`` (or from ``rows`` already loaded)."""
    rows = [r for r in (load(args.records) if rows is None else rows)
            if r["generator"] in args.generators.split(",")]
    none = [r for r in rows if r["label"] == "none" and r.get("criterion")]
    ratios = [max(v for c, v in r["criterion"]["innovation_ratio"].items()
                  if c not in r["criterion"].get("offset", {})) for r in none]
    gains = []
    for r in none:
        models = r["criterion"]["models"]
        n_singles = sum("+" not in m["name"] for m in models)
        singles = [m["per_sample"] for m in models
                   if "+" not in m["name"] and not m.get("refused")
                   and significant(m["gain"], m.get("gain_se"), n_singles, args.fpr)]
        gains.append(max(singles) if singles else 0.0)
    if not none:
        raise SystemExit("no no-effect pairs recorded for " + args.generators)
    alpha = args.fpr
    scales = [max([abs(d) for d, se, dof in r["criterion"]["scale"].values()
                   if significant_delta(d, se, dof, len(r["criterion"]["scale"]), alpha)]
                  + [0.0])
              for r in none if "scale" in r["criterion"]]
    mismatch_ratio = _largest(ratios)
    probe = Calibration(mismatch_ratio, 0.0, 0.0, alpha, {})
    extras = []
    for r in rows:
        if r["label"] == "none" or r.get("oov") or "+" in r["expected"] or not r.get("criterion"):
            continue
        crit = r["criterion"]
        models = crit["models"]
        singles = sorted((m for m in models if "+" not in m["name"] and not m.get("refused")),
                         key=lambda m: -m["gain"])
        if not singles or not _same(r["expected"], singles[0]["name"]):
            continue
        lead = singles[0]
        after = crit.get("after_lead")
        if after and after.get("name") == lead["name"] and not mismatched(
                after["ratio"], after.get("offset", {}), probe):
            continue  # nothing left after the first effect: no second one is sought
        pairs = [m for m in models if "+" in m["name"]
                 and m["name"].split("+")[0] == lead["name"] and not m.get("refused")]
        ex = [(m["gain"] - lead["gain"]) / max(m["n_scored"], 1) for m in pairs
              if significant(m["gain"] - lead["gain"], m.get("extra_se"), len(pairs), alpha)]
        extras.append(max(ex) if ex else 0.0)
    cal = Calibration(
        mismatch_ratio=mismatch_ratio, gain_per_sample=_largest(gains),
        pair_gain_per_sample=max(_largest(extras), _largest(gains)),
        false_positive_rate=alpha,
        scale_tolerance=(max(_largest(scales), GYRO_SCALE_FACTOR_TOLERANCE) if scales
                         else float("inf")),
        source={"generators": args.generators.split(","),
                "records": [Path(r).name for r in args.records],
                "no_effect_pairs": len(none), "single_effect_pairs": len(extras),
                "rule": "largest recorded value of the no-effect pairs' largest dynamic "
                        "channel ratio and best significant single gain, and of the "
                        "single-effect pairs' best significant second-effect gain where a "
                        "channel is still mismatched after the first, and no lower than "
                        "the single's threshold: a second effect's extra gain has the same "
                        "sources of model error as a first's (a new pair exceeds "
                        "the largest of n with probability 1/(n + 1)); every gain must also "
                        "be significant at the rate among the models tried (Bonferroni); "
                        "the largest significant gyro-scale difference of the no-effect "
                        "pairs (etsid/gap/scale.py), no lower than a healthy gyro's "
                        f"datasheet sensitivity tolerance ({GYRO_SCALE_FACTOR_TOLERANCE:g})",
                "supported_rate": round(1.0 / (len(none) + 1), 4),
                "written": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")})
    out = Path(args.out) if args.out else CALIBRATION_PATH
    out.write_text(json.dumps(calibration_dict(cal), indent=1) + "\n")
    print(f"{len(none)} no-effect pairs ({args.generators}): largest channel ratio "
          f"{np.round(sorted(ratios), 2).tolist()}")
    print(f"  best single gain per sample {np.round(sorted(gains), 4).tolist()}")
    print("  largest significant gyro-scale difference "
          f"{np.round(sorted(scales), 4).tolist()}")
    print(f"{len(extras)} single-effect pairs named right with a channel left: best "
          f"significant second-effect gain per sample {np.round(sorted(extras), 4).tolist()}")
    print(f"at a false-positive rate of {alpha:g}: mismatch_ratio {cal.mismatch_ratio:.3g}, "
          f"gain_per_sample {cal.gain_per_sample:.3g}, pair_gain_per_sample "
          f"{cal.pair_gain_per_sample:.3g}, scale_tolerance {cal.scale_tolerance:.3g}; "
          f"written to {out}")


# ---------------------------------------------------------------- score
ANSWERS = ("consistent", "mismatch", "insufficient", "different-vehicle")


def honest_miss(expected: str, decided: dict[str, Any], row: dict[str, Any],
                cal: Calibration) -> bool:
    """A pair not named right but answered honestly (issue 38's rule): nothing named that
    the truth lacks, not called another vehicle, and every expected effect left unnamed
    below the pair's stated detectable size (:func:`below_detectable`)."""
    if decided["verdict"] == "different-vehicle":
        return False
    named = [] if decided["answer"] in ANSWERS else decided["answer"].split("+")
    want = expected.split("+")
    if any(not any(_same(w, n) for w in want) for n in named):
        return False
    missing = [w for w in want if not any(_same(w, n) for n in named)]
    return bool(missing) and all(below_detectable(w, row, cal) for w in missing)


def judged(row: dict[str, Any], decided: dict[str, Any], cal: Calibration
           ) -> tuple[bool, bool]:
    """(right, honest) of a recorded pair's answer ``decided``: an out-of-vocabulary pair is
    right when called a mismatch with nothing named at ≥ 0.5; any other when named as
    expected, and honest when not but :func:`honest_miss` (effect pairs only)."""
    if row.get("oov"):
        return (decided["verdict"] != "consistent"
                and not any(c >= 0.5 for c in decided["confidence"].values())), False
    ok = _same(row["expected"], decided["answer"])
    honest = (not ok and row["label"] != "none"
              and honest_miss(row["expected"], decided, row, cal))
    return ok, honest


def score(args: argparse.Namespace) -> None:
    cal = load_calibration(args.calibration)
    rows = [r for r in load(args.records) if r["generator"] in args.generator.split(",")]
    right = total = fp = n_none = conf_n = conf_ok = oov_bad = n_honest = 0
    old_right = old_total = both = only_new = only_old = 0
    for r in rows:
        d = decide(r, cal)
        exp = r["expected"]
        ok, honest = judged(r, d, cal)
        if r.get("oov"):
            oov_bad += any(c >= 0.5 for c in d["confidence"].values())
        else:
            total += 1
            right += ok
            n_honest += honest
        if r["label"] == "none":
            n_none += 1
            fp += d["verdict"] != "consistent"
        for name, c in d["confidence"].items():
            if c >= CONFIDENT:
                conf_n += 1
                conf_ok += named_in(exp, name)
        old = r.get("old")
        old_ok = None
        if old is not None and not r.get("oov"):
            old_ok = _same(exp, old["answer"])
            old_total += 1
            old_right += old_ok
            both += ok and old_ok
            only_new += ok and not old_ok
            only_old += old_ok and not ok
        mark = "" if old_ok is None else ("ok" if old_ok else "NO")
        print(f"{r['id']:18s} {r['label']:24s} expected {exp:24s} new {d['answer']:26s} "
              f"{'ok ' if ok else ('HON' if honest else 'NO ')}"
              + (f" old {old['answer']:24s} {mark}" if old else "")
              + "  " + ", ".join(f"{k} {v:.2f}" for k, v in d["confidence"].items()))
    print(f"\n{args.generator} under {args.calibration or 'the package calibration'}: "
          f"named right {right}/{total}; below the detectable size and said so (honest) "
          f"{n_honest}; false positives {fp}/{n_none}; out-of-vocabulary "
          f"named at confidence >= 0.5: {oov_bad}; confidence >= {CONFIDENT}: "
          f"{conf_ok}/{conf_n} right")
    if any(r.get("old") for r in rows):
        print(f"on the {old_total} of these pairs also run with the old method (tiers): old "
              f"named right {old_right}/{old_total}; both right {both}, only new {only_new}, "
              f"only old {only_old}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="run etsid gap on pairs, append the criterion's numbers")
    r.add_argument("--etsid-seeds", default=None, help="etsid's own generator: seeds")
    r.add_argument("--dir", default=None, help="a third-party set (gap_thirdparty --generate)")
    r.add_argument("--only", default=None, help="comma-separated labels")
    r.add_argument("--again", default=None,
                   help="an earlier record file: record its pairs again (etsid's seeds from "
                        "its ids; a third-party set's from --dir)")
    r.add_argument("--out", required=True, help="JSON-lines file to append to")
    f = sub.add_parser("fit", help="thresholds from records, written to a calibration file")
    f.add_argument("records", nargs="+")
    f.add_argument("--generators", required=True, help="e.g. pyflyt,multirotor")
    f.add_argument("--fpr", type=float, default=0.01, help="false-positive rate")
    f.add_argument("--out", default=None, help="default: the package's calibration.json")
    s = sub.add_parser("score", help="decide recorded pairs again under a calibration")
    s.add_argument("records", nargs="+")
    s.add_argument("--generator", required=True)
    s.add_argument("--calibration", default=None)
    args = ap.parse_args()
    {"record": record, "fit": fit, "score": score}[args.cmd](args)


if __name__ == "__main__":
    main()
