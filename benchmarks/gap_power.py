"""Does a pair's stated detectable size say where the criterion starts to name an effect?

``etsid gap`` states, for every vocabulary effect, the smallest size this pair could have
seen (``detectable`` in gap.json, a power analysis: :mod:`etsid.gap.detectable`). A user
reads a ``consistent`` verdict as "nothing above these sizes"; the benchmarks count a miss
below the stated size as honest. Both need the size to be where naming starts: well above
it an effect present should be named, well below it rarely.

This reads a folder of ``gap_calibrate.py record`` files with its rotation calibrations
(``cal_etsid.json``, ``cal_pyflyt.json``, ``cal_multirotor.json``: each generator decided
and its sizes stated under the calibration it was held out of), takes every pair with one
in-vocabulary effect whose true size is known, and prints how often the effect is named
against the ratio of its true size to the stated one (the largest over its parameters).

Run::

    python benchmarks/gap_power.py benchmarks/records/gap_s24
"""

from __future__ import annotations

import argparse
from itertools import pairwise
from pathlib import Path
from typing import Any

from gap_calibrate import _same, decide, load, stated_sizes

from etsid.gap.calibration import Calibration, load_calibration

BINS = (0.0, 0.5, 1.0, 2.0, 4.0, float("inf"))
"""Edges of the true/stated size ratio's bins."""
GENERATOR_CAL = {"etsid": "cal_etsid.json", "pyflyt": "cal_pyflyt.json",
                 "multirotor": "cal_multirotor.json"}


def size_ratio(row: dict[str, Any], effect: str, cal: Calibration) -> float | None:
    """Largest true/stated size over the effect's parameters (0 where a parameter is not
    detectable in its direction within its range); None without a truth or a size."""
    entry = stated_sizes(row, cal).get(effect)
    truth = (row.get("truth_sizes") or {}).get(effect)
    if not entry or not truth:
        return None
    if entry.get("status") == "insufficient":
        return 0.0
    per = entry.get("per_parameter") or {}
    ratios = []
    for param, way, size in truth:
        limit = (per.get(param) or {}).get(way)
        ratios.append(0.0 if limit is None else float(size) / max(float(limit), 1e-300))
    return max(ratios) if ratios else None


def rows_of(folder: Path) -> list[tuple[dict[str, Any], Calibration]]:
    """Every record of the folder with its generator's rotation calibration."""
    cals = {g: load_calibration(str(folder / f)) for g, f in GENERATOR_CAL.items()
            if (folder / f).exists()}
    out = []
    for path in sorted(folder.glob("*.jsonl")):
        for row in load([str(path)]):
            cal = cals.get(str(row.get("generator")))
            if cal is not None:
                out.append((row, cal))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", help="records folder with cal_<generator>.json files")
    args = ap.parse_args()
    counts = [[0, 0] for _ in BINS[:-1]]
    beyond = [0, 0]  # not detectable at any size in range (or in that direction)
    for row, cal in rows_of(Path(args.folder)):
        expected = str(row.get("expected", ""))
        if row.get("oov") or "+" in expected or expected in ("consistent", ""):
            continue
        r = size_ratio(row, expected, cal)
        if r is None:
            continue
        answer = decide(row, cal)["answer"]
        named = any(_same(expected, part) for part in answer.split("+"))
        if r == 0.0:
            beyond[0] += 1
            beyond[1] += named
            continue
        for i, (lo, hi) in enumerate(pairwise(BINS)):
            if lo <= r < hi:
                counts[i][0] += 1
                counts[i][1] += named
    print(f"{args.folder}: single in-vocabulary effects with a known true size")
    print(f"{'true / stated size':>20s} {'pairs':>6s} {'named':>6s} {'share':>6s}")
    for (lo, hi), (n, k) in zip(pairwise(BINS), counts, strict=True):
        label = f"{lo:g}–{hi:g}" if hi != float("inf") else f"≥ {lo:g}"
        share = f"{k / n:.0%}" if n else "–"
        print(f"{label:>20s} {n:6d} {k:6d} {share:>6s}")
    share = f"{beyond[1] / beyond[0]:.0%}" if beyond[0] else "–"
    print(f"{'not in range':>20s} {beyond[0]:6d} {beyond[1]:6d} {share:>6s}")


if __name__ == "__main__":
    main()
