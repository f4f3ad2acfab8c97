"""Progress on stderr: long steps say what they do when not on a terminal, short ones do
not; simulate reports during the flight; identify's bar moves in small steps."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from etsid import progress
from etsid.cli import cli


@pytest.fixture
def fast_narrator(monkeypatch: pytest.MonkeyPatch) -> progress.Narrator:
    """The CLI's narrator, saying every step at once and again at every tick."""
    monkeypatch.setenv("ETSID_PROGRESS", "on")
    monkeypatch.setattr(progress, "TICK_S", 0.01)
    monkeypatch.setattr(progress.NARRATOR, "delay_s", 0.0)
    monkeypatch.setattr(progress.NARRATOR, "every_s", 0.0)
    return progress.NARRATOR


def test_a_step_is_said_only_when_it_lasts(capsys: pytest.CaptureFixture[str]) -> None:
    narrator = progress.Narrator(delay_s=0.4, every_s=0.5)
    progress.enable(True)
    try:
        narrator.say("short step")
        time.sleep(0.05)
        narrator.say("long step …")
        time.sleep(1.3)
        narrator.done()
        time.sleep(0.6)  # nothing more once done
    finally:
        progress.enable(False)
    lines = capsys.readouterr().err.splitlines()
    assert "short step" not in " ".join(lines)
    assert lines[0] == "long step …"
    assert len(lines) <= 3  # first at 0.4 s, repeats at 0.9 s and maybe 1.4 s
    assert all(re.fullmatch(r"long step … \(\d+ s\)", line) for line in lines[1:])


def test_library_calls_are_silent(capsys: pytest.CaptureFixture[str]) -> None:
    narrator = progress.Narrator(delay_s=0.0, every_s=0.0)
    narrator.say("step")
    time.sleep(0.4)
    narrator.done()
    assert capsys.readouterr().err == ""


def test_simulate_says_how_far_the_flight_is(fast_narrator: progress.Narrator,
                                             tmp_path: Path) -> None:
    out = tmp_path / "f.parquet"
    result = CliRunner().invoke(cli, ["simulate", "steps", "-o", str(out), "--duration", "12"])
    assert result.exit_code == 0, result.output
    shares = [int(m.group(1)) for m in re.finditer(
        r"simulating steps \(flight s\): (\d+) % \(\d+/12\)", result.stderr)]
    assert shares, result.stderr
    assert shares == sorted(shares) and shares[-1] <= 100
    assert result.stdout.startswith(f"{out}: steps, 12.0 s")  # stdout keeps the result


def test_the_flight_flown_in_pieces_is_the_same_flight(monkeypatch: pytest.MonkeyPatch) -> None:
    from etsid.sim import simulate

    whole = simulate("steps", duration=4.0, seed=5, rate_hz=200.0)
    progress.enable(True)
    try:
        pieces = simulate("steps", duration=4.0, seed=5, rate_hz=200.0)
    finally:
        progress.enable(False)
    assert whole.table.equals(pieces.table) and whole.truth.equals(pieces.truth)


def test_the_learning_bar_moves_in_small_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    """It used to jump 0 → 68 → 100 % (4096-sample pieces on a 6000-sample flight)."""
    from etsid.ets import ETS
    from etsid.ident import learn
    from etsid.ident.regressors import Regression

    steps: list[int] = []

    @contextmanager
    def recorder(total: int, label: str, enabled: bool) -> Iterator[progress.Progress]:
        class Bar(progress.Progress):
            def update(self, n: int, status: str | None = None) -> None:
                steps.append(n)
        yield Bar(None)

    monkeypatch.setattr(learn, "progress", recorder)
    n = 6000
    rng = np.random.default_rng(0)
    X = rng.standard_normal((n, 2))
    Y = X @ np.array([[0.5], [-0.2]]) + 0.01 * rng.standard_normal((n, 1))
    reg = Regression(X=X, Y=Y, rows=np.arange(n), t=np.arange(n) * 0.02)
    learn.learn_online(ETS(radius=0.5), reg, 4200, True, "identify")
    assert sum(steps) == n
    assert max(steps) <= 0.03 * n


def test_a_step_inside_another_gives_the_outer_one_back() -> None:
    """Reading a log: a bar over the bytes, then the rest of the reading is still said."""
    narrator = progress.NARRATOR
    progress.enable(True)
    try:
        with progress.stage("reading flight.bag"):
            assert narrator.current == "reading flight.bag"
            with progress.progress(10, "decoding", True) as bar:
                bar.update(10)
                assert narrator.current == "decoding: 100 % (10/10)"
            assert narrator.current == "reading flight.bag"
        assert narrator.current is None
    finally:
        progress.enable(False)


def test_a_cold_numba_compile_is_said_at_once(capsys: pytest.CaptureFixture[str],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A real compile (a kernel not in any cache) prints one line before it starts; the
    step around it is said again afterwards; a call that compiles nothing says nothing."""
    from numba import njit

    from etsid import jitnote

    monkeypatch.setitem(jitnote._state, "said", False)
    assert jitnote.install(progress.NARRATOR, progress.enabled)

    @njit
    def plus_one(x: float) -> float:
        return x + 1.0

    progress.enable(True)
    try:
        progress.NARRATOR.say("simulating")
        assert plus_one(1.0) == 2.0
        assert progress.NARRATOR.current == "simulating"
        first = capsys.readouterr().err
        assert plus_one(2.0) == 3.0  # compiled already: no event, no line
        assert plus_one(2) == 3.0  # a new signature compiles, but the cache note is said once
    finally:
        progress.enable(False)
    assert re.fullmatch(r"compiling numba kernels \(test_progress\.plus_one\); first run only, "
                        r"cached in .+ …\n", first), first
    assert capsys.readouterr().err == ""
