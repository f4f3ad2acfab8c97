"""Fuzz etsid's ingest and rule-base loading with seeded mutants and print the tally.

    python benchmarks/fuzz.py --mutants 3000 --jobs 2
    python benchmarks/fuzz.py --structure


Every mutant of every sample log (tests/fuzz/mutants.py: truncation, byte flips, a zeroed
4 KiB page, a duplicated stretch, appended garbage, damaged ROS 2 metadata) is read with
``etsid ingest`` in a worker process that has a memory limit; a run that does not end
within ``--timeout`` seconds is killed and counted. Prints the tally per format and every
run that is not "read ok" or "clean error" with its seed (add the seed to
tests/fuzz/test_fuzz.py to keep it fixed).

``--files`` runs the hostile files beside the logs (tests/fuzz/files.py: sidecars, vehicle
files, run and batch folders, list files, table metadata, ``--set`` values) the same way.

``--structure`` runs instead the structure-aware cases of tests/fuzz/structure.py
(decompression bombs, one bad message, damaged DataFlash FMT records, recursive ULog
formats, huge counts, FIFOs and devices, terminal escapes), one at a time, each bounded to
30 s and 1 GB, and prints one line per case.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

# this checkout's etsid, in this process and (structure.child_env) in its children
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fuzz"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import files
import mutants
import structure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mutants", type=int, default=300, help="mutants in all (default 300)")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=60.0, help="s per mutant")
    parser.add_argument("--memory-gb", type=float, default=4.0, help="address-space limit")
    parser.add_argument("--formats", default=",".join(mutants.SOURCES))
    parser.add_argument("--rules", type=int, default=0,
                        help="also this many seeded byte mutations of a rules.json (plus the "
                             "fixed hostile variants), through `etsid rules` and `predict`")
    parser.add_argument("--structure", action="store_true",
                        help="run the structure-aware cases instead (tests/fuzz/structure.py)")
    parser.add_argument("--files", action="store_true",
                        help="run the hostile files beside the logs instead (tests/fuzz/"
                             "files.py: sidecars, vehicle files, run and batch folders, list "
                             "files, table metadata, --set values)")
    parser.add_argument("--cases", default="",
                        help="with --structure or --files: these cases only")
    args = parser.parse_args()
    if args.structure or args.files:
        structure_tally(args.cases.split(",") if args.cases else [],
                        files.CASES if args.files else structure.CASES)
        return
    formats = args.formats.split(",")
    todo = [(formats[i % len(formats)], args.first_seed + i) for i in range(args.mutants)]
    tally: dict[str, Counter] = {f: Counter() for f in formats}
    seconds: list[float] = []
    peaks: list[float] = []
    odd = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as root:
        pool = mutants.Pool(args.jobs, args.memory_gb)
        try:
            for source, seed, what, kind, detail, secs, peak in pool.run(todo, root,
                                                                          args.timeout):
                tally[source][kind] += 1
                seconds.append(secs)
                peaks.append(peak)
                if kind not in ("read ok", "clean error"):
                    odd.append((source, seed, what, kind, detail))
                    print(f"  {kind}: {source} seed {seed} ({what}): {detail}", flush=True)
        finally:
            pool.close()
    wall = time.perf_counter() - start
    last = args.first_seed + args.mutants - 1
    print(f"\n{args.mutants} mutants, seeds {args.first_seed}..{last}, "
          f"{args.jobs} workers, {wall:.0f} s wall")
    header = f"{'format':<10}" + "".join(f"{k:>16}" for k in mutants.OUTCOMES)
    print(header)
    total: Counter = Counter()
    for fmt in formats:
        total.update(tally[fmt])
        print(f"{fmt:<10}" + "".join(f"{tally[fmt][k]:>16}" for k in mutants.OUTCOMES))
    print(f"{'all':<10}" + "".join(f"{total[k]:>16}" for k in mutants.OUTCOMES))
    if args.rules:
        rules_tally(args.rules)
    finite = sorted(s for s in seconds if s == s)
    if finite:
        print(f"time per mutant: median {finite[len(finite) // 2]:.2f} s, "
              f"max {finite[-1]:.1f} s; peak worker RSS {max(p for p in peaks if p == p):.0f} MiB")


def structure_tally(names: list[str], every: list[structure.Case]) -> None:
    """Run the cases of ``every`` (all, or those in ``names``) one at a time and print a
    line per case."""
    cases = [c for c in every if not names or c.name in names]
    failed = 0
    print(f"{'case':<24}{'verdict':>8}{'s':>7}{'MB':>7}  detail")
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            verdict = structure.run_case(case, Path(tmp) / case.name)
            failed += not verdict.ok
            print(f"{case.name:<24}{'ok' if verdict.ok else 'FAIL':>8}{verdict.seconds:>7.1f}"
                  f"{verdict.peak_mb:>7.0f}  {verdict.detail}", flush=True)
            shutil.rmtree(Path(tmp) / case.name, ignore_errors=True)
    print(f"\n{len(cases) - failed} of {len(cases)} cases within the bounds "
          f"({structure.TIME_BOUND_S:.0f} s, {structure.MEMORY_BOUND_MB:.0f} MB) with a correct "
          "result")


def rules_tally(count: int) -> None:
    """Run the rule-base variants in this process and print their tally."""
    import json

    root = Path(__file__).resolve().parents[1]
    gas = root / "tests" / "data" / "gas_furnace.csv"
    tally: Counter = Counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        made = mutants.run_cli(["identify", str(gas), "--output", "co2", "--regressors",
                                "co2[k-1],input_gas_rate[k-4]", "--out", str(work / "run"),
                                "--quiet"])
        assert made.kind == "read ok", made.detail
        pristine = json.loads((work / "run" / "rules.json").read_text())
        variants = mutants.rules_variants(pristine, work, mutations=count)
        for what, path in variants:
            for args in (["rules", str(path)], ["predict", str(gas), "--rules", str(path),
                                                "-o", str(work / "p"), "--quiet"]):
                verdict = mutants.run_cli(args, names=path.name)
                tally[verdict.kind] += 1
                if verdict.kind not in ("read ok", "clean error"):
                    print(f"  {verdict.kind}: rules variant {what!r}: {verdict.detail}")
    print(f"\nrule bases: {len(variants)} variants x 2 commands (rules, predict)")
    print("".join(f"{k:>16}" for k in mutants.OUTCOMES))
    print("".join(f"{tally[k]:>16}" for k in mutants.OUTCOMES))


if __name__ == "__main__":
    main()
