"""Recompute the gyro-scale test of recorded pairs (``criterion.scale`` of gap.json) in place
of re-recording them: the test reads only the two prepared flights and decides nothing the
criterion uses, so a change to it needs the pairs again but not the criterion.

Every pair is made again (etsid's pairs from their seeds; third-party pairs from folders
written by ``gap_thirdparty.py --generate``) and its scale test written anew. The flights
made again are the recorded ones only where the simulator repeats itself to the last digit:
on another machine or library build a closed-loop flight of 30-45 s drifts (etsid's and
PyFlyt's did, by a median of a few tenths of a standard error in the slope difference), so
the script prints how far the recomputed differences are from the recorded ones and the
records it writes are a regenerated pair's scale test beside the recorded pair's criterion.
``--plain`` also writes the same tests with the previous degrees of freedom (the shorter
flight's blocks less one), for a comparison on the same flights::

    python benchmarks/gap_rescale.py benchmarks/records/gap_s25/seen_py.jsonl \
        --dir gen/640_py --dir gen/650_py --out new/seen_py.jsonl --plain old/seen_py.jsonl
    python benchmarks/gap_rescale.py benchmarks/records/gap_s25/seen_etsid.jsonl --etsid \
        --out new/seen_etsid.jsonl
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np

from etsid.gap.run import prepare_pair
from etsid.gap.scale import channel_samples, scale_tests
from etsid.gap.signals import Flight

sys.path.insert(0, str(Path(__file__).resolve().parent))

SAME = 1e-9
"""A recomputed slope difference within this of the recorded one (1) is the same flight's."""


def _pairs(args: argparse.Namespace, wanted: set[str]):
    """(id, sim table, real table) of every wanted pair."""
    from gap_calibrate import _dir_pairs, _etsid_pairs
    if args.etsid:
        seeds = sorted({int(pid.split("-")[1]) // 100 for pid in wanted})
        sources = [_etsid_pairs(seeds, None, wanted)]
    else:
        sources = [_dir_pairs(Path(folder), None, wanted) for folder in args.dir]
    for pairs in sources:
        for pid, _, _, _, sim, real, _ in pairs:
            yield pid, sim, real


def blocks(flight: Flight) -> dict[str, int]:
    """Gyro channel → the number of blocks of its airborne samples (the previous test's G)."""
    return {c: int(np.unique((idx - idx[0]) // block).size)
            for c, _, _, idx, block in channel_samples(flight) if idx.size}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", type=Path)
    ap.add_argument("--dir", action="append", default=[], help="generated third-party pairs")
    ap.add_argument("--etsid", action="store_true", help="etsid's pairs, from their seeds")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--plain", type=Path, default=None,
                    help="also write the tests with the previous degrees of freedom")
    args = ap.parse_args()
    rows = [json.loads(line) for line in args.records.read_text().splitlines() if line]
    plain_rows = copy.deepcopy(rows)
    by_id = {r["id"]: r for r in rows if (r.get("criterion") or {}).get("scale") is not None}
    plain_by_id = {r["id"]: r for r in plain_rows if r["id"] in by_id}
    drift: list[float] = []
    done: set[str] = set()
    for pid, sim_table, real_table in _pairs(args, set(by_id)):
        old = by_id[pid]["criterion"]["scale"]
        sim, real = prepare_pair(sim_table, real_table, "sim", "real")
        new = scale_tests(sim, real)
        if set(new) != set(old):
            sys.exit(f"{args.records}: {pid} tests {sorted(new)}, the record {sorted(old)}")
        drift += [abs(new[c][0] - old[c][0]) / max(new[c][1], 1e-12) for c in new
                  if abs(new[c][0] - old[c][0]) > SAME]
        by_id[pid]["criterion"]["scale"] = {c: list(v) for c, v in new.items()}
        done.add(pid)
        g_sim, g_real = blocks(sim), blocks(real)
        plain_by_id[pid]["criterion"]["scale"] = {
            c: [v[0], v[1], min(g_sim[c], g_real[c]) - 1] for c, v in new.items()}
        shown = ", ".join(f"{c} {v[0]:+.4f}/{v[1]:.4f} ({v[2]:.1f} dof)" for c, v in new.items())
        print(f"{pid}: {shown}", flush=True)
    if len(done) < len(by_id):
        sys.exit(f"{args.records}: {len(by_id) - len(done)} of {len(by_id)} pairs with a scale "
                 f"test were not found in the given pairs, e.g. {min(set(by_id) - done)}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("".join(json.dumps(r) + "\n" for r in rows))
    if args.plain:
        args.plain.parent.mkdir(parents=True, exist_ok=True)
        args.plain.write_text("".join(json.dumps(r) + "\n" for r in plain_rows))
    moved = np.array(drift) if drift else np.zeros(1)
    print(f"{args.records}: {len(done)} pairs' gyro-scale tests recomputed; {len(drift)} of "
          f"{3 * len(done)} slope differences moved from the recorded ones (median "
          f"{np.median(moved):.2f}, largest {moved.max():.2f} standard errors) -> {args.out}")


if __name__ == "__main__":
    main()
