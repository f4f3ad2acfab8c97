"""etsid's own no-effect pairs carry no spurious command delay (session 13).

With 250 Hz snapshots of the simulator's 1 kHz motor commands, the gyro-noise jitter in a
snapshot reads as held for a whole log period; the share of it differs between two flights
(noise level, manoeuvre), and ``etsid gap`` fitted a time delay of 1–2 ms to no-effect pairs
(etsid-84000: 1.27 ms, +0.030 nats per sample). The generator logs the period's mean
command (``benchmarks/gap_concealed.py``'s ``COMMAND_LOG``): the delay fitted there is at
the search's floor (0.02 ms).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gap_concealed

from etsid.gap.run import analyse

LOG_PERIOD_S = 1.0 / 250.0


def test_no_effect_pair_fits_no_sub_sample_delay() -> None:
    sim, real, truth = gap_concealed.make_pair("none", 84000)
    assert not truth["effects"]
    models = analyse(sim, real, "SIM", "REAL").data["criterion"]["models"]
    delay = next(m for m in models if m["name"] == "time_delay")
    # an eighth of a log period; the snapshot log gave 1.27 ms (a third of it)
    assert delay["theta"][0] < LOG_PERIOD_S / 8
    assert sim.attrs["command_log"] == real.attrs["command_log"] == "mean"
