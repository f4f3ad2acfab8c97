"""Write docs/cli.md from the ``--help`` of every ``etsid`` command.

Run: ``python docs/make_cli_md.py`` (``--check`` exits 1 if docs/cli.md is out of date).
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from etsid.cli import cli

OUT = Path(__file__).with_name("cli.md")


def command_help(name: str | None, sub: str | None = None) -> str:
    """The ``--help`` text of ``etsid NAME [SUB]`` (of ``etsid`` itself for None)."""
    settings = {**cli.context_settings, "terminal_width": 88, "max_content_width": 88}
    with click.Context(cli, info_name="etsid", **settings) as root:
        if name is None:
            return cli.get_help(root)
        command = cli.get_command(root, name)
        with click.Context(command, info_name=name, parent=root) as ctx:
            if sub is None:
                return command.get_help(ctx)
            subcommand = command.get_command(ctx, sub)
            with click.Context(subcommand, info_name=sub, parent=ctx) as subctx:
                return subcommand.get_help(subctx)


def render() -> str:
    """docs/cli.md as text (every command, loaded first; a group's commands after it)."""
    parts = ["# Command-line reference", "",
             "Generated from `--help` by `docs/make_cli_md.py`; do not edit by hand.", "",
             "```", command_help(None), "```", ""]
    with click.Context(cli, info_name="etsid") as root:
        names = cli.list_commands(root)
        commands = {name: cli.get_command(root, name) for name in names}
    for name in sorted(commands):
        parts += [f"## etsid {name}", "", "```", command_help(name), "```", ""]
        group = commands[name]
        if isinstance(group, click.Group):
            for sub in sorted(group.commands):
                parts += [f"## etsid {name} {sub}", "", "```", command_help(name, sub),
                          "```", ""]
    return "\n".join(parts)


def main(argv: list[str]) -> int:
    """Write (or with ``--check`` compare) docs/cli.md."""
    text = render()
    if "--check" in argv:
        return 0 if OUT.exists() and OUT.read_text() == text else 1
    OUT.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
