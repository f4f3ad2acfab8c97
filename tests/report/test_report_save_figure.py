"""``save_figure`` draws a PNG once, and writes the bytes ``savefig`` writes."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from etsid.report.build import save_figure
from etsid.report.figures import style


def _figure() -> Figure:
    """Constrained layout, shared axes, a legend, text beside the axes (what the report's
    figures have)."""
    with style():
        fig = Figure(figsize=(7, 3), layout="constrained")
        axes = fig.subplots(2, 2, sharex=True)
        t = np.linspace(0, 8, 400)
        for i, ax in enumerate(axes.flat):
            ax.plot(t, np.sin(t * (i + 1)), label=f"output {i}")
            ax.set_ylabel(f"rate {i} (rad/s)")
            ax.legend(loc="upper right")
        fig.suptitle("four panels")
        fig.text(0.01, 0.01, "a note in the corner", fontsize=7)
    return fig


def test_png_is_byte_for_byte_what_savefig_writes(tmp_path: Path) -> None:
    reference = _figure()
    FigureCanvasAgg(reference)
    reference.savefig(tmp_path / "savefig.png")
    save_figure(_figure(), tmp_path / "once.png")
    assert (tmp_path / "once.png").read_bytes() == (tmp_path / "savefig.png").read_bytes()


def test_other_save_settings_still_go_through_savefig(tmp_path: Path) -> None:
    with matplotlib.rc_context({"savefig.bbox": "tight", "savefig.dpi": 72}):
        reference = _figure()
        FigureCanvasAgg(reference)
        reference.savefig(tmp_path / "savefig.png")
        save_figure(_figure(), tmp_path / "once.png")
    written = (tmp_path / "once.png").read_bytes()
    assert written == (tmp_path / "savefig.png").read_bytes()
    plain = tmp_path / "plain.png"
    save_figure(_figure(), plain)
    assert plain.read_bytes() != written  # the settings did change the file
