"""Offline estimate of one proposed rule of ``etsid gap`` on recorded pairs (session 12).

The proposal: a sensor-consistency channel's held-out gain is measured against the noise
model's own null, ``e = β + u`` with the flight offset ``β ~ N(0, τ²)`` drawn once per flight
(the law the mismatch rule already tests with F(1, k)). Against that null a model that
removes the offset gains ``½ z²`` nats on the channel, ``z²`` REAL's offset statistic
(etsid/gap/noise.py ``offset_z2``), instead of ``½ m (cβ)² / s²``, which grows with the
``m`` samples. The records hold each model's gain per channel and REAL's offset statistic
under the null, so every channel's recorded gain is capped at half that statistic, the
thresholds are fitted again under the cap, and each generator is scored under the other
two's calibration, before and after. An estimate: the block standard errors are the
recorded ones. The package implements the rule since session 13
(``etsid.gap.criterion.LikelihoodScorer``, with the blocks scaled too); on records made
since, the cap here changes nothing.

    python benchmarks/gap_offset_null.py RECORDS... [--fresh RECORDS...]
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import gap_calibrate as gc

GENERATORS = ("etsid", "pyflyt", "multirotor")


def capped(row: dict[str, Any]) -> dict[str, Any]:
    """A copy of a record whose models' gains on each sensor-consistency channel are at
    most half REAL's offset statistic there (nats; per-sample gains follow)."""
    crit = row.get("criterion")
    if not crit:
        return row
    off = crit.get("offset", {})
    out = copy.deepcopy(row)
    for m in out["criterion"]["models"]:
        cut = sum(max(0.0, g - 0.5 * float(off[c][0]))
                  for c, (g, _) in m.get("by_channel", {}).items()
                  if c in off and np.isfinite(off[c][0]))
        m["gain"] -= cut
        m["per_sample"] = m["gain"] / max(m["n_scored"], 1)
    return out


def tally(rows: list[dict[str, Any]], cal: Any) -> str:
    """Effects named right or honestly below their detectable size, and false positives."""
    good = effects = fp = none = 0
    for r in rows:
        if r.get("oov"):
            continue
        d = gc.decide(r, cal)
        if r["label"] == "none":
            none += 1
            fp += d["verdict"] != "consistent"
            continue
        effects += 1
        good += gc._same(r["expected"], d["answer"]) or gc.honest_miss(
            r["expected"], d, r, cal)
    return f"right or honest {good}/{effects}, false positives {fp}/{none}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records", nargs="+", help="seen records (calibration and scoring)")
    ap.add_argument("--fresh", nargs="*", default=[], help="held-out draws, scored only")
    args = ap.parse_args()
    seen = gc.load(args.records)
    fresh = gc.load(args.fresh) if args.fresh else []
    scratch = Path(tempfile.mkdtemp(prefix="gap_offset_null_"))
    for rule, prep in (("as recorded", lambda r: r), ("offset null", capped)):
        rows = [prep(r) for r in seen]
        later = [prep(r) for r in fresh]
        for g in GENERATORS:
            others = ",".join(x for x in GENERATORS if x != g)
            out = scratch / f"{g}_{rule.replace(' ', '_')}.json"
            with contextlib.redirect_stdout(io.StringIO()):
                gc.fit(argparse.Namespace(records=[], generators=others, fpr=0.01,
                                          out=str(out)), rows=rows)
            cal = gc.load_calibration(str(out))
            line = f"{rule:12s} {g:10s} gain {cal.gain_per_sample:.4f}: seen " + tally(
                [r for r in rows if r["generator"] == g], cal)
            if later:
                line += "; fresh " + tally([r for r in later if r["generator"] == g], cal)
            print(line, flush=True)
    shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
