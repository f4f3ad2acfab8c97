"""Concealed-effect benchmark of ``etsid gap``: simulation/recording pairs, labels hidden.

Every pair is one randomised vehicle (tarot680 or quad250 with mass, arm, rotor radius
and so hover command perturbed) flown twice with different seeds, durations and
manoeuvres: the "simulation" without the effect, the "recording" with it (and 10–30 %
more sensor noise). The analysis sees two FlightTables and nothing else; the label lives
only here. The generator's laws are not the candidates' (per-rotor Sanchez-Cuevas ground
effect with a body term vs a one-law candidate; asymmetric spin-up/down lag vs a
symmetric one; rotor drag ∝ Ω v plus extra quadratic body drag vs a linear candidate;
battery sag through internal resistance and the motor's speed-voltage law vs a power law).

Run::

    python benchmarks/gap_concealed.py            # held-out seeds 200-205 (reported figures)
    python benchmarks/gap_concealed.py --dev      # development seeds (thresholds chosen here;
                                                  # plus 16 no-effect pairs, seeds 102-109)
    python benchmarks/gap_concealed.py --seeds 110,111 --only motor_lag   # diagnosis
    python benchmarks/gap_concealed.py --only ground_effect --old-ground  # previous GE pairs

Ground-effect pairs fly the chapter's situation on the multirotor law for both vehicles:
hubs wandering through z/R ≈ 1.5-4.5 of the vehicle's rotor radius (docs/gap.md).
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter

import numpy as np

from etsid.gap.calibration import load_calibration
from etsid.gap.candidates import ground_ratio, ground_ratio_exp
from etsid.gap.run import analyse
from etsid.sim import load_vehicle, simulate

EFFECTS = ("none", "ground_effect", "rotor_drag", "motor_lag", "time_delay", "battery_sag",
           "thrust_scale", "inertia_scale", "torque_offset", "gyro_bias",
           "thrust_scale+time_delay", "none")
DEV_SEEDS = (100, 101)
DEV_NONE_SEEDS = tuple(range(102, 110))
"""Extra development seeds flown as no-effect pairs only (false-positive calibration)."""
TEST_SEEDS = (200, 201, 202, 203, 204, 205)
COMMAND_LOG = "mean"
"""Motor outputs of both tables: the mean over each log period (``simulate``'s
``command_log``); ``"sample"`` gave pairs recorded before session 13."""
GE_HUB_ZR = (2.5, 3.5)
GE_WANDER_ZR = 1.5
"""Ground-effect pairs: mean hub height drawn in GE_HUB_ZR rotor radii, altitude wander
±GE_WANDER_ZR radii (hubs at z/R ≈ 1–5; landing gear permitting)."""


def random_vehicle(rng: np.random.Generator):
    name = str(rng.choice(["tarot680", "quad250"]))
    v = load_vehicle(name)
    return v.with_settings({
        "mass": v.mass * rng.uniform(0.85, 1.15),
        "frame.arm_length": v["frame"]["arm_length"] * rng.uniform(0.9, 1.1),
        "rotor.radius": v["rotor"]["radius"] * rng.uniform(0.94, 1.06),
    })


def make_pair(effect: str, seed: int, old_ground: bool = False,
              command_log: str | None = None):
    """(sim table, real table, truth dict) for one concealed pair (``old_ground``: the
    previous generator's ground-effect pairs, for comparison; ``command_log``: how the
    motor outputs are logged, default :data:`COMMAND_LOG`)."""
    command_log = command_log or COMMAND_LOG
    rng = np.random.default_rng(seed)
    veh = random_vehicle(rng)
    est = str(rng.choice(["none", "mahony"]))
    base = {"vehicle.estimator": est}
    noisy = {f"vehicle.sensors.{k}": veh["sensors"][k] * rng.uniform(1.1, 1.3)
             for k in ("gyro_std", "accel_std")}
    real_set = dict(base, **noisy)
    truth: dict = {"effects": [] if effect == "none" else effect.split("+"),
                   "vehicle": veh.name}
    big = veh.name == "tarot680"
    # manoeuvres that excite what a nominal model must learn (rates and thrust changes)
    sc_sim = str(rng.choice(["hover-oge", "sine-altitude"]))
    sc_real = str(rng.choice(["hover-oge", "sine-altitude"]))

    def manoeuvre(sc: str) -> dict:
        if sc == "hover-oge":
            return {"alt_wander": rng.uniform(0.2, 0.4), "amplitude": rng.uniform(0.3, 0.45)}
        return {"altitude": 2.5, "alt_amplitude": rng.uniform(0.4, 0.8),
                "amplitude": rng.uniform(0.25, 0.4)}

    kw_sim, kw_real = manoeuvre(sc_sim), manoeuvre(sc_real)
    ge_sim = ge_real = True
    for name in truth["effects"]:
        if name == "ground_effect" and old_ground:
            sc_sim = sc_real = "hover-ige"
            alt = rng.uniform(0.3, 0.4) if big else rng.uniform(0.12, 0.17)
            wander = 0.12 if big else 0.05
            kw_sim = {"altitude": alt * rng.uniform(0.9, 1.1), "alt_wander": wander}
            kw_real = {"altitude": alt, "alt_wander": wander}
            ge_sim = False
            truth["altitude"] = alt
        elif name == "ground_effect":
            # the chapter's situation: a low flight, hubs wandering through z/R ≈ 1.5–4.5
            # (in and out of the band z/R < 2–3 where ground effect acts), for every
            # vehicle; the multirotor law (neighbour and body terms), never the candidate's
            # single-rotor Cheeseman–Bennett law that the quad250 file uses by default
            sc_sim = sc_real = "hover-ige"
            radius, hub = veh["rotor"]["radius"], -veh["frame"]["hub_z"]
            zr = rng.uniform(GE_HUB_ZR[0], GE_HUB_ZR[1])
            wander = GE_WANDER_ZR * radius
            alt = max(zr * radius - hub, veh["ground"]["gear_height"] + wander + 0.02)
            kw_sim = {"altitude": alt + rng.uniform(-0.3, 0.3) * radius, "alt_wander": wander}
            kw_real = {"altitude": alt, "alt_wander": wander}
            ge_sim = False
            real_set["vehicle.ground.model"] = "sanchez-cuevas"
            truth["altitude"] = alt
        elif name == "rotor_drag":
            sc_sim = sc_real = "forward-flight"
            kw_sim = {"speed": rng.uniform(4.0, 7.0)}
            kw_real = {"speed": rng.uniform(4.0, 7.0)}
            k = rng.uniform(3.0, 5.0)
            real_set["vehicle.drag.rotor_drag"] = veh["drag"]["rotor_drag"] * k
            real_set["vehicle.drag.quadratic"] = [q * 2.0 for q in veh["drag"]["quadratic"]]
            truth["rotor_drag_extra"] = (k - 1.0) * veh["drag"]["rotor_drag"]
        elif name == "motor_lag":
            tau = veh["motor"]["time_constant"] * rng.uniform(1.8, 3.0)
            ratio = rng.uniform(1.2, 1.6)
            up, down = 2 * tau / (1 + ratio), 2 * tau * ratio / (1 + ratio)
            real_set["vehicle.motor_lag"] = [up, down]
            truth["tau"] = tau
        elif name == "time_delay":
            d = rng.uniform(0.015, 0.04)
            real_set["vehicle.time_delay"] = d
            truth["delay"] = d
        elif name == "battery_sag":
            real_set["vehicle.battery.r_internal"] = veh["battery"]["r_internal"] * \
                rng.uniform(6.0, 10.0)
            real_set["vehicle.battery.soc0"] = rng.uniform(0.5, 0.7)
        elif name == "thrust_scale":
            s = rng.uniform(0.8, 0.9) if rng.random() < 0.5 else rng.uniform(1.1, 1.2)
            real_set["vehicle.thrust_scale"] = s
            truth["scale"] = s
        elif name == "inertia_scale":
            s = rng.uniform(1.3, 1.6)
            real_set["vehicle.inertia_scale"] = s
            truth["inertia"] = s
        elif name == "torque_offset":
            acc = rng.uniform(1.0, 3.0, 2) * rng.choice([-1, 1], 2)
            inertia = veh.inertia
            m = inertia @ np.array([acc[0], acc[1], 0.0])
            real_set["vehicle.torque_offset"] = [float(m[0]), float(m[1]), 0.0]
            truth["offset"] = np.linalg.solve(inertia, m)[:2]
        elif name == "gyro_bias":
            b = rng.uniform(0.02, 0.05, 2) * rng.choice([-1, 1], 2)
            real_set["vehicle.gyro_bias"] = [float(b[0]), float(b[1]), 0.0]
            truth["bias"] = b
    d_sim, d_real = rng.uniform(30.0, 40.0), rng.uniform(30.0, 45.0)
    # motor outputs logged as their mean over each log period: the 1 kHz loop answers the
    # gyro's white noise, and a 250 Hz snapshot of that jitter reads as held four times
    # longer than the motors saw it, a flight-dependent error a time delay fits (docs/sim.md)
    sim = simulate(sc_sim, veh, duration=d_sim, seed=seed, ground_effect=ge_sim,
                   settings=base, command_log=command_log, **kw_sim)
    real = simulate(sc_real, veh, duration=d_real, seed=seed + 7919, ground_effect=ge_real,
                    settings=real_set, command_log=command_log, **kw_real)
    if "ground_effect" in truth["effects"]:
        n = veh.n_rotors
        ge = real.truth[[f"true_ge{i}" for i in range(1, n + 1)]].to_numpy().mean(axis=1)
        truth["ge_excess"] = float(ge.mean() - 1.0)
        truth["ge_series"] = ge - 1.0
        truth["alt_series"] = real.truth["true_alt"].to_numpy()
        truth["radius"] = veh["rotor"]["radius"]
        truth["hub"] = -veh["frame"]["hub_z"]
    if "rotor_drag" in truth["effects"]:
        n = veh.n_rotors
        om = real.truth[[f"true_w{i}" for i in range(1, n + 1)]].to_numpy().sum(axis=1).mean()
        truth["drag"] = truth["rotor_drag_extra"] * om / veh.mass
    return sim.table, real.table, truth


def ge_band_top(alt: np.ndarray, excess: np.ndarray, radius: float) -> float:
    """Upper end (m) of the true ground-effect band: the highest height bin (0.25 R wide)
    whose mean thrust excess is at least half that of the most affected bin."""
    keep = alt > 0.0
    alt, excess = alt[keep], excess[keep]
    edges = np.arange(alt.min(), alt.max() + 0.25 * radius, 0.25 * radius)
    idx = np.digitize(alt, edges) - 1
    means = np.array([excess[idx == b].mean() if np.sum(idx == b) > 0.01 * alt.size
                      else np.nan for b in range(edges.size)])
    hot = np.flatnonzero(means >= 0.5 * np.nanmax(means))
    return float(edges[hot[-1]] + 0.25 * radius)


def located_right(reg: dict, truth: dict) -> bool:
    """The regime is height, starts at the bottom of the flown heights and ends within
    half a rotor radius of the true band's upper end (:func:`ge_band_top`)."""
    if reg.get("variable") != "alt" or not reg.get("range"):
        return False
    lo, hi = reg["range"]
    alt, radius = truth["alt_series"], truth["radius"]
    top = ge_band_top(alt, truth["ge_series"], radius)
    return bool(lo <= np.percentile(alt[alt > 0], 10) + 0.25 * radius
                and abs(hi - top) <= 0.5 * radius)


def param_error(name: str, eff: dict, truth: dict) -> float | None:
    """Relative error of the fitted parameter against the generator's truth."""
    p = {k: v["value"] for k, v in eff["parameters"].items()}
    if name == "ground_effect":
        ratio = (ground_ratio_exp(truth["alt_series"], p["excess"], p["decay"])
                 if "excess" in p else ground_ratio(truth["alt_series"], p["R"], p["exponent"]))
        fit = float(np.mean(ratio)) - 1.0  # either law of the candidate, at the hub height
        return abs(fit - truth["ge_excess"]) / truth["ge_excess"]
    if name == "motor_lag":
        return abs(p["tau"] - truth["tau"]) / truth["tau"]
    if name == "time_delay":
        return abs(p["delay"] - truth["delay"]) / truth["delay"]
    if name == "thrust_scale":
        return abs(p["scale"] - truth["scale"]) / abs(truth["scale"] - 1.0)
    if name == "inertia_scale":
        return abs(p["scale"] - truth["inertia"]) / abs(truth["inertia"] - 1.0)
    if name == "torque_offset":
        f = np.array([p["p_offset"], p["q_offset"]])
        return float(np.linalg.norm(f - truth["offset"]) / np.linalg.norm(truth["offset"]))
    if name == "gyro_bias":
        f = np.array([p["bx"], p["by"]])
        return float(np.linalg.norm(f - truth["bias"]) / np.linalg.norm(truth["bias"]))
    if name == "rotor_drag":
        return abs(p["drag"] - truth["drag"]) / truth["drag"]
    return None


PACKAGE_CAL = load_calibration()
"""The calibration the package decides with (the detectable sizes it states)."""


def honest_answer(want: str, label: str, data: dict, truth: dict) -> bool:
    """Issue 38's honest miss: nothing named the truth lacks, and every true effect left
    unnamed is below the size the verdict states it could detect (gap.json's
    ``detectable``), as :func:`gap_calibrate.honest_miss` scores the recorded sets."""
    from gap_calibrate import honest_miss, truth_sizes

    row = {"label": want, "detectable": data.get("detectable") or {},
           "truth_sizes": truth_sizes(want, truth)}
    return honest_miss(want, {"verdict": data["verdict"], "answer": label}, row, PACKAGE_CAL)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dev", action="store_true", help="use the development seeds")
    ap.add_argument("--seeds", type=str, default=None,
                    help="comma-separated seeds instead of the default set (diagnosis)")
    ap.add_argument("--only", type=str, default=None,
                    help="comma-separated effect labels to run (diagnosis)")
    ap.add_argument("--record", type=str, default=None,
                    help="append one JSON line per named effect (seed, truth, name, "
                         "confidence, right) to this file, for benchmarks/gap_reliability.py")
    ap.add_argument("--old-ground", action="store_true",
                    help="the previous generator's ground-effect pairs (vehicle-file law, "
                         "fixed low heights) for comparison")
    ap.add_argument("--command-log", choices=("mean", "sample"), default=COMMAND_LOG,
                    help="motor outputs logged as each period's mean (default) or as "
                         "snapshots (the pairs before session 13)")
    args = ap.parse_args()
    seeds = DEV_SEEDS if args.dev else TEST_SEEDS
    if args.seeds:
        seeds = tuple(int(s) for s in args.seeds.split(","))
    confusion: Counter = Counter()
    perr: dict[str, list[float]] = {}
    reductions: list[float] = []
    correct = total = fp = n_none = n_honest = 0
    loc_ok = loc_n = 0
    t0 = time.time()
    jobs = [(s * 100 + j, effect) for s in seeds for j, effect in enumerate(EFFECTS)]
    if args.dev:
        jobs += [(s * 100 + j, "none") for s in DEV_NONE_SEEDS for j in (0, len(EFFECTS) - 1)]
    if args.only:
        jobs = [j for j in jobs if j[1] in args.only.split(",")]
    for seed, effect in jobs:
        sim, real, truth = make_pair(effect, seed, args.old_ground, args.command_log)
        data = analyse(sim, real, "a", "b").data
        named = sorted(e["name"] for e in data["effects"] if e["name"] != "unexplained")
        label = "+".join(named) if named else ("unexplained" if data["effects"] else
                                               data["verdict"])
        want = "+".join(sorted(truth["effects"])) or "consistent"
        ok = label == want
        honest = not ok and effect != "none" and honest_answer(want, label, data, truth)
        total += 1
        correct += ok
        n_honest += honest
        confusion[(want, label)] += 1
        if args.record:
            with open(args.record, "a", encoding="utf-8") as out:
                for e in data["effects"]:
                    out.write(json.dumps({"seed": seed, "truth": truth["effects"],
                                          "name": e["name"], "confidence": e["confidence"],
                                          "right": e["name"] in truth["effects"]}) + "\n")
        if effect == "none":
            n_none += 1
            fp += data["verdict"] != "consistent"
        else:
            main_ch = data["mismatch"]["channels"][0] if data.get("mismatch") else None
            if main_ch:
                b, a = data["rmse_before"][main_ch], data["rmse_after"][main_ch]
                reductions.append(1 - a / b)
            else:
                reductions.append(0.0)
        for e in data["effects"]:
            if e["name"] in truth["effects"]:
                err = param_error(e["name"], e, truth)
                if err is not None:
                    perr.setdefault(e["name"], []).append(err)
        if "ground_effect" in truth["effects"]:
            loc_n += 1
            reg = (data.get("mismatch") or {}).get("regime") or {}
            loc_ok += located_right(reg, truth)
            top = ge_band_top(truth["alt_series"], truth["ge_series"], truth["radius"])
            print(f"    ground-effect band: true up to {top:.3f} m, located "
                  f"{reg.get('variable')} {np.round(reg.get('range') or [], 3).tolist()}")
        print(f"seed {seed:6d} {truth['vehicle']:9s} truth {want:26s} named {label:26s} "
              f"{'ok' if ok else ('HONEST' if honest else 'WRONG')}  {data['summary'][:110]}",
              flush=True)
    print(f"\n{total} pairs in {time.time() - t0:.0f} s, seeds {seeds}"
          + (f" + no-effect seeds {DEV_NONE_SEEDS}" if args.dev else ""))
    print(f"named correctly: {correct}/{total} = {100 * correct / total:.0f} %; not named "
          f"but below the detectable size the verdict states (honest): {n_honest}; right or "
          f"honest {correct + n_honest}/{total}")
    print(f"false positives on no-effect pairs: {fp}/{n_none}")
    print(f"median held-out RMSE reduction (main channel, effect present): "
          f"{100 * float(np.median(reductions)):.0f} %")
    print(f"ground-effect regime located in the right z/R band: {loc_ok}/{loc_n}")
    print("parameter recovery (median relative error):")
    for name, errs in sorted(perr.items()):
        print(f"  {name:14s} {100 * float(np.median(errs)):5.1f} %  (n={len(errs)})")
    print("confusion (truth → named: count):")
    for (want, got), n in sorted(confusion.items()):
        print(f"  {want:26s} → {got:26s} {n}")


if __name__ == "__main__":
    main()
