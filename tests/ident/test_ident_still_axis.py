"""An axis that barely moves in the validation part is flagged, not scored as if it were
informative: a synthetic flight whose yaw command stops before the validation part."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ident import IdentConfig, identify
from etsid.ident.flight import EXCITE_STD
from etsid.ident.synthetic import rate_table
from etsid.report.tables import summary_table


@pytest.fixture(scope="module")
def still_yaw_run():
    table = rate_table(10000, seed=3, sigma=0.01, segments=1)
    t = table.index.to_numpy()
    # yaw stick centred after 60 % of the flight: r is gyro noise there (σ 0.01 rad/s)
    still = t >= 0.6 * t[-1]
    table.loc[still, "u_yaw"] = 0.0
    table.loc[still, "r"] = np.random.default_rng(4).normal(scale=0.01, size=still.sum())
    return identify(table, IdentConfig(segments="all"))


def test_still_axis_is_flagged_in_metrics(still_yaw_run) -> None:
    out = still_yaw_run.metrics["outputs"]
    for y in ("p", "q"):
        for block in out[y]["validation"].values():
            assert block["informative"] is True and block["signal_std"] > EXCITE_STD
    r_val = out["r"]["validation"]
    for block in (*r_val.values(), *out["r"]["arx"]["validation"].values()):
        assert block["informative"] is False
        # σ at 50 Hz after the 5-sample block mean: 0.01 / √5 ≈ 0.0045 rad/s
        assert block["signal_std"] == pytest.approx(0.01 / np.sqrt(5), rel=0.3)


def test_still_axis_warns_in_one_line_and_table_says_so(still_yaw_run) -> None:
    notes = [n for n in still_yaw_run.config["model"]["notes"] if "too little motion" in n]
    assert len(notes) == 1 and notes[0].startswith("warning: r: too little motion")
    assert "its metrics describe noise" in notes[0]
    rows = {line.split()[0]: line for line in summary_table(still_yaw_run).splitlines()[1:]
            if line.strip()}
    assert "not informative" in rows["r"]
    assert "not informative" not in rows["p"] and "not informative" not in rows["q"]


def test_validation_figure_says_not_informative(still_yaw_run) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from etsid.report.figures import fig_validation

    fig = fig_validation(still_yaw_run)
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    plt.close(fig)
    assert any("not informative" in t for t in titles)
    assert sum("not informative" in t for t in titles) == 1  # r only
