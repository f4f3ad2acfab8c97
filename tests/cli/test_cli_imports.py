"""Commands import only what they use: ``etsid --help`` and every ``etsid COMMAND --help``
no science stack, ``etsid inspect`` no pandas/matplotlib (and no numba for formats read
without it, and for a tlog, ULog or DataFlash log small enough to walk without it,
:mod:`etsid.ingest.kernel_choice`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import click
import pytest

from etsid.cli import COMMAND_HELP, COMMAND_MODULES, cli

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "pandas", "numba", "scipy", "matplotlib", "pyarrow")


def _modules_after(args: list[str]) -> set[str]:
    """Top-level packages of HEAVY loaded after running ``etsid ARGS`` in a fresh process."""
    code = ("import sys, json\nfrom etsid.cli import main\nsys.argv = ['etsid'] + "
            f"{args!r}\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
            f"print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & {set(HEAVY)!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


def test_help_lists_every_command_with_its_own_help() -> None:
    assert set(COMMAND_HELP) == set(COMMAND_MODULES)
    ctx = click.Context(cli)
    for name in COMMAND_MODULES:
        command = cli.get_command(ctx, name)
        assert command is not None
        assert COMMAND_HELP[name] == command.get_short_help_str(limit=10**6), name


def test_help_imports_no_science_stack() -> None:
    assert _modules_after(["--help"]) == set()


@pytest.mark.parametrize(("log", "absent"), [
    ("sample_logs/hexa_ige_oge.tlog", {"pandas", "matplotlib", "pyarrow", "numba", "scipy"}),
    ("sample_logs/hexa_ige_oge.bag", {"pandas", "matplotlib", "pyarrow", "numba", "scipy"}),
    ("tests/data/px4_sitl_tagged.ulg", {"pandas", "matplotlib", "pyarrow", "numba", "scipy"}),
    ("tests/data/ardupilot_copter403_hexa_loiter_real.bin",
     {"pandas", "matplotlib", "pyarrow", "numba", "scipy"}),
])  # fmt: skip
def test_inspect_imports_no_table_or_plot_stack(log: str, absent: set[str]) -> None:
    loaded = _modules_after(["inspect", "--quiet", log])
    assert "numpy" in loaded  # the log was read
    assert not loaded & absent


def test_gap_help_imports_no_science_stack() -> None:
    """``etsid gap --help`` lists the vocabulary from the shipped schema, not by importing
    the analysis (it took 4 s when the help imported the effect registry)."""
    assert _modules_after(["gap", "--help"]) == set()


BATCH_COMMANDS = ("inspect", "ingest", "identify", "gap", "fit")
"""Subcommands of ``etsid batch``."""


@pytest.mark.parametrize("command", [*sorted(COMMAND_MODULES),
                                     *(f"batch {name}" for name in BATCH_COMMANDS)])
def test_every_command_help_imports_no_science_stack(command: str) -> None:
    """``etsid COMMAND --help`` takes its option choices and defaults from light modules
    (etsid.ident.choices, etsid.ets.params, …) and imports the science stack only when the
    command runs: identify's help took 3 s when it imported the eTS core for them."""
    assert _modules_after([*command.split(), "--help"]) == set()


def test_batch_subcommands_are_all_checked() -> None:
    ctx = click.Context(cli)
    batch = cli.get_command(ctx, "batch")
    assert isinstance(batch, click.Group)
    assert set(batch.list_commands(ctx)) == set(BATCH_COMMANDS)
