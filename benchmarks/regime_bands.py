"""Scores per altitude band, eTS against ARX, on regime flights of both generators (issue 41).

For each flight, ``etsid identify`` with the defaults (``IdentConfig()``) and, per altitude
band of its validation part (``metrics.json`` → ``regimes.per_regime``: in ground effect,
transition, out of ground effect when the rotor radius is known), the free-run fit % of the
frozen eTS and of ARX; ``n.i.`` where the band is not informative (too short or too still).
The last lines: the mean Δ (eTS − ARX) over the whole validation part and the worst band Δ.

- ``--generator etsid``: etsid's simulator, ``ige-oge`` (150 s; the chapter's manoeuvre);
- ``--generator gen2``: the second generator of ``benchmarks/ets_gen2.py`` (Hayden's ground
  effect, single-loop PID, 180 s of alternating low and high dwells).

Settings frozen before the first run: ``IdentConfig()`` at the commit that added this
script. The first result is recorded in docs/identify.md (issue 41 section).

    python benchmarks/regime_bands.py --generator gen2 --seeds 7,8,9
    python benchmarks/regime_bands.py --generator gen2 --airframe hexa15 --seeds 31,32,33
    python benchmarks/regime_bands.py --generator etsid --seeds 111,112
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd


def flight(generator: str, seed: int, airframe: str = "quad10") -> pd.DataFrame:
    """The regime flight of ``generator`` for ``seed`` (``airframe``: gen2's airframe)."""
    if generator == "gen2":
        sys.path.insert(0, str(Path(__file__).parent))
        from ets_gen2 import AIRFRAMES, fly

        return fly(seed, 180.0, regimes=True, frame=AIRFRAMES[airframe])
    from etsid.sim import simulate

    return simulate("ige-oge", duration=150.0, seed=seed).table


def band_deltas(regimes: dict) -> list[tuple[str, int, dict[str, tuple[float, float] | None]]]:
    """Per band: name, validation rows and per output (eTS fit, ARX fit) or None (n.i.)."""
    out = []
    for band in regimes.get("per_regime") or []:
        fits: dict[str, tuple[float, float] | None] = {}
        for y in "pqr":
            o = (band.get("outputs") or {}).get(y) or {}
            e = (o.get("free_run") or {}).get("fit")
            a = (o.get("arx_free_run") or {}).get("fit")
            fits[y] = (e, a) if o.get("informative") and e is not None and a is not None \
                else None
        out.append((band["name"], int(band.get("n_validation", 0)), fits))
    return out


def main() -> None:
    from etsid.ident import IdentConfig, identify

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generator", choices=("etsid", "gen2"), default="gen2")
    ap.add_argument("--seeds", default="7,8,9")
    ap.add_argument("--airframe", choices=("quad10", "hexa15"), default="quad10",
                    help="gen2's airframe (benchmarks/ets_gen2.py)")
    args = ap.parse_args()
    print("| seed | structure, rules | band | val rows | eTS / ARX free-run fit % p | q | r |")
    print("|---|---|---|---|---|---|---|")
    whole, worst = [], {y: np.inf for y in "pqr"}
    for seed in (int(s) for s in args.seeds.split(",")):
        run = identify(flight(args.generator, seed, args.airframe), IdentConfig())
        m = run.metrics
        label = f"{(m.get('structure') or {}).get('chosen')}, {m['rules']['frozen']}"
        for name, rows, fits in band_deltas(m["regimes"]):
            cells = []
            for y in "pqr":
                f = fits[y]
                if f is None:
                    cells.append("n.i.")
                    continue
                cells.append(f"{f[0]:.1f} / {f[1]:.1f} ({f[0] - f[1]:+.1f})")
                worst[y] = min(worst[y], f[0] - f[1])
            print(f"| {seed} | {label} | {name} | {rows} | " + " | ".join(cells) + " |",
                  flush=True)
        out = m["outputs"]
        whole.append([out[y]["validation"]["free_run"]["fit"]
                      - out[y]["arx"]["validation"]["free_run"]["fit"] for y in "pqr"])
        print(f"| {seed} | {label} | whole validation part | – | "
              + " | ".join(f"Δ {d:+.1f}" for d in whole[-1]) + " |", flush=True)
    mean = np.mean(whole, axis=0)
    print("mean Δ free-run fit eTS − ARX over the validation part p / q / r: "
          + " / ".join(f"{v:+.2f}" for v in mean))
    print("worst band Δ p / q / r: " + " / ".join(f"{worst[y]:+.1f}" for y in "pqr"))


if __name__ == "__main__":
    main()
