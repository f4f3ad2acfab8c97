"""Held-out concealed-effect benchmark of ``etsid gap`` on simulators etsid does not contain.

Pairs (SIM log, "REAL" log with a hidden effect or none) flown in two third-party
multirotor simulators from PyPI (the ``bench`` extra: ``pip install -e ".[bench]"``):

* ``pyflyt`` — PyFlyt on PyBullet: a 27 g Crazyflie-size quadrotor, PyFlyt's cascaded PID,
  120 Hz, written as MCAP (ROS 2, MAVROS topics);
* ``multirotor`` — the ``multirotor`` package: its 10.7 kg Tarot T18 octocopter, its
  ArduPilot-style cascade, 100 Hz, written as MAVLink telemetry logs.

Each seed gives 24 pairs per simulator: every effect of issue 22's vocabulary the simulator
can express, four no-effect pairs, thrust scale + time delay together, and three changes
outside the vocabulary (gyro scale factor, tilted IMU, tilted rotor axes). The vehicle,
controller, sensor model, log format and rate differ from etsid's own simulator and from
each other (docs/gap_benchmarks.md). Labels live only in ``labels.json`` of
the output directory, never in the logs or their names.

Run::

    python benchmarks/gap_thirdparty.py --generate DIR            # seed set 300, both sims
    python benchmarks/gap_thirdparty.py --generate DIR --seeds 301 --sims pyflyt --jobs 2
    python benchmarks/gap_thirdparty.py --inspect DIR              # sanity: ingest, airborne,
                                                                   # excitation (no gap)
    python benchmarks/gap_thirdparty.py --score DIR --jobs 2       # runs etsid gap per pair
    python benchmarks/gap_thirdparty.py --timing DIR               # CPU s per pair, one core
    python benchmarks/gap_thirdparty.py --generate DIR --seeds 308 --duration 90 --jobs 2
                                                                   # 90 s flights (speed)
    python benchmarks/gap_thirdparty.py --detectability DIR        # oracle: does the true
                                                                   # law show in the logs
    python benchmarks/gap_thirdparty.py --generate DIR --seeds 950 --sims pyflyt --excite
                                          # PyFlyt flights with 3-2-1-1 inputs at the mixer
    python benchmarks/gap_thirdparty.py --generate DIR --seeds 321 --sims pyflyt \
        --motor-noise 0                   # ablation: PyFlyt without its motor noise

``--score`` prints, per simulator and overall: named correctly X/N, false positives on the
no-effect pairs, the confusion matrix, a per-effect table and, for the out-of-vocabulary
changes, whether the answer was ``unexplained``/caveated or a confident wrong name.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from thirdparty.common import (
    expected_name,
    jsonable,
    out_of_vocabulary,
    same_answer,
    to_table,
)

SIMULATORS = ("pyflyt", "multirotor")
DEFAULT_SEEDS = (300,)
"""The first held-out seed set; later sets: 301, 302, … (never looked at before a run)."""
DURATIONS = {"pyflyt": (40.0, 60.0), "multirotor": (45.0, 70.0)}
"""Flight durations, s (take-off and landing included), drawn per flight."""
CONFIDENT = 0.9
"""A named effect at or above this confidence without a caveat is a confident answer."""


def simulator(name: str) -> ModuleType:
    """The pair module of simulator ``name``; exits with one line when the simulator
    package is not installed."""
    package = {"pyflyt": "PyFlyt", "multirotor": "multirotor"}.get(name)
    if package is not None:
        try:
            __import__(package)
        except ImportError:
            raise SystemExit(f"simulator {name!r} is not installed: pip install -e "
                             "'.[bench]'") from None
    if name == "pyflyt":
        from thirdparty import pyflyt_pairs
        return pyflyt_pairs
    if name == "multirotor":
        from thirdparty import multirotor_pairs
        return multirotor_pairs
    raise SystemExit(f"unknown simulator {name!r}; choose from {', '.join(SIMULATORS)}")


MIN_AIRBORNE_SHARE = 0.5
"""A flight airborne for less than this share of its duration (a pack sagged below hover,
a crash) is no test of ``etsid gap``: its effect is drawn again."""
REDRAWS = 5


def airborne_share(rec: Any) -> float:
    """Share of a record's samples more than 3 cm above the ground (PyFlyt's low flights
    dwell at 5-10 cm)."""
    return float(np.mean(rec.pos[:, 2] - rec.ground_height > 0.03))


def make_pair(sim_name: str, label: str, seed: int, duration: float | None = None
              ) -> tuple[Any, Any, dict[str, Any]]:
    """(SIM FlightTable, REAL FlightTable, truth) of one concealed pair, each flight
    ``duration`` s long (default: drawn from :data:`DURATIONS`). An effect that keeps REAL on
    the ground is drawn again (up to :data:`REDRAWS` times; ``truth["redraws"]``)."""
    mod = simulator(sim_name)
    for attempt in range(REDRAWS + 1):
        rng = np.random.default_rng(seed + 104729 * attempt)
        vehicle = mod.random_vehicle(rng)
        fx, sensor_overrides, truth = mod.draw_effect(label, rng)
        kind_sim, kind_real = mod.flight_kind(label, rng)
        lo, hi = DURATIONS[sim_name]
        d_sim, d_real = rng.uniform(lo, hi), rng.uniform(lo, hi)
        if duration is not None:
            d_sim = d_real = float(duration)
        s_sim = mod.sensors(rng, False, {})
        s_real = mod.sensors(rng, True, sensor_overrides)
        rec_sim = mod.fly(kind_sim, d_sim, seed, vehicle, {}, s_sim)
        rec_real = mod.fly(kind_real, d_real, seed + 7919, vehicle, fx, s_real)
        if min(airborne_share(rec_sim), airborne_share(rec_real)) >= MIN_AIRBORNE_SHARE:
            break
    sim = to_table(rec_sim, s_sim, rng, f"{sim_name} SIM")
    real = to_table(rec_real, s_real, rng, f"{sim_name} REAL")
    truth.update({"vehicle": vehicle, "profiles": [kind_sim, kind_real],
                  "durations_s": [round(d_sim, 2), round(d_real, 2)], "redraws": attempt})
    return sim, real, truth


def pair_jobs(sims: list[str], seeds: list[int], only: list[str] | None
              ) -> list[dict[str, Any]]:
    """Every pair to generate: id, simulator, label, seed. Ids are numbered in a shuffled
    order so that a file name says nothing about its effect."""
    jobs = []
    for name in sims:
        labels = simulator_labels(name)
        for s in seeds:
            order = np.random.default_rng(s * 7 + len(name)).permutation(len(labels))
            for k, j in enumerate(order):
                label = labels[j]
                if only and label not in only:
                    continue
                jobs.append({"id": f"{name}-{s}-{k:02d}", "sim": name, "label": label,
                             "seed": s * 1000 + int(j) * 10})
    return jobs


def simulator_labels(name: str) -> tuple[str, ...]:
    """The labels of one seed of ``name``, without importing the simulator itself."""
    if name == "pyflyt":
        from thirdparty.pyflyt_pairs import LABELS
    else:
        from thirdparty.multirotor_pairs import LABELS
    return LABELS


def generate_one(job: dict[str, Any], out: str) -> dict[str, Any]:
    """Fly one pair, write its two logs through etsid's writers, return its label entry."""
    from etsid.sim.writers import write_log

    t0 = time.time()
    mod = simulator(job["sim"])
    if hasattr(mod, "excite_flights"):
        mod.excite_flights = bool(job.get("excite"))
    if hasattr(mod, "motor_noise_scale"):
        mod.motor_noise_scale = float(job.get("motor_noise", 1.0))
    sim, real, truth = make_pair(job["sim"], job["label"], job["seed"], job.get("duration"))
    folder = Path(out) / job["id"]
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    suffix = mod.LOG_SUFFIX
    low = getattr(mod, "LOW_FLIGHT_SUFFIX", None)
    if low and ("ground_effect" in job["label"] or int(job["id"][-2:]) % 4 == 0):
        # low flights need the table format (see the module); a quarter of the other
        # pairs (by shuffled number) share it, so that a file name tells nothing
        suffix = low
    for role, table in (("sim", sim), ("real", real)):
        path = folder / f"{role}{suffix}"
        paths[role] = str(write_log(table, path, rates=mod.LOG_RATES).relative_to(out))
    return {**job, "expected": expected_name(job["label"], job["sim"]),
            "out_of_vocabulary": out_of_vocabulary(job["label"], job["sim"]),
            "sim_log": paths["sim"], "real_log": paths["real"], "truth": jsonable(truth),
            "seconds": round(time.time() - t0, 1)}


def generate(out: Path, sims: list[str], seeds: list[int], only: list[str] | None,
             jobs: int, duration: float | None = None, excite: bool = False,
             motor_noise: float = 1.0) -> None:
    """Write every pair of ``sims`` × ``seeds`` (``only`` these labels) into ``out``.
    ``labels.json`` is rewritten after each pair, so an interrupted run keeps what it wrote
    and a rerun into the same folder writes only the pairs it lacks."""
    out.mkdir(parents=True, exist_ok=True)
    labels = out / "labels.json"
    entries = json.loads(labels.read_text())["pairs"] if labels.exists() else []
    have = {e["id"] for e in entries}
    todo = [dict(j, duration=duration) if duration else j for j in pair_jobs(sims, seeds, only)]
    todo = [dict(j, excite=True) if excite else j for j in todo]
    todo = [dict(j, motor_noise=motor_noise) if motor_noise != 1.0 else j for j in todo]
    if have:
        print(f"{sum(j['id'] in have for j in todo)} pairs already in {labels}", flush=True)
    todo = [j for j in todo if j["id"] not in have]
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = [pool.submit(generate_one, j, str(out)) for j in todo]
        for f in futures:
            e = f.result()
            entries.append(e)
            labels.write_text(json.dumps({"benchmark": "gap_thirdparty", "pairs": entries},
                                         indent=1))
            print(f"{e['id']:20s} written in {e['seconds']:5.1f} s", flush=True)
    print(f"{len(todo)} pairs in {time.time() - t0:.0f} s; labels in {labels}")


def inspect_one(entry: dict[str, Any], out: str) -> str:
    """One line of sanity figures per log of a pair (read back through etsid's ingest):
    rate, duration, airborne time, height range, rate and attitude excitation."""
    from etsid.gap.signals import prepare
    from etsid.ingest import read_log

    cols = []
    for role in ("sim_log", "real_log"):
        table = read_log(Path(out) / entry[role])
        fl = prepare(table, entry[role])
        air = fl.airborne
        if not np.any(air):
            cols.append(f"{fl.fs:5.0f} Hz {fl.t[-1]:5.1f} s NOT AIRBORNE (alt finite "
                        f"{np.isfinite(fl.alt).mean():.0%}, max {np.nanmax(fl.alt):.2f} m)")
            continue
        alt = fl.alt[air]
        speed = np.linalg.norm(fl.v_body[air, :2], axis=1)
        cols.append(f"{fl.fs:5.0f} Hz {fl.t[-1]:5.1f} s air {fl.airborne_s:5.1f} s "
                    f"alt {np.nanmin(alt):5.2f}-{np.nanmax(alt):5.2f} m "
                    f"p,q,r std {np.array2string(np.std(fl.rates[air], axis=0), precision=2)} "
                    f"v<={np.max(speed):4.1f} m/s n={fl.motors.shape[1]}")
    return f"{entry['id']:20s} " + " | ".join(cols)


def inspect(out: Path, jobs: int) -> None:
    entries = json.loads((out / "labels.json").read_text())["pairs"]
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        for line in pool.map(inspect_one, entries, [str(out)] * len(entries)):
            print(line, flush=True)


def answer(data: dict[str, Any]) -> tuple[str, str]:
    """(the name etsid gap gave, its kind): the named effects "+"-joined, or
    ``unexplained``/``consistent``/another verdict; kind is ``confident`` when a named
    effect has confidence ≥ CONFIDENT and no caveat, else ``caveated``, or the verdict."""
    effects = data.get("effects") or []
    named = sorted(e["name"] for e in effects if e["name"] != "unexplained")
    if not named:
        label = "unexplained" if effects else str(data.get("verdict"))
        return label, label
    caveat = any(e.get("caveat") or e.get("caveats") or e.get("at_bound")
                 for e in effects) or bool(data.get("caveats"))
    confident = any(float(e.get("confidence", 0.0)) >= CONFIDENT for e in effects
                    if e["name"] != "unexplained")
    return "+".join(named), "confident" if confident and not caveat else "caveated"


def score_one(entry: dict[str, Any], out: str) -> dict[str, Any]:
    """Run ``etsid gap`` (in process, :func:`etsid.gap.run.run_gap`) on one pair."""
    from etsid.gap.run import run_gap

    t0 = time.time()
    gap_dir = Path(out) / entry["id"] / "gap"
    gap_dir.mkdir(parents=True, exist_ok=True)
    try:
        data = run_gap(Path(out) / entry["sim_log"], Path(out) / entry["real_log"],
                       gap_dir).data
        name, kind = answer(data)
        summary = str(data.get("summary", ""))
    except Exception as exc:  # a failure is a result here, reported per pair
        name, kind, data, summary = "error", "error", {}, f"{type(exc).__name__}: {exc}"
    return {"id": entry["id"], "sim": entry["sim"], "label": entry["label"],
            "expected": entry["expected"], "named": name, "kind": kind,
            "verdict": data.get("verdict", "error"), "summary": summary,
            "seconds": round(time.time() - t0, 1)}


def report(rows: list[dict[str, Any]], title: str) -> None:
    """Print the figures of ``rows`` (one simulator or all)."""
    vocab = [r for r in rows if not out_of_vocabulary(r["label"], r["sim"])]
    none = [r for r in rows if r["label"] == "none"]
    correct = sum(same_answer(r["expected"], r["named"]) for r in vocab)
    fp = sum(r["verdict"] != "consistent" for r in none)
    print(f"\n== {title}: {len(rows)} pairs")
    print(f"named correctly (vocabulary and no-effect pairs): {correct}/{len(vocab)} = "
          f"{100 * correct / max(1, len(vocab)):.0f} %")
    print(f"false positives on no-effect pairs: {fp}/{len(none)}")
    per: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    wrong: dict[str, Counter] = defaultdict(Counter)
    for r in vocab:
        ok = same_answer(r["expected"], r["named"])
        per[r["label"]][0] += ok
        per[r["label"]][1] += 1
        if not ok:
            wrong[r["label"]][r["named"]] += 1
    print("per effect (label → expected: named right / pairs; what it said instead):")
    for label in sorted(per):
        ok, n = per[label]
        instead = ", ".join(f"{k} ×{v}" for k, v in wrong[label].most_common())
        want = next(r["expected"] for r in vocab if r["label"] == label)
        print(f"  {label:24s} → {want:24s} {ok}/{n}  {instead}")
    oov = [r for r in rows if out_of_vocabulary(r["label"], r["sim"])]
    if oov:
        print("out-of-vocabulary changes (honest = unexplained, caveated or mismatch without "
              "a confident name):")
        for r in oov:
            honest = r["kind"] != "confident" and r["verdict"] != "consistent"
            verdict = "honest" if honest else (
                "CONFIDENT WRONG" if r["kind"] == "confident" else "missed")
            print(f"  {r['id']:20s} {r['label']:12s} → {r['named']:28s} {r['kind']:10s} "
                  f"{verdict}")
    confusion = Counter((r["expected"], r["named"]) for r in rows)
    print("confusion (expected → named: count):")
    for (want, got), n in sorted(confusion.items()):
        print(f"  {want:28s} → {got:28s} {n}")


def score(out: Path, jobs: int, only_sims: list[str] | None) -> None:
    entries = json.loads((out / "labels.json").read_text())["pairs"]
    if only_sims:
        entries = [e for e in entries if e["sim"] in only_sims]
    t0 = time.time()
    rows = []
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        for r in pool.map(score_one, entries, [str(out)] * len(entries)):
            rows.append(r)
            mark = "ok" if same_answer(r["expected"], r["named"]) else (
                "oov" if out_of_vocabulary(r["label"], r["sim"]) else "WRONG")
            print(f"{r['id']:20s} truth {r['label']:24s} named {r['named']:26s} {mark:5s} "
                  f"{r['seconds']:5.1f} s  {r['summary'][:100]}", flush=True)
    (out / "scores.json").write_text(json.dumps(rows, indent=1))
    print(f"\n{len(rows)} pairs scored in {time.time() - t0:.0f} s")
    for name in sorted({r["sim"] for r in rows}):
        report([r for r in rows if r["sim"] == name], name)
    if len({r["sim"] for r in rows}) > 1:
        report(rows, "all simulators")


def detectability_one(entry: dict[str, Any], out: str) -> str:
    """Whether a pair's hidden effect shows in its logs at all: the TRUE law (an oracle the
    analysis does not have) fitted on REAL's fit part, its parameter's distance from "no
    effect" in standard errors, and what it removes on the held-out part (floor units,
    summed over its channels). A law that is not 3 standard errors from no effect, or
    removes less than one floor unit held out, does not show in these logs (either the
    effect is below their noise or the vocabulary's law does not take its shape)."""
    from etsid.gap import run as gap_run
    from etsid.gap.candidates import LIBRARY, Context
    from etsid.gap.fitting import Scorer, channels_of, fit_candidates
    from etsid.gap.nominal import measured
    from etsid.ingest import read_log

    name = expected_name(entry["label"], entry["sim"])
    cands = [c for c in LIBRARY if c.name == name]
    if not cands:
        return f"{entry['id']:20s} {entry['label']:24s} (no single law)"
    sim, real = gap_run.prepare_pair(read_log(Path(out) / entry["sim_log"]),
                                     read_log(Path(out) / entry["real_log"]), "sim", "real")
    floors = gap_run.nominal_and_floors(sim, real, None)
    yr = measured(real)
    floors.nominal.channels = tuple(c for c in floors.nominal.channels if c in yr)
    gap_run.restrict_to_envelope(sim, real, floors.nominal)
    v_ref = float(np.nanmean(sim.vbat[sim.airborne])) if "vbat" in sim.have else None
    ctx = Context(real, floors.nominal, v_ref, gap_run._rotor_dirs(floors.nominal, real), None)
    scorer = Scorer(ctx, yr, floors.sigma)
    fit, hold = gap_run.split_evidence(real, scorer.residuals(), floors.sigma)
    best = None
    for cand in cands:
        if not cand.available(ctx):
            continue
        f = fit_candidates((cand,), scorer, fit)
        chans = channels_of((cand,), scorer)
        gain = (sum(scorer.zscores(None, hold, chans).values())
                - sum(scorer.zscores(f.mods, hold, chans).values()))
        nulls = [ctx.nominal.tau if cand.name == "motor_lag" else
                 (p.null if p.null is not None else p.x0) for p in cand.params]
        t = max(abs(float(v) - n) / float(e) if np.isfinite(e) and e > 0 else 0.0
                for v, n, e in zip(f.theta, nulls, f.stderr, strict=True))
        if best is None or gain > best[0]:
            best = (gain, t, f.theta)
    if best is None:
        return f"{entry['id']:20s} {entry['label']:24s} (law not available: log lacks data)"
    gain, t, theta = best
    verdict = "shows" if t >= 3.0 and gain >= 1.0 else "NOT SHOWN"
    return (f"{entry['id']:20s} {entry['label']:24s} {verdict:12s} {t:6.1f} SE from no "
            f"effect, held-out gain {gain:7.2f} floor units, fitted "
            f"{np.array2string(np.asarray(theta), precision=3)}")


def detectability(out: Path, jobs: int) -> None:
    entries = [e for e in json.loads((out / "labels.json").read_text())["pairs"]
               if not out_of_vocabulary(e["label"], e["sim"]) and e["label"] != "none"]
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        for line in pool.map(detectability_one, entries, [str(out)] * len(entries)):
            print(line, flush=True)


def timing(out: Path, only: list[str] | None = None) -> None:
    """CPU seconds of ``etsid gap`` per pair on one core (every fourth pair, or every pair
    whose label is in ``only``, in this process), with the two flights' durations."""
    from etsid.gap.run import run_gap

    entries = json.loads((out / "labels.json").read_text())["pairs"]
    entries = [e for e in entries if e["label"] in only] if only else entries[::4]
    spent = []
    for e in entries:
        t0 = time.process_time()
        data = run_gap(out / e["sim_log"], out / e["real_log"]).data
        cpu = time.process_time() - t0
        spent.append(cpu)
        print(f"{e['id']:20s} {e['label']:24s} flights {e['truth']['durations_s'][0]:5.1f} + "
              f"{e['truth']['durations_s'][1]:5.1f} s  {data['verdict']:12s} cpu {cpu:5.1f} s",
              flush=True)
    print(f"{len(spent)} pairs: median {np.median(spent):.1f} s, max {max(spent):.1f} s CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--generate", type=Path, metavar="DIR", help="write pairs + labels.json")
    mode.add_argument("--inspect", type=Path, metavar="DIR",
                      help="sanity figures of the written logs (no gap analysis)")
    mode.add_argument("--score", type=Path, metavar="DIR", help="run etsid gap on every pair")
    mode.add_argument("--timing", type=Path, metavar="DIR",
                      help="CPU time of etsid gap per pair on one core (every 4th pair)")
    mode.add_argument("--detectability", type=Path, metavar="DIR",
                      help="oracle: does each pair's true law show in its logs at all")
    ap.add_argument("--sims", default=",".join(SIMULATORS),
                    help=f"comma-separated simulators (default {','.join(SIMULATORS)})")
    ap.add_argument("--seeds", default=",".join(map(str, DEFAULT_SEEDS)),
                    help="comma-separated seed sets, 24 pairs per simulator each (default 300)")
    ap.add_argument("--only", default=None, help="comma-separated labels (diagnosis)")
    ap.add_argument("--jobs", type=int, default=1, help="parallel processes")
    ap.add_argument("--duration", type=float, default=None,
                    help="fly every flight this long, s (e.g. 90 for the speed target)")
    ap.add_argument("--excite", action="store_true",
                    help="PyFlyt: fly 3-2-1-1 inputs at the mixer (identification flights)")
    ap.add_argument("--motor-noise", type=float, default=1.0, metavar="X",
                    help="PyFlyt: its motor noise times X (ablation; scored sets fly 1)")
    args = ap.parse_args()
    sims = [s for s in args.sims.split(",") if s]
    for s in sims:
        if s not in SIMULATORS:
            ap.error(f"unknown simulator {s!r}; choose from {', '.join(SIMULATORS)}")
    if args.generate:
        seeds = [int(s) for s in args.seeds.split(",")]
        only = args.only.split(",") if args.only else None
        generate(args.generate, sims, seeds, only, args.jobs, args.duration, args.excite,
                 args.motor_noise)
    elif args.inspect:
        inspect(args.inspect, args.jobs)
    elif args.timing:
        timing(args.timing, args.only.split(",") if args.only else None)
    elif args.detectability:
        detectability(args.detectability, args.jobs)
    else:
        score(args.score, args.jobs, sims if args.sims != ",".join(SIMULATORS) else None)


if __name__ == "__main__":
    main()
