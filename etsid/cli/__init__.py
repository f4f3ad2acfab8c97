"""The ``etsid`` command: click commands only (parse, call one function, print).

Errors raised on purpose (:class:`~etsid.errors.EtsidError`) become one line on stderr and
exit code 1; click's usage errors exit 2. Set ``ETSID_DEBUG=1`` to see tracebacks.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
from typing import Any

import click

from etsid import __version__
from etsid.errors import EtsidError

COMMAND_MODULES: dict[str, str] = {
    "inspect": "etsid.cli.ingest_cmds",
    "ingest": "etsid.cli.ingest_cmds",
    "simulate": "etsid.cli.sim_cmds",
    "identify": "etsid.cli.ident_cmds",
    "predict": "etsid.cli.ident_cmds",
    "rules": "etsid.cli.ident_cmds",
    "report": "etsid.cli.report_cmds",
    "gap": "etsid.cli.gap_cmds",
    "fit": "etsid.cli.fit_cmds",
    "batch": "etsid.cli.batch_cmds",
    "control": "etsid.cli.control_cmds",
}
"""Command name → module holding it (in its ``COMMANDS`` list); imported on first use so
that ``etsid inspect`` does not pay for matplotlib, scipy or numba."""

COMMAND_HELP: dict[str, str] = {
    "batch": "Run inspect, ingest, identify, gap or fit over many logs: a result row per log.",
    "control": "Fly SCENARIO with the vertical loop closed by CONTROLLER; write RUN_DIR and "
               "figures.",
    "fit": "Fit an airframe's physical parameters from its LOGS (flights of one airframe, "
           "pooled) and write them as a vehicle file the simulator flies.",
    "gap": "Locate where SIM_LOG and REAL_LOG disagree and name the physics SIM left out.",
    "identify": "Learn an eTS model of LOG (a flight log or a saved .parquet/.csv table).",
    "ingest": "Read LOG into a FlightTable (SI units, FRD body / NED world) and save it.",
    "inspect": "Show what a LOG holds: format, duration, topics/messages and the columns they "
               "fill.",
    "predict": "Apply a saved rule base to LOG: one-step and free-run predictions and metrics.",
    "report": "Write RUN_DIR/report/: an interactive, self-contained index.html (zoom, pan, "
              "linked time axes, hover values; works offline), report.md and static figures.",
    "rules": "Print the rule base in PATH (rules.json or a RUN_DIR) as readable IF … THEN … "
             "rules.",
    "simulate": "Fly SCENARIO with the hexacopter physics model and write it as a real flight "
                "log.",
}
"""Command name → its one-line help, for ``etsid --help`` without importing every command
module (tests/cli check it against the commands' own help)."""


class EtsidGroup(click.Group):
    """Click group that loads commands lazily and turns etsid errors into one-line messages."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(COMMAND_MODULES) | set(self.commands))

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list of ``--help`` from :data:`COMMAND_HELP` (no command imported)."""
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(name) for name in names)
        rows = []
        for name in names:
            if name in COMMAND_HELP:
                text = click.Command(name, help=COMMAND_HELP[name]).get_short_help_str(limit)
            else:  # a command added at run time
                text = self.commands[name].get_short_help_str(limit)
            rows.append((name, text))
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self.commands:
            return self.commands[cmd_name]
        module_name = COMMAND_MODULES.get(cmd_name)
        if module_name is None:
            return None
        from etsid.progress import stage

        with stage(f"{cmd_name}: loading"):  # numba, pandas, matplotlib: seconds on a cold start
            module = importlib.import_module(module_name)
        for command in module.COMMANDS:
            self.add_command(command)
        return self.commands.get(cmd_name)

    def main(self, *args: Any, **kwargs: Any) -> Any:
        from etsid import progress

        # what a long step is doing, on stderr (--quiet or ETSID_PROGRESS=off: nothing)
        progress.enable(os.environ.get("ETSID_PROGRESS", "").lower() != "off")
        try:
            return super().main(*args, **kwargs)
        finally:
            progress.enable(False)

    def invoke(self, ctx: click.Context) -> Any:
        from etsid.escape import TerminalStream

        streams = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = TerminalStream(sys.stdout), TerminalStream(sys.stderr)
        try:
            return self._invoke(ctx)
        finally:
            sys.stdout, sys.stderr = streams

    def _invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except EtsidError as err:
            if os.environ.get("ETSID_DEBUG"):
                raise
            click.echo(f"etsid: error: {one_line(err)}", err=True)
            ctx.exit(1)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
            # silence the flush of the rest at exit
            with contextlib.suppress(OSError, ValueError, AttributeError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            ctx.exit(0)
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
    """The first line of an error message, safe for a terminal (file names and strings from
    files in it shown with their control characters escaped)."""
    from etsid.escape import printable

    text = str(err).strip()
    if not text:
        return type(err).__name__
    line = printable(text.splitlines()[0])
    return line if len(line) <= MAX_LINE else f"{line[:MAX_LINE - 60]} … ({len(line)} characters)"


MAX_LINE = 1000
"""Longest error line printed (a message naming a 5000-character path is cut)."""


@click.group(cls=EtsidGroup, context_settings={"help_option_names": ["-h", "--help"]},
             invoke_without_command=True)
@click.version_option(__version__, prog_name="etsid")
@click.pass_context
def cli(ctx: click.Context) -> None:
    """Learn a drone's rate dynamics from its flight logs with evolving fuzzy models (eTS)."""
    if ctx.invoked_subcommand is None:  # plain `etsid`: the help, on stdout, exit 0
        click.echo(ctx.get_help())


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="etsid")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
