"""The ``etsid`` command: click commands only (parse, call one function, print).

Errors raised on purpose (:class:`~etsid.errors.EtsidError`) become one line on stderr and
exit code 1; click's usage errors exit 2. Set ``ETSID_DEBUG=1`` to see tracebacks.
"""

from __future__ import annotations

import os
import sys
from typing import Any

import click

from etsid import __version__
from etsid.errors import EtsidError


class EtsidGroup(click.Group):
    """Click group that turns etsid errors into one-line messages."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except EtsidError as err:
            if os.environ.get("ETSID_DEBUG"):
                raise
            click.echo(f"etsid: error: {one_line(err)}", err=True)
            ctx.exit(1)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except KeyboardInterrupt:
            click.echo("etsid: interrupted", err=True)
            ctx.exit(130)
        except Exception as err:
            if os.environ.get("ETSID_DEBUG"):
                raise
            click.echo(f"etsid: internal error: {type(err).__name__}: {one_line(err)} "
                       "(set ETSID_DEBUG=1 for a traceback and please report it)", err=True)
            ctx.exit(1)


def one_line(err: BaseException) -> str:
    """The first line of an error message."""
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


@click.group(cls=EtsidGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="etsid")
def cli() -> None:
    """Learn a drone's rate dynamics from its flight logs with evolving fuzzy models (eTS)."""


def _register() -> None:
    import importlib

    for name in ("ingest_cmds", "sim_cmds", "ident_cmds", "report_cmds"):
        try:
            module = importlib.import_module(f"etsid.cli.{name}")
        except ModuleNotFoundError as err:
            if err.name != f"etsid.cli.{name}":
                raise
            continue
        for command in module.COMMANDS:
            cli.add_command(command)


_register()


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="etsid")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
