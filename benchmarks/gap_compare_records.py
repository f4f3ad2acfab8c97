"""Pair-by-pair comparison of two recorded methods of ``etsid gap``, leave one generator out.

Each side is a set of record files (``gap_calibrate.py record``); for every generator, each
side's rotation is fitted on that side's records of the other two generators
(``gap_calibrate.fit`` rules) and decides that side's records of the held-out generator.
Pairs recorded on both sides (same id) are compared: right on both, only on the new side,
only on the old; "right" as ``gap_calibrate.score`` counts it (named right, or below the
pair's detectable size and said so; out-of-vocabulary pairs: not named at ≥ 0.5).

    python benchmarks/gap_compare_records.py --old OLD.jsonl... --new NEW.jsonl...
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import gap_calibrate as gc

from etsid.gap.calibration import load_calibration

GENERATORS = ("etsid", "pyflyt", "multirotor")


def decided(paths: list[str], held_out: str, scratch: Path) -> dict[str, bool]:
    """Pair id → right, for ``held_out``'s pairs under the rotation fitted on the others."""
    rows = gc.load(paths)
    others = ",".join(g for g in GENERATORS if g != held_out)
    out = scratch / f"cal_{held_out}.json"
    args = argparse.Namespace(records=paths, generators=others, fpr=0.01, out=str(out))
    with contextlib.redirect_stdout(io.StringIO()):
        gc.fit(args, rows)
    cal = load_calibration(out)
    return {str(r["id"]): any(gc.judged(r, gc.decide(r, cal), cal))
            for r in rows if r["generator"] == held_out}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", nargs="+", required=True, help="the old method's records")
    ap.add_argument("--new", nargs="+", required=True, help="the new method's records")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gap_compare_") as tmp:
        for g in GENERATORS:
            (Path(tmp) / "old").mkdir(exist_ok=True)
            (Path(tmp) / "new").mkdir(exist_ok=True)
            old = decided(args.old, g, Path(tmp) / "old")
            new = decided(args.new, g, Path(tmp) / "new")
            common = sorted(set(old) & set(new))
            both = sum(old[i] and new[i] for i in common)
            only_new = [i for i in common if new[i] and not old[i]]
            only_old = [i for i in common if old[i] and not new[i]]
            print(f"{g}: {len(common)} pairs on both sides; right on both {both}, only new "
                  f"{len(only_new)}, only old {len(only_old)}, neither "
                  f"{len(common) - both - len(only_new) - len(only_old)}")
            print(f"  only new: {', '.join(only_new) or '-'}")
            print(f"  only old: {', '.join(only_old) or '-'}")


if __name__ == "__main__":
    main()
