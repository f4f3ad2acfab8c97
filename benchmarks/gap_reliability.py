"""Reliability of ``etsid gap``'s confidence: of the effects named with confidence c, how many
are right? Reads the records of ``benchmarks/gap_concealed.py --record FILE`` (one JSON line
per named effect) and prints the table per confidence bin; ``--plot PNG`` draws the
reliability diagram (docs/gap.md).

Run::

    python benchmarks/gap_concealed.py --record gap_records.jsonl          # held-out seeds
    python benchmarks/gap_concealed.py --dev --record gap_records.jsonl    # dev seeds
    python benchmarks/gap_reliability.py gap_records.jsonl --plot docs/gap_reliability.png
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

EDGES = (0.0, 0.3, 0.5, 0.7, 0.9, 1.0001)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records", nargs="+", help="JSON-lines files of gap_concealed.py --record")
    ap.add_argument("--plot", default=None, help="write the reliability diagram here (PNG)")
    args = ap.parse_args()
    rows = [json.loads(line) for path in args.records
            for line in Path(path).read_text(encoding="utf-8").splitlines() if line.strip()]
    rows = [r for r in rows if r["name"] != "unexplained"]
    conf = np.array([r["confidence"] for r in rows])
    right = np.array([r["right"] for r in rows], dtype=float)
    print(f"{len(rows)} named effects")
    print(f"{'confidence':>12} {'named':>6} {'right':>6} {'share right':>12}")
    centers, shares, counts = [], [], []
    for lo, hi in itertools.pairwise(EDGES):
        sel = (conf >= lo) & (conf < hi)
        if not np.any(sel):
            continue
        share = float(right[sel].mean())
        centers.append(float(conf[sel].mean()))
        shares.append(share)
        counts.append(int(sel.sum()))
        print(f"{lo:5.2f}–{min(hi, 1.0):4.2f} {int(sel.sum()):6d} {int(right[sel].sum()):6d} "
              f"{100 * share:11.0f} %")
    high = conf >= 0.9
    if np.any(high):
        print(f"confidence >= 0.9: {int(right[high].sum())}/{int(high.sum())} right "
              f"({100 * right[high].mean():.0f} %)")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(4.5, 4.2))
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
        ax.plot(centers, shares, "o-", color="C0", label="etsid gap")
        for x, y, n in zip(centers, shares, counts, strict=True):
            ax.annotate(f"n={n}", (x, y), textcoords="offset points", xytext=(4, -12),
                        fontsize=8)
        ax.set_xlabel("reported confidence (bin mean)")
        ax.set_ylabel("share of named effects that are right")
        ax.set_xlim(0, 1.02)
        ax.set_ylim(0, 1.05)
        ax.legend(loc="upper left", fontsize=8)
        ax.set_title("Reliability of named effects", fontsize=10)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
