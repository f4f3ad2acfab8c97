"""``etsid fit`` on the real logs with motor outputs, then their twins (issue 40).

    python benchmarks/fit_real.py LOG_DIR [--out DIR]

For every log (the coaxial octocopter's two flights pooled into one airframe): the fit's
verdict counts, then ``replay`` of each flight with the fitted vehicle, the recorded
collective straight to the mixer (``thrust="command"``) and with the simulator's altitude
hold on the recorded altitude (``thrust="alt_hold"``): how long the twin stays with the
recording (divergence: 30° of roll/pitch, 5 m of altitude, or on the ground while the
recording flies) and its per-channel RMSE against the log.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from etsid.errors import EtsidError
from etsid.fit import fit_tables
from etsid.fit.output import write_fit
from etsid.ingest import read_log
from etsid.sim.replay import replay
from etsid.sim.vehicle import vehicle_from_dict

AIRFRAMES: dict[str, list[str]] = {
    "coaxocto": ["px4_coaxocto_stabilized_real.ulg", "px4_coaxocto_manual_real.ulg"],
    "cubeorange": ["px4_cubeorange_real.ulg"],
    "quad_mission_lowrate": ["px4_quad_mission_lowrate_real.ulg"],
    "v6c_quad": ["px4_v6c_quad_lowhover_real.ulg"],
    "sitl_tagged": ["px4_sitl_tagged.ulg"],
    "copter33_quad": ["ardupilot_copter33_loiter_acro_flips_real.bin"],
    "copter403_hexa": ["ardupilot_copter403_hexa_loiter_real.bin"],
    "sitl_quadplane": ["ardupilot_sitl_quadplane.tlog"],
}
"""Airframe → its logs (the logs of etsid's data set that carry motor outputs)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log_dir", type=Path)
    ap.add_argument("--out", type=Path, default=Path("fit_real_out"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, files in AIRFRAMES.items():
        paths = [args.log_dir / f for f in files]
        try:
            tables = [read_log(p) for p in paths]
            result = fit_tables(tables, name=name)
        except EtsidError as err:
            print(f"{name}: no fit: {err}")
            continue
        write_fit(result, args.out / f"{name}.toml")
        verdicts: dict[str, int] = {}
        for p in result.params.values():
            verdicts[p.verdict] = verdicts.get(p.verdict, 0) + 1
        print(f"{name}: {result.layout['n']} rotors; " + ", ".join(
            f"{v} {k}" for k, v in sorted(verdicts.items())), flush=True)
        vehicle = vehicle_from_dict(result.vehicle, name)
        for path, table in zip(paths, tables, strict=True):
            for thrust in ("command", "alt_hold"):
                try:
                    twin = replay(table, vehicle, mode="loop", thrust=thrust, noise="log")
                except EtsidError as err:
                    print(f"  {path.name} {thrust}: no replay: {err}")
                    continue
                span = float(table.index[-1] - table.index[0])
                div = twin.divergence
                follows = span if div is None else float(div["t"])
                errs = ", ".join(
                    f"{k} {v['ratio']:.2f}" for k, v in twin.errors.items()
                    if k in ("roll", "pitch", "p", "q", "r", "alt")
                    and math.isfinite(v["ratio"]))
                print(f"  {path.name} {thrust:8s}: follows {follows:5.1f} of {span:5.1f} s"
                      + (f" ({div['what']})" if div else "") + f"; RMSE/std {errs}",
                      flush=True)


if __name__ == "__main__":
    main()
