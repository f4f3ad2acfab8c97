"""The one HTML page style of every report (identify, predict, gap, control, fleet).

A page is self-contained: its CSS is inline, the Bokeh library (when the page has interactive
plots) is inlined once in ``<head>``, static figures are data URIs. Nothing is fetched from
the network, so a report opens offline, from a mail attachment or a file share.
"""

from __future__ import annotations

import base64
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from etsid.errors import ReportError
from etsid.escape import for_html, printable
from etsid.files import read_bytes

CSS = (
    "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:76em;"
    "margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}"
    "h1{font-size:1.5em;margin-bottom:.3em}h2{font-size:1.2em;margin-top:1.6em;"
    "border-bottom:1px solid #ddd;padding-bottom:.2em}h3{font-size:1.05em}"
    "table{border-collapse:collapse;font-size:88%;margin:.5em 0}"
    "td,th{border:1px solid #ccc;padding:2px 7px;text-align:right;vertical-align:top}"
    "th{background:#f0f0f0}td:first-child,th:first-child{text-align:left}"
    "td.text,th.text{text-align:left;max-width:40em}"
    "img{max-width:100%}pre{background:#f6f6f6;padding:.6em;overflow-x:auto;font-size:85%;"
    "white-space:pre-wrap;word-break:break-word}"
    "figure{margin:1em 0}figcaption{font-size:90%;color:#444}"
    "p.lead{font-size:105%;background:#f4f8fc;border-left:4px solid #1f77b4;padding:.5em .8em}"
    "p.hint{font-size:88%;color:#555}details{margin:.8em 0}summary{cursor:pointer;"
    "font-weight:600}.plot{margin:.3em 0 1em 0}code{background:#f3f3f3;padding:0 .2em}"
)
"""The report style, shared by every page."""

HINT = ("Interactive plots: drag to pan along time, scroll to zoom time, box-zoom with the "
        "toolbar, hover for values, double-click or the reset tool to go back. Time axes of "
        "a section are linked.")


def esc(text: object) -> str:
    """``str(text)`` for HTML: control and bidi characters shown escaped (``\\xNN``),
    then HTML-escaped (:func:`etsid.escape.for_html`)."""
    return for_html(text)


def markdown_safe(text: str) -> str:
    """Markdown with raw HTML made inert: ``<`` and ``>`` outside code spans and fenced blocks
    become ``&lt;``/``&gt;`` (names from a log — topics, fields, files — can hold
    ``<script>``; a Markdown viewer renders raw HTML). Code keeps its characters. Control
    and bidi characters are shown escaped (``\\xNN``) everywhere (a newline from a file
    cannot start a line: it was escaped where the string entered)."""
    out, fenced = [], False
    for raw in text.replace("\r\n", "\n").split("\n"):
        line = printable(raw)
        if line.lstrip().startswith("```"):
            fenced = not fenced
            out.append(line)
            continue
        if fenced:
            out.append(line)
            continue
        parts = line.split("`")
        for i in range(0, len(parts), 2):  # even parts are outside code spans
            parts[i] = parts[i].replace("<", "&lt;").replace(">", "&gt;")
        out.append("`".join(parts))
    return "\n".join(out)


def table_html(head: Sequence[str], rows: Iterable[Sequence[object]],
               text_columns: Iterable[int] = ()) -> str:
    """An HTML table; cells of ``text_columns`` are left aligned prose."""
    text = set(text_columns)
    out = ["<table><tr>" + "".join(f'<th class="text">{esc(h)}</th>' if i in text
                                   else f"<th>{esc(h)}</th>" for i, h in enumerate(head))
           + "</tr>"]
    for row in rows:
        out.append("<tr>" + "".join(
            f'<td class="text">{esc(c)}</td>' if i in text else f"<td>{esc(c)}</td>"
            for i, c in enumerate(row)) + "</tr>")
    out.append("</table>")
    return "".join(out)


def image_html(path: Path, name: str, caption: str) -> str:
    """A static figure (PNG or SVG file) as an inline ``<figure>`` with a data URI."""
    mime = "image/svg+xml" if path.suffix == ".svg" else "image/png"
    data = base64.b64encode(read_bytes(path, "figure", ReportError)).decode()
    return (f'<figure id="{esc(name)}"><img alt="{esc(name)}" src="data:{mime};base64,{data}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def html_page(title: str, body: Iterable[str], bokeh_head: str = "") -> str:
    """A whole page: the shared style, ``bokeh_head`` (inlined library and plot script,
    see :func:`etsid.report.interactive.embed`) and the body parts."""
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{esc(title)}</title>", f"<style>{CSS}</style>", bokeh_head,
        "</head><body>", f"<h1>{esc(title)}</h1>", *body, "</body></html>", ""])


def make_shared_dir(path: Path) -> None:
    """Give a report directory the permissions the umask allows (``mkdtemp`` makes 0700)."""
    mask = os.umask(0)
    os.umask(mask)
    path.chmod(0o777 & ~mask)
