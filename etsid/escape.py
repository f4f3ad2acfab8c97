r"""One escaping path for every string that comes from a file.

Topic, field and unit names, warnings, vehicle names, table attrs, run and batch folders'
JSON and file names are made safe once, where they enter (:func:`clean` on what a reader
returns): control characters become ``\xNN`` and the bidirectional controls that reorder
text (U+202A–U+202E, U+2066–U+2069, U+200E/F, U+061C) become ``\uNNNN``, so no ESC
sequence (OSC 52 "write the clipboard", CSI) and no reordering reaches a terminal or page.

Each sink then escapes for itself: :func:`for_terminal` (the above, for text that did not
pass through :func:`clean`), :func:`for_html` (the above, line breaks kept, plus HTML
entities) and :func:`for_markdown` (HTML entities plus the Markdown table and emphasis
characters).
Bokeh pages pass strings as data columns, never inside tooltip templates (which Bokeh
renders as HTML): see etsid/report/interactive.py.

Standard library only.
"""

from __future__ import annotations

import html
import re
from typing import Any

_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028\u2029\u202a-\u202e"
                     "\u2066-\u2069]")


def _shown(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text: str) -> str:
    r"""``text`` with control characters shown as ``\xNN`` (``\uNNNN`` for bidi controls).

    >>> printable("/x\x1b]52;c;ZWNobw==\x07")
    '/x\\x1b]52;c;ZWNobw==\\x07'
    >>> printable("run\u202eexe.pdf")
    'run\\u202eexe.pdf'
    """
    return _UNSAFE.sub(_shown, text)


_PLAIN = {int, float, bool, type(None)}
"""Types :func:`clean` keeps as they are."""


def clean(value: Any) -> Any:
    r"""``value`` (a JSON-like document) with every string, keys too, made :func:`printable`.

    Iterative, so a deep document cannot exhaust the stack; non-string leaves are kept.

    >>> clean({"warnings": ["a\x1bb"], "n": 1})
    {'warnings': ['a\\x1bb'], 'n': 1}
    """
    if isinstance(value, str):
        return printable(value)
    if not isinstance(value, dict | list | tuple):
        return value
    root: list[Any] = [None]
    todo: list[tuple[Any, Any, Any]] = [(value, root, 0)]
    while todo:
        item, parent, slot = todo.pop()
        if isinstance(item, str):
            parent[slot] = printable(item)
        elif isinstance(item, dict):
            out: dict[Any, Any] = {}
            parent[slot] = out
            for key, child in item.items():
                name = printable(key) if isinstance(key, str) else key
                out[name] = None
                todo.append((child, out, name))
        elif isinstance(item, list | tuple):
            if set(map(type, item)) <= _PLAIN:  # numbers only (a matrix row): as they are
                parent[slot] = list(item)
                continue
            seq: list[Any] = [None] * len(item)
            parent[slot] = seq
            todo.extend((child, seq, i) for i, child in enumerate(item))
        else:
            parent[slot] = item
    return root[0]


_TERMINAL_UNSAFE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028"
                              "\u2029\u202a-\u202e\u2066-\u2069]")
CLEAR_LINE = "\r\x1b[K"
"""The one control sequence etsid itself writes to a terminal (the progress line)."""


def for_stream(text: str) -> str:
    """``text`` safe on a terminal, keeping newlines, tabs and :data:`CLEAR_LINE`."""
    return CLEAR_LINE.join(_TERMINAL_UNSAFE.sub(_shown, part)
                           for part in text.split(CLEAR_LINE))


class TerminalStream:
    """A text stream whose writes pass through :func:`for_stream`: file names and other
    strings from files printed by any command cannot write escape sequences (the CLI wraps
    stdout and stderr in it)."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        self._stream.write(for_stream(text))
        return len(text)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def for_terminal(text: object) -> str:
    """``str(text)`` safe to print on a terminal."""
    return printable(str(text))


def for_html(text: object) -> str:
    r"""``str(text)`` safe inside HTML text or a quoted attribute; line breaks and tabs are
    kept (etsid's own multi-line text in a ``<pre>``: a rule base, a run's config; a string
    from a file has its line breaks shown as ``\x0a`` by :func:`clean` already).

    >>> for_html('<b onclick="x">\u202e\n\x1b')
    '&lt;b onclick=&quot;x&quot;&gt;\\u202e\n\\x1b'
    """
    return html.escape(_TERMINAL_UNSAFE.sub(_shown, str(text)), quote=True)


_MD_SPECIAL = re.compile(r"([\\`*_\[\]|#])")


def for_markdown(text: object) -> str:
    r"""``str(text)`` shown literally in Markdown: HTML entities for ``< > &`` (raw HTML is
    live in most renderers) and a backslash before ``\ ` * _ [ ] | #``.

    >>> for_markdown("<img src=x onerror=alert(1)> | a*b")
    '&lt;img src=x onerror=alert(1)&gt; \\| a\\*b'
    """
    return _MD_SPECIAL.sub(r"\\\1", html.escape(printable(str(text)), quote=False))
