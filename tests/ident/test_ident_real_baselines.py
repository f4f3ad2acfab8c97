"""Every real flight in ../shared/data/logs that identify accepts: on every informative
axis the validation one-step error of eTS is at most no-change persistence and 1.02 × ARX,
or the run says which axis is behind and why, in one line, and falls back to the better
baseline there (issues 24, 41)."""

from __future__ import annotations

from pathlib import Path

import pytest

from etsid.ident import IdentConfig, identify
from etsid.ident.inputs import load_for_ident

DATA = Path(__file__).parents[1] / "data"
SHARED = Path(__file__).parents[2].parent / "shared" / "data" / "logs"
FLIGHTS = ("px4_coaxocto_stabilized_real.ulg", "px4_coaxocto_manual_real.ulg",
           "px4_v6c_quad_lowhover_real.ulg", "ardupilot_copter403_hexa_loiter_real.bin")


@pytest.mark.parametrize("name", FLIGHTS)
def test_never_behind_the_baselines_unannounced(name: str) -> None:
    path = DATA / name if (DATA / name).exists() else SHARED / name
    if not path.exists():
        pytest.skip(f"{path} not available")
    run = identify(load_for_ident(path), IdentConfig(), source=path)
    notes = run.config["model"]["notes"]
    assert any(n.startswith("structure: ") for n in notes)
    table = run.metrics["structure"]["validation"]
    assert {"ARX", "no-change"} <= set(table) and len(table) >= 4
    for y, block in run.metrics["outputs"].items():
        one = block["validation"]["one_step"]
        if not one.get("informative", True):
            continue
        ets = one["rmse"]
        arx = block["arx"]["validation"]["one_step"]["rmse"]
        persist = block["persistence"]["validation"]["rmse"]
        behind = ets > 1.02 * arx or ets > persist
        said = [n for n in notes if n.startswith(f"warning: {y}: eTS validation one-step")]
        assert behind == bool(said), (y, ets, arx, persist, said)
        if said:
            assert "likely reason: " in said[0]
            better = "ARX" if arx <= persist else "no-change"
            assert block["used"] == better and f"falls back to {better}" in said[0]
        else:
            assert block["used"] == "eTS"
