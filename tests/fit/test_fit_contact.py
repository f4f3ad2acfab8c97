"""Ground contact at take-off and landing is kept out of the fit (etsid.fit.signals)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from etsid.fit.signals import CONTACT_MARGIN_S, prepare, trim_contact


def test_edges_next_to_the_ground_are_cut_and_the_logs_own_ends_kept() -> None:
    dt = 0.01
    mask = np.r_[np.zeros(50, bool), np.ones(500, bool), np.zeros(50, bool), np.ones(300, bool)]
    out = trim_contact(mask, dt, margin_s=0.2)
    k = 20
    assert not out[:50 + k].any() and out[50 + k:550 - k].all() and not out[550 - k:600 + k].any()
    assert out[600 + k:].all()          # runs to the log's end: that end is no landing


def test_prepare_drops_the_spool_up_on_the_legs() -> None:
    # 1 s idle, 0.5 s of spool-up on the ground at 60 % of hover, 20 s of flight, landed
    dt = 0.01
    t = np.arange(0.0, 25.0, dt)
    level = np.where(t < 1.0, 0.05, np.where(t < 1.5, 0.3, np.where(t < 21.5, 0.5, 0.05)))
    table = pd.DataFrame({"p": 0.0, "q": 0.0, "r": 0.0, "ax": 0.0, "ay": 0.0, "az": -9.81,
                          **{f"m{i}": level for i in range(1, 5)}}, index=pd.Index(t, name="t"))
    f = prepare(table, [f"m{i}" for i in range(1, 5)], None)
    first = f.t[np.argmax(f.airborne)]
    last = f.t[len(f.t) - 1 - np.argmax(f.airborne[::-1])]
    assert abs(first - (1.0 + CONTACT_MARGIN_S)) < 2 * dt     # the spool-up from 1.0 s is cut
    assert abs(last - (21.5 - CONTACT_MARGIN_S)) < 2 * dt
