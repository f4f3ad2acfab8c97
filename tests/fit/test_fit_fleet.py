"""The fleet's change rule: a sustained shift is flagged where it starts, noise is not."""

from __future__ import annotations

import numpy as np
import pandas as pd

from etsid.fit.fleet import airframe_of, change_flags


def _frame(shift_from: int | None, rng: np.random.Generator, name: str) -> pd.DataFrame:
    n = 20
    se = np.full(n, 0.002)
    v = 1.0 + rng.normal(0.0, 0.002, n)
    if shift_from is not None:
        k = np.arange(1, n + 1)
        v = v + np.where(k >= shift_from, 0.01 * (k - shift_from + 1), 0.0)
    return pd.DataFrame({"airframe": name, "flight": [f"f{i:02d}" for i in range(1, n + 1)],
                         "index": np.arange(1, n + 1), "motor2_share": v,
                         "motor2_share_se": se})


def test_a_progressive_shift_is_flagged_near_its_start_and_noise_never() -> None:
    hits, false = [], 0
    for seed in range(30):
        rng = np.random.default_rng(seed)
        frame = pd.concat([_frame(10, rng, "B"), _frame(None, rng, "A"),
                           _frame(None, rng, "C")])
        flags = change_flags(frame)
        hits += [f["flight"] for f in flags if f["airframe"] == "B"]
        false += sum(f["airframe"] != "B" for f in flags)
    assert len(hits) == 30 and all(10 <= h <= 13 for h in hits)
    assert false <= 1


def test_airframe_is_the_logs_identity_else_its_folder(tmp_path) -> None:
    t = pd.DataFrame({"p": [0.0]})
    assert airframe_of(t, tmp_path / "alpha" / "f.ulg", tmp_path) == "alpha"
    t.attrs["sys_uuid"] = "0042"
    assert airframe_of(t, tmp_path / "alpha" / "f.ulg", tmp_path) == "sys_uuid=0042"
