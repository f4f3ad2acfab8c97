"""``--set KEY=VALUE``: parse repeatable assignments into a ``{key: value}`` dict.

Values use TOML syntax (``1.1``, ``[0.02, 0, 0]``, ``true``, ``"text"``); a bare word that
is not valid TOML (``mahony``, ``chirp``) is taken as a string. The keys are checked by the
command that uses them (for ``etsid simulate``: :func:`etsid.sim.settings.split_settings`).
"""

from __future__ import annotations

import re
import tomllib
from typing import Any

import click

_BARE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")


def parse_value(text: str) -> Any:
    """TOML value of ``text``; a bare word is a string.

    >>> parse_value("1.5"), parse_value("[1, 2, 3]"), parse_value("true"), parse_value("mahony")
    (1.5, [1, 2, 3], True, 'mahony')
    """
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        if _BARE.match(text):
            return text
        raise ValueError(f"{text!r} is not a number, list, true/false or string") from None


def parse_assignments(items: tuple[str, ...] | list[str], option: str = "--set"
                      ) -> dict[str, Any]:
    """``["a.b=1", "c=[1,2]"]`` → ``{"a.b": 1, "c": [1, 2]}``; a repeated key: the last wins.

    Raises
    ------
    click.BadParameter
        An item without ``=`` or with an unreadable value (one line, exit code 2).
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise click.BadParameter(f"{item!r}: expected KEY=VALUE", param_hint=option)
        try:
            out[key] = parse_value(text.strip())
        except ValueError as err:
            raise click.BadParameter(f"{key}: {err}", param_hint=option) from None
    return out
